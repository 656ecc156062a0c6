//! The avatar locator (§4.3.1 of Prior-4D): the skinned avatar, posed in the acting camera's
//! frame (Eq. 3), is carried into the scene by `V_world = E^t · σ · V_cam` (Eq. 3′) with `E^t`
//! the (refined) acting camera's camera-to-world transform and `σ = exp(s)` the global scale.
//!
//! Radii scale with σ as well (spec, Eq. 3′: our choice): scaling the camera-space avatar and its
//! radii about the camera centre leaves its image at that camera unchanged (App. A), so the
//! photometric and normal losses cannot see σ; only occlusion by the scene and the contact loss
//! (Eq. 7) can. Avatar Gaussians are isotropic solid spheres: one radius, the mean of the node's
//! three log-scales, and opacity fixed near 1.

use crate::camera::{RigidFrame, splats_to_world};
use burn::tensor::Tensor;
use splatzoo_rasterizer::Splats;

/// Opacity logit of the avatar's "solid spheres": sigmoid(9.2) ≈ 0.9999 (the rasterizer caps
/// per-splat α at 0.99).
pub const SOLID_OPACITY_LOGIT: f32 = 9.2;

/// The avatar's splats as isotropic opaque spheres: one log-radius per Gaussian (the mean of
/// its three log-scales), identity rotations, opacity [`SOLID_OPACITY_LOGIT`].
pub fn solid_spheres(splats: Splats) -> Splats {
    let n = splats.len();
    let device = splats.means.device();
    let log_radius = splats.log_scales.mean_dim(1); // [N, 1]
    Splats {
        log_scales: log_radius.expand([n, 3]),
        quats: Tensor::<2>::from_floats([[1.0, 0.0, 0.0, 0.0]], &device).expand([n, 4]),
        opacity_logits: Tensor::<1>::full([n], SOLID_OPACITY_LOGIT, &device),
        ..splats
    }
}

/// Eq. 3′: camera-space avatar splats → world, `x ↦ R (σ x) + c`, radii `× σ`, rotations by
/// `R`, with `log_sigma = s` `[1]` and `camera` the acting camera of the frame.
pub fn place(camera_space: Splats, log_sigma: Tensor<1>, camera: &RigidFrame) -> Splats {
    let sigma = log_sigma.clone().exp().reshape([1, 1]);
    let scaled = Splats {
        means: camera_space.means * sigma,
        log_scales: camera_space.log_scales + log_sigma.reshape([1, 1]),
        ..camera_space
    };
    splats_to_world(&scaled, camera)
}
