//! A generated avatar as a scene node: the Gaussians the network decoded for one subject, posed
//! on its mesh. The node has no learnables of its own (the generator network is the method's),
//! so its lifecycle is rendering only; training and evaluation both render through the graph.

use splatzoo_rasterizer::Splats;
use splatzoo_train::scene::{FrameContext, FrameQuery, NodeOutput, SceneNode};

pub struct GeneratedAvatar {
    splats: Splats,
}

impl GeneratedAvatar {
    /// The node over `splats` (autodiff tensors while training: gradients reach the network).
    pub fn new(splats: Splats) -> Self {
        Self { splats }
    }
}

impl SceneNode for GeneratedAvatar {
    fn name(&self) -> &str {
        "avatar"
    }

    fn gaussians(&self) -> usize {
        self.splats.len()
    }

    fn render(&self, _query: &FrameQuery, _context: &FrameContext) -> NodeOutput {
        NodeOutput::splats(self.splats.clone())
    }
}
