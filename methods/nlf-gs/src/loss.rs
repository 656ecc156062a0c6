//! NLF-GS's training objective (Eq. 5–7 of NLF-GS):
//! `L = λ_rec L_rec + λ_sil L_sil + λ_reg L_reg`, with `L_rec = λ_l1 L1 + λ_ssim (1 − SSIM) +
//! λ_perc L_perc` and `L_reg = λ_scale L_scale + λ_Δx L_Δx + λ_α L_α`.
//!
//! The paper gives `λ_l1 = 0.5`, `λ_sil = 0.1`, `λ_scale = 0.01`, `λ_Δx = 0.01`,
//! `λ_α = 0.005`; it does not give `λ_ssim` or `λ_perc`, which default here to 0.2 and 0.1.
//! Terms: `L_perc` is [`intensity_gradient`]; `L_scale` the mean Gaussian scale (discourages
//! over-expanded Gaussians), `L_Δx` the mean squared anchor offset, `L_α` the mean transparency
//! `1 − α` (a prior towards solid foreground coverage).

use burn::tensor::Tensor;
use burn::tensor::activation::sigmoid;
use serde::{Deserialize, Serialize};
use splatzoo_train::loss::{l1, silhouette, ssim};

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NlfLossWeights {
    pub reconstruction: f64,
    pub l1: f64,
    pub ssim: f64,
    pub perceptual: f64,
    pub silhouette: f64,
    pub regularisation: f64,
    pub scale: f64,
    pub offset: f64,
    pub opacity: f64,
}

impl Default for NlfLossWeights {
    fn default() -> Self {
        Self {
            reconstruction: 1.0,
            l1: 0.5,
            ssim: 0.2,
            perceptual: 0.1,
            silhouette: 0.1,
            regularisation: 1.0,
            scale: 0.01,
            offset: 0.01,
            opacity: 0.005,
        }
    }
}

/// What the loss sees of one rendered target view and the predicted Gaussians.
pub struct NlfLossInputs {
    /// `[H, W, 3]` render and ground truth.
    pub image: Tensor<3>,
    pub target: Tensor<3>,
    /// `[H, W]` rendered alpha and ground-truth mask.
    pub alpha: Tensor<2>,
    pub mask: Tensor<2>,
    /// `[N, 3]`, `[N, 3]`, `[N]`.
    pub log_scales: Tensor<2>,
    pub offsets: Tensor<2>,
    pub opacity_logits: Tensor<1>,
}

/// The terms and their weighted total.
pub struct NlfLoss {
    pub total: Tensor<1>,
    pub l1: Tensor<1>,
    pub ssim: Tensor<1>,
    pub perceptual: Tensor<1>,
    pub silhouette: Tensor<1>,
    pub scale: Tensor<1>,
    pub offset: Tensor<1>,
    pub opacity: Tensor<1>,
}

/// Eq. 5–7 of NLF-GS.
pub fn nlf_loss(x: NlfLossInputs, w: &NlfLossWeights) -> NlfLoss {
    let l1_term = l1(x.image.clone(), x.target.clone());
    let ssim_term = -ssim(x.image.clone(), x.target.clone()) + 1.0;
    let perceptual = intensity_gradient(x.image, x.target);
    let silhouette_term = silhouette(x.alpha, x.mask);
    let scale = x.log_scales.exp().mean();
    let offset = x.offsets.powi_scalar(2).sum_dim(1).mean();
    let opacity = (-sigmoid(x.opacity_logits) + 1.0).mean();
    let reconstruction =
        l1_term.clone() * w.l1 + ssim_term.clone() * w.ssim + perceptual.clone() * w.perceptual;
    let regularisation =
        scale.clone() * w.scale + offset.clone() * w.offset + opacity.clone() * w.opacity;
    NlfLoss {
        total: reconstruction * w.reconstruction
            + silhouette_term.clone() * w.silhouette
            + regularisation * w.regularisation,
        l1: l1_term,
        ssim: ssim_term,
        perceptual,
        silhouette: silhouette_term,
        scale,
        offset,
        opacity,
    }
}

/// The intensity-and-gradient term NLF-GS adds to its reconstruction loss (its `L_perc`,
/// Eq. 6): L1 between luminances (Rec. 709 weights) plus L1 between their horizontal and
/// vertical finite differences, which weighs edges. No pretrained network is involved.
pub fn intensity_gradient(image: Tensor<3>, target: Tensor<3>) -> Tensor<1> {
    let [h, w, c] = image.dims();
    assert_eq!(c, 3, "intensity_gradient takes [H, W, 3] images");
    let device = image.device();
    let luma = Tensor::<1>::from_floats([0.2126, 0.7152, 0.0722], &device).reshape([1, 1, 3]);
    let y = |t: Tensor<3>| (t * luma.clone()).sum_dim(2).reshape([h, w]);
    let (a, b) = (y(image), y(target));
    let dx = |t: Tensor<2>| t.clone().slice([0..h, 1..w]) - t.slice([0..h, 0..w - 1]);
    let dy = |t: Tensor<2>| t.clone().slice([1..h, 0..w]) - t.slice([0..h - 1, 0..w]);
    (a.clone() - b.clone()).abs().mean()
        + (dx(a.clone()) - dx(b.clone())).abs().mean()
        + (dy(a) - dy(b)).abs().mean()
}
