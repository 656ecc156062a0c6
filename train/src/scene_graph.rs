//! Scene graphs: a frame is rendered from a list of nodes (a static background; later
//! SMPL-driven humans, deformable accessories, rigid objects), each producing its posed
//! Gaussians for a camera and time. The nodes' Gaussians are concatenated and rendered in one
//! call of the rasterizer op, so they occlude each other correctly and share one backward pass.
//! A scene holds only the nodes it needs; `train-3dgs` is the one-node case.

use crate::gaussians::GaussianSet;
use burn::tensor::Tensor;
use splatzoo_rasterizer::{Camera, RasterError, RasterSettings, Render, Splats, rasterize};
use std::ops::Range;

/// What a node is asked for: the view and the moment.
#[derive(Debug, Clone, Copy)]
pub struct FrameQuery<'a> {
    pub camera: &'a Camera,
    /// Frame index in the sequence (0 for static scenes).
    pub frame: usize,
    /// Seconds since the start of the sequence.
    pub time: f64,
}

/// One part of a scene.
pub trait SceneNode {
    fn name(&self) -> &str;
    /// The node's Gaussians in world space for `query` (autodiff tensors while training).
    fn splats(&self, query: &FrameQuery) -> Splats;
}

/// Gaussians that do not move: the background scene, or the scene prior of later methods.
pub struct StaticNode {
    pub name: String,
    pub gaussians: GaussianSet,
}

impl SceneNode for StaticNode {
    fn name(&self) -> &str {
        &self.name
    }

    fn splats(&self, _query: &FrameQuery) -> Splats {
        self.gaussians.splats()
    }
}

/// A render of a whole graph, with each node's rows in the concatenated splat list (for
/// per-node statistics such as density control).
pub struct GraphRender {
    pub render: Render,
    /// `rows[k]`: node k's rows in `render.radii` and `render.screen_offsets`.
    pub rows: Vec<Range<usize>>,
}

#[derive(Default)]
pub struct SceneGraph {
    pub nodes: Vec<Box<dyn SceneNode>>,
}

impl SceneGraph {
    pub fn new() -> Self {
        Self::default()
    }

    pub fn with(mut self, node: impl SceneNode + 'static) -> Self {
        self.nodes.push(Box::new(node));
        self
    }

    /// Renders every node for `query` in one rasterizer call over `background`.
    pub fn render(
        &self,
        query: &FrameQuery,
        background: Tensor<1>,
        settings: &RasterSettings,
    ) -> Result<GraphRender, RasterError> {
        let parts: Vec<Splats> = self.nodes.iter().map(|n| n.splats(query)).collect();
        let mut rows = Vec::with_capacity(parts.len());
        let mut start = 0;
        for p in &parts {
            rows.push(start..start + p.len());
            start += p.len();
        }
        let splats = concatenate(parts);
        Ok(GraphRender {
            render: rasterize(&splats, background, settings)?,
            rows,
        })
    }
}

/// Concatenates splat lists; colour tables with fewer coefficients (say, a DC-only human next
/// to a degree-3 background) are padded with zero coefficients, which leaves their colour
/// unchanged.
pub fn concatenate(mut parts: Vec<Splats>) -> Splats {
    assert!(!parts.is_empty(), "a scene graph needs at least one node");
    if parts.len() == 1 {
        return parts.pop().expect("one part");
    }
    let coefficients = parts
        .iter()
        .map(|p| p.colors.dims()[1])
        .max()
        .expect("non-empty");
    let channels = parts[0].colors.dims()[2];
    let colors = parts
        .iter()
        .map(|p| {
            let [n, k, c] = p.colors.dims();
            assert_eq!(c, channels, "every node renders the same colour channels");
            if k == coefficients {
                p.colors.clone()
            } else {
                let pad = Tensor::<3>::zeros([n, coefficients - k, c], &p.colors.device());
                Tensor::cat(vec![p.colors.clone(), pad], 1)
            }
        })
        .collect();
    Splats {
        means: Tensor::cat(parts.iter().map(|p| p.means.clone()).collect(), 0),
        quats: Tensor::cat(parts.iter().map(|p| p.quats.clone()).collect(), 0),
        log_scales: Tensor::cat(parts.iter().map(|p| p.log_scales.clone()).collect(), 0),
        opacity_logits: Tensor::cat(parts.iter().map(|p| p.opacity_logits.clone()).collect(), 0),
        colors: Tensor::cat(colors, 0),
    }
}
