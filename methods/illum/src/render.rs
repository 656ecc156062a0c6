//! One frame of Illum's scene and human in one rasterizer call (§3, "splatted together"), as
//! [`CHANNELS`] feature channels: `[rgb(3), metallic/roughness(2), albedo(3), normal(3),
//! human(1), ao(1)]`.
//!
//! - Scene Gaussians: colour `ao · max(SH(d) + 0.5, 0)` (Eq. 9 as the spec reads it: the SH is
//!   evaluated here in Burn ops along `d = x − camera centre`, then darkened), zero in the
//!   material, albedo, normal and human channels, and their `ao` in the last one, so a render
//!   shows where the decoder casts shadow.
//! - Human Gaussians: their shaded sRGB colour (Eq. 7, [`crate::lighting::shade_gaussians`]),
//!   `[m, r]`, albedo, world normal, indicator 1 and `ao = 1`.
//!
//! The human's maps are read where the human is in front: the scene still occludes them, and
//! their losses (Eq. 11) mask by the human channel. Depth comes from the same call.

use crate::IllumError;
use burn::tensor::Tensor;
use splatzoo_rasterizer::sh::sh_colour;
use splatzoo_rasterizer::{ColorMode, RasterSettings, Render, Splats, rasterize};
use splatzoo_train::scene::concatenate;

/// Feature channels per splat.
pub const CHANNELS: usize = 13;

/// The static scene's Gaussians (SH colours of `degree`) and their occlusion `[M]` (Eq. 8;
/// `None`: no shadow module, `ao ≡ 1`).
pub struct SceneLayer<'a> {
    pub splats: &'a Splats,
    pub degree: u32,
    pub ao: Option<Tensor<1>>,
}

/// The human's Gaussians (geometry; their colour table is ignored) and per-Gaussian channels.
pub struct HumanLayer<'a> {
    pub splats: &'a Splats,
    /// `[N, 3]` shaded sRGB colour.
    pub colour: Tensor<2>,
    /// `[N, 2]` metallic and roughness.
    pub material: Tensor<2>,
    /// `[N, 3]` linear albedo.
    pub albedo: Tensor<2>,
    /// `[N, 3]` world normals.
    pub normals: Tensor<2>,
}

/// The maps of one joint render.
pub struct JointMaps {
    /// `[H, W, 3]` colour over the background.
    pub colour: Tensor<3>,
    /// `[H, W, 2]` metallic and roughness (human only).
    pub material: Tensor<3>,
    /// `[H, W, 3]` albedo (human only).
    pub albedo: Tensor<3>,
    /// `[H, W, 3]` blended world normals (human only).
    pub normal: Tensor<3>,
    /// `[H, W]` the visible human's accumulated alpha.
    pub human_alpha: Tensor<2>,
    /// `[H, W]` blended scene occlusion (1 where the human's Gaussians or unshadowed scene
    /// lie in front; the background contributes 0).
    pub ao: Tensor<2>,
    /// The raw render (alpha, depth, screen offsets for density control).
    pub render: Render,
}

/// Renders `scene` and/or `human` with `settings`' camera over the RGB `background`.
pub fn render_joint(
    scene: Option<SceneLayer>,
    human: Option<HumanLayer>,
    settings: &RasterSettings,
    background: [f32; 3],
) -> Result<JointMaps, IllumError> {
    let mut parts = Vec::new();
    let mut device = None;
    if let Some(scene) = scene {
        let s = scene.splats;
        let m = s.len();
        let d = s.means.device();
        let centre = Tensor::<2>::from_floats([settings.camera.position()], &d);
        let directions = s.means.clone() - centre;
        let length = (directions.clone().powi_scalar(2).sum_dim(1) + 1e-20).sqrt();
        let rgb = sh_colour(s.colors.clone(), directions / length, scene.degree);
        let ao = match scene.ao {
            Some(ao) => {
                assert_eq!(ao.dims(), [m], "scene ao must be [{m}]");
                ao.reshape([m, 1])
            }
            None => Tensor::ones([m, 1], &d),
        };
        let colors = Tensor::cat(vec![rgb * ao.clone(), Tensor::zeros([m, 9], &d), ao], 1)
            .reshape([m, 1, CHANNELS]);
        parts.push(Splats {
            colors,
            ..s.clone()
        });
        device = Some(d);
    }
    if let Some(human) = human {
        let s = human.splats;
        let n = s.len();
        let d = s.means.device();
        for (name, t, width) in [
            ("colour", &human.colour, 3),
            ("material", &human.material, 2),
            ("albedo", &human.albedo, 3),
            ("normals", &human.normals, 3),
        ] {
            assert_eq!(t.dims(), [n, width], "human {name} must be [{n}, {width}]");
        }
        let colors = Tensor::cat(
            vec![
                human.colour,
                human.material,
                human.albedo,
                human.normals,
                Tensor::ones([n, 2], &d),
            ],
            1,
        )
        .reshape([n, 1, CHANNELS]);
        parts.push(Splats {
            colors,
            ..s.clone()
        });
        device = Some(d);
    }
    let Some(device) = device else {
        return Err(IllumError::input(
            "joint render",
            "neither a scene nor a human to render",
        ));
    };
    let settings = RasterSettings {
        color: ColorMode::Features,
        ..*settings
    };
    let mut fill = [0.0f32; CHANNELS];
    fill[..3].copy_from_slice(&background);
    let background = Tensor::<1>::from_floats(fill, &device);
    let render = rasterize(&concatenate(parts), background, &settings)?;
    let [h, w, _] = render.color.dims();
    let channels = |range: std::ops::Range<usize>| render.color.clone().slice([0..h, 0..w, range]);
    Ok(JointMaps {
        colour: channels(0..3),
        material: channels(3..5),
        albedo: channels(5..8),
        normal: channels(8..11),
        human_alpha: channels(11..12).reshape([h, w]),
        ao: channels(12..13).reshape([h, w]),
        render,
    })
}
