//! The avatar (§3.2 of Prior-4D, ExAvatar's representation in the spec's `free` variant): one
//! opaque isotropic RGB Gaussian per vertex of the built-in body subdivided
//! `avatar.subdivisions` times, on the engine's skinned node (canonical centres, log-radii and
//! colours its own learnables; pose and shape refined per frame), and everything one frame of it
//! needs to be rendered: the posed splats as solid spheres and the posed mesh's vertex normals
//! (Eq. 5), in the frame the node's body track lives in.

use crate::render::AvatarSplats;
use burn::tensor::Tensor;
use splatzoo_models::anchor::subdivide;
use splatzoo_models::body::{BodyModel, builtin_body};
use splatzoo_models::normals::vertex_normals;
use splatzoo_rasterizer::Camera;
use splatzoo_train::scene::{FrameContext, FrameQuery, SceneNode, SkinnedGaussianNode};

/// The built-in body subdivided `levels` times (one Gaussian per vertex).
pub fn avatar_model(levels: usize) -> BodyModel {
    let mut model = builtin_body().model.clone();
    for _ in 0..levels {
        model = subdivide(&model).0;
    }
    model
}

/// The avatar at `frame`: solid spheres and unit vertex normals in the node's frame (the
/// scan's world in stage B, the acting camera's frame in stage D). The step's leaves inside a
/// step. `faces` are the avatar model's.
pub fn posed_avatar(
    node: &SkinnedGaussianNode,
    frame: usize,
    camera: &Camera,
    faces: &[u32],
) -> AvatarSplats {
    let query = FrameQuery {
        camera,
        frame,
        time: 0.0,
    };
    let splats = node.render(&query, &FrameContext { outputs: &[] }).splats;
    let g = splats.len();
    let normals = vertex_normals(splats.means.clone().reshape([1, g, 3]), faces).reshape([g, 3]);
    AvatarSplats {
        splats: crate::locate::solid_spheres(splats),
        normals,
    }
}

/// The canonical avatar's colours `[G, 3]` (RGB of the SH DC term) and log-radii `[G]` (the
/// mean of the three log-scales) — the step's leaves inside a step.
pub fn canonical_appearance(node: &SkinnedGaussianNode) -> (Tensor<2>, Tensor<1>) {
    let set = node
        .canonical_leaves()
        .cloned()
        .unwrap_or_else(|| node.canonical_set().clone());
    let g = set.len();
    let rgb = crate::render::dc_rgb(&set.sh_dc);
    let log_radii = set.log_scales.mean_dim(1).reshape([g]);
    (rgb, log_radii)
}
