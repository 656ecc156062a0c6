//! Stage 1's human objective (§3.1): the refined body's face Gaussians, posed by the frame's
//! body parameters, rendered alone over a background and compared with the frame's person
//! pixels composited on the same background (L_human of Eq. 10, without its perceptual term),
//! plus the mesh regulariser L_mesh (stage 1 only, the paper) and L_scale (Eq. 15's λ_4 term).
//!
//! - Image: `0.8 L1 + 0.2 (1 − SSIM)` of the render against `I·M + b(1 − M)` (HUGS' mix; its
//!   LPIPS-VGG term needs user weights and is left to the trainer).
//! - L_mesh: the uniform Laplacian energy of the refined canonical mesh `v + F_Δ(v)`.
//! - L_scale: the mean of `relu(max_axis σ − 0.02·H)` over the Gaussians (the spec's form; the
//!   paper gives none).
//!
//! F_c's colours are display (sRGB) colours in stage 1; stage 2 starts its linear albedo from
//! `sRGB⁻¹(c)`.

use crate::IllumError;
use crate::human::{BodyMesh, RefinedBody, pose_refined};
use burn::tensor::Tensor;
use burn::tensor::activation::relu;
use splatzoo_models::body::Posed;
use splatzoo_models::laplacian::UniformLaplacian;
use splatzoo_models::networks::hash_grid::HashQueries;
use splatzoo_rasterizer::{ColorMode, RasterSettings, Render, Splats, rasterize};
use splatzoo_train::loss::photometric;

/// Stage 1's loss weights.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Stage1Weights {
    /// λ of the D-SSIM term within the image loss.
    pub ssim: f64,
    /// L_mesh (iHuman's mesh weight).
    pub mesh: f64,
    /// L_scale (IRAGA's `lambda_scaling`).
    pub scale: f64,
    /// The largest σ L_scale leaves free, as a fraction of the body height.
    pub max_scale: f64,
}

impl Default for Stage1Weights {
    fn default() -> Self {
        Self {
            ssim: 0.2,
            mesh: 0.01,
            scale: 10.0,
            max_scale: 0.02,
        }
    }
}

/// One training view of the person: camera and raster options, the sRGB image `[H, W, 3]`,
/// the person mask `[H, W]`, and the background to composite on.
pub struct HumanView<'a> {
    pub settings: &'a RasterSettings,
    pub image: Tensor<3>,
    pub mask: Tensor<2>,
    pub background: [f32; 3],
}

/// Each term, and their weighted sum.
pub struct Stage1Terms {
    pub image: Tensor<1>,
    pub mesh: Tensor<1>,
    pub scale: Tensor<1>,
    pub total: Tensor<1>,
    pub render: Render,
    /// The posed face Gaussians rendered (the joint render of the trainer reuses them).
    pub splats: Splats,
}

/// Stage 1's loss for one view of the body posed as `posed` (a batch of one, from the
/// subdivided model `mesh` was built on), with `queries` the fixed hash queries of its
/// template and `laplacian` its Laplacian.
pub fn stage1_terms(
    body: &RefinedBody,
    mesh: &BodyMesh,
    laplacian: &UniformLaplacian,
    queries: &HashQueries,
    posed: &Posed,
    view: HumanView,
    weights: &Stage1Weights,
) -> Result<Stage1Terms, IllumError> {
    let v = mesh.vertex_count();
    let [batch, rows, _] = posed.vertices.dims();
    if batch != 1 || rows != v {
        return Err(IllumError::input(
            "posed body",
            format!("expected one pose of {v} vertices, got [{batch}, {rows}, 3]"),
        ));
    }
    let device = posed.vertices.device();
    let offsets = body.offsets(queries);
    let refined = (mesh.template(&device) + offsets.clone()).reshape([1, v, 3]);
    let placed = pose_refined(posed, offsets).reshape([v, 3]);
    let splats = body.face_splats(mesh, placed, body.vertex_colours(queries));
    let settings = RasterSettings {
        color: ColorMode::Features,
        ..*view.settings
    };
    let background = Tensor::<1>::from_floats(view.background, &device);
    let render = rasterize(&splats, background.clone(), &settings)?;
    let [h, w, _] = render.color.dims();
    let mask = view.mask.reshape([h, w, 1]);
    let target = view.image * mask.clone() + background.reshape([1, 1, 3]) * (mask.neg() + 1.0);
    let image = photometric(render.color.clone(), target, weights.ssim);
    let mesh_term = laplacian.energy(refined);
    let largest = splats.log_scales.clone().exp().max_dim(1);
    let scale = relu(largest - weights.max_scale * mesh.height).mean();
    let total = image.clone() + mesh_term.clone() * weights.mesh + scale.clone() * weights.scale;
    Ok(Stage1Terms {
        image,
        mesh: mesh_term,
        scale,
        total,
        render,
        splats,
    })
}
