//! One frame of the scene and the avatar rendered in one rasterizer call as seven feature
//! channels `[rgb(3), normal(3), avatar(1)]`: the composite image (Eq. 4), the avatar's
//! alpha-blended normal map (Eq. 5) and the visible avatar's alpha, together.
//!
//! Everything is rendered as features from the rendering camera's own frame
//! ([`crate::camera::splats_in_frame`]), so a refined camera gets gradients. The scene's
//! colours are therefore evaluated here, in the world frame, from its SH coefficients along
//! `x − c'` (the op's built-in SH would use camera-frame directions against world-frame
//! coefficients, wrong for degree ≥ 1). Avatar splats carry their RGB, their unit normal rotated
//! into the rendering camera's frame (OpenCV axes: a normal facing the camera has `n_z < 0`)
//! and an indicator 1; scene splats carry zero normal and indicator, so the scene still
//! occludes the avatar in both maps. `N̂` is not normalised (spec, Eq. 5: our choice): partial
//! coverage shortens it, and the L1 term of Eq. 6 sees that.

use crate::camera::{RigidFrame, camera_at_origin, splats_in_frame};
use burn::tensor::Tensor;
use splatzoo_rasterizer::sh::{SH_C0, sh_colour};
use splatzoo_rasterizer::{ColorMode, RasterError, RasterSettings, Render, Splats, rasterize};
use splatzoo_train::scene::concatenate;

/// Feature channels per splat.
pub const CHANNELS: usize = 7;

/// The scene prior's splats in the world, with SH colours of `degree`.
pub struct SceneSplats<'a> {
    pub splats: &'a Splats,
    pub degree: u32,
}

/// The placed avatar: world splats whose colour table's first coefficient is the RGB's SH DC
/// term, and each splat's unit normal in the world `[G, 3]`.
pub struct AvatarSplats {
    pub splats: Splats,
    pub normals: Tensor<2>,
}

/// What one render yields.
pub struct Layers {
    /// `[H, W, 3]` colour over the background.
    pub color: Tensor<3>,
    /// `[H, W, 3]` the avatar's blended normals in the rendering camera's frame (zero where the
    /// scene or nothing is in front).
    pub normal: Tensor<3>,
    /// `[H, W]` the visible avatar's accumulated alpha.
    pub avatar_alpha: Tensor<2>,
    /// `[H, W]` everything's accumulated alpha.
    pub alpha: Tensor<2>,
    pub render: Render,
}

/// RGB `[N, 3]` from the DC coefficient of an SH table `[N, K, 3]`, as the rasterizer reads it.
pub fn dc_rgb(colors: &Tensor<3>) -> Tensor<2> {
    let [n, _, _] = colors.dims();
    (colors.clone().slice([0..n, 0..1, 0..3]).reshape([n, 3]) * SH_C0)
        .add_scalar(0.5)
        .clamp_min(0.0)
}

fn features(rgb: Tensor<2>, normal: Tensor<2>, indicator: Tensor<2>) -> Tensor<3> {
    let n = rgb.dims()[0];
    Tensor::cat(vec![rgb, normal, indicator], 1).reshape([n, 1, CHANNELS])
}

/// Renders `scene` and/or `avatar` from `view` (the rendering camera's camera-to-world pose,
/// refined or not) with `settings`' intrinsics and raster options, over the RGB `background`.
pub fn render_layers(
    scene: Option<&SceneSplats>,
    avatar: Option<&AvatarSplats>,
    view: &RigidFrame,
    settings: &RasterSettings,
    background: [f32; 3],
) -> Result<Layers, RasterError> {
    let mut parts = Vec::new();
    if let Some(scene) = scene {
        let s = scene.splats;
        let n = s.len();
        let device = s.means.device();
        let directions = s.means.clone() - view.centre.clone().reshape([1, 3]);
        let length = (directions.clone().powi_scalar(2).sum_dim(1) + 1e-20).sqrt();
        let rgb = sh_colour(s.colors.clone(), directions / length, scene.degree);
        let colors = features(
            rgb,
            Tensor::zeros([n, 3], &device),
            Tensor::zeros([n, 1], &device),
        );
        parts.push(Splats {
            colors,
            ..s.clone()
        });
    }
    if let Some(avatar) = avatar {
        let s = &avatar.splats;
        let n = s.len();
        let device = s.means.device();
        let colors = features(
            dc_rgb(&s.colors),
            view.rotate_to_local(avatar.normals.clone()),
            Tensor::ones([n, 1], &device),
        );
        parts.push(Splats {
            colors,
            ..s.clone()
        });
    }
    if parts.is_empty() {
        return Err(RasterError::Value {
            name: "splats",
            problem: "neither a scene nor an avatar to render".into(),
        });
    }
    let device = view.centre.device();
    let splats = splats_in_frame(&concatenate(parts), view);
    let settings = RasterSettings {
        camera: camera_at_origin(&settings.camera),
        color: ColorMode::Features,
        ..*settings
    };
    let [r, g, b] = background;
    let background = Tensor::<1>::from_floats([r, g, b, 0.0, 0.0, 0.0, 0.0], &device);
    let render = rasterize(&splats, background, &settings)?;
    let [h, w, _] = render.color.dims();
    let channels = |range: std::ops::Range<usize>| render.color.clone().slice([0..h, 0..w, range]);
    Ok(Layers {
        color: channels(0..3),
        normal: channels(3..6),
        avatar_alpha: channels(6..7).reshape([h, w]),
        alpha: render.alpha.clone(),
        render,
    })
}
