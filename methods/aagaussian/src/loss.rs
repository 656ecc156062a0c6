//! The render as the model's inputs (Eq. 3–4 of AAGaussian) and the sparsity term (U4):
//!
//! - RGB branch: the `[B, H, W, 3]` renders as `[B, 3, H, W]` mapped from [0, 1] to [−1, 1]
//!   (a pixel-space model's input; a latent model's codec takes this image).
//! - Depth branch (Eq. 4): the accumulated depth `Σ_i d_i σ_i Π_{j<i}(1 − σ_j)` normalised by
//!   its image's min and max (background 0 included, as HumanGaussian), min and max detached
//!   (A17: no single-pixel gradient spikes), mapped to [−1, 1].
//! - U4: `mean_p √(d̂(p)² + 0.01)`, `d̂ = d_acc / (max_batch d_acc + 1e-5)` (HumanGaussian's
//!   "opacity" term; the max detached), or the same on the render's alpha (`alpha` variant).

use burn::tensor::Tensor;
use serde::{Deserialize, Serialize};
use splatzoo_rasterizer::Render;

/// What U4 penalises.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum SparsityKind {
    /// Accumulated depth over its batch max (HumanGaussian).
    Depth,
    /// The render's alpha.
    Alpha,
}

/// `[B, 3, H, W]` in [−1, 1] from the renders' colours.
pub fn rgb_branch(renders: &[Render]) -> Tensor<4> {
    let images: Vec<Tensor<3>> = renders
        .iter()
        .map(|r| {
            r.color
                .clone()
                .permute([2, 0, 1])
                .mul_scalar(2.0)
                .sub_scalar(1.0)
        })
        .collect();
    Tensor::stack(images, 0)
}

/// One image's accumulated depth `[H, W]` min–max normalised (detached bounds) to [0, 1].
pub fn normalise_depth(depth: Tensor<2>) -> Tensor<2> {
    let lo = depth.clone().detach().min().reshape([1, 1]);
    let hi = depth.clone().detach().max().reshape([1, 1]);
    let range = (hi - lo.clone()).clamp_min(1e-8);
    (depth - lo) / range
}

/// `[B, 1, H, W]` in [−1, 1] from the renders' accumulated depth (Eq. 4).
pub fn depth_branch(renders: &[Render]) -> Tensor<4> {
    let images: Vec<Tensor<3>> = renders
        .iter()
        .map(|r| {
            normalise_depth(r.accumulated_depth.clone())
                .mul_scalar(2.0)
                .sub_scalar(1.0)
                .unsqueeze_dim(0)
        })
        .collect();
    Tensor::stack(images, 0)
}

/// U4 over a batch of renders.
pub fn sparsity(renders: &[Render], kind: SparsityKind) -> Tensor<1> {
    let maps: Vec<Tensor<2>> = renders
        .iter()
        .map(|r| match kind {
            SparsityKind::Depth => r.accumulated_depth.clone(),
            SparsityKind::Alpha => r.alpha.clone(),
        })
        .collect();
    let stacked = Tensor::stack::<3>(maps, 0);
    let normalised = match kind {
        SparsityKind::Depth => {
            let top = stacked
                .clone()
                .detach()
                .max()
                .reshape([1, 1, 1])
                .add_scalar(1e-5);
            stacked / top
        }
        SparsityKind::Alpha => stacked,
    };
    normalised.powi_scalar(2).add_scalar(0.01).sqrt().mean()
}
