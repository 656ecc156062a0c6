//! Prior-4D's per-pixel and per-Gaussian terms: the normal loss (Eq. 6) and the Huber prior
//! regulariser (§4.4.4, no formula in the paper). The contact loss (Eq. 7) is [`crate::contact`].

use burn::tensor::Tensor;

/// Eq. 6 of Prior-4D (after HSR): `‖N̂ − N‖₁ + ‖1 − N̂ᵀN‖₁`, averaged over the pixels where
/// `mask` `[H, W]` (0/1) is set — given normal maps are only valid on the person (spec: our
/// choice). Per pixel: the L1 distance summed over xyz plus `|1 − N̂·N|`. `rendered` and
/// `target` are `[H, W, 3]` in the same camera frame. Zero when the mask is empty.
pub fn normal_loss(rendered: Tensor<3>, target: Tensor<3>, mask: Tensor<2>) -> Tensor<1> {
    let [h, w, c] = rendered.dims();
    assert_eq!(c, 3, "rendered normals must be [H, W, 3]");
    assert_eq!(
        target.dims(),
        [h, w, 3],
        "target normals must be [{h}, {w}, 3]"
    );
    assert_eq!(mask.dims(), [h, w], "the normal mask must be [{h}, {w}]");
    let l1 = (rendered.clone() - target.clone()).abs().sum_dim(2); // [H, W, 1]
    let dot = (rendered * target).sum_dim(2);
    let cosine = (dot.neg().add_scalar(1.0)).abs();
    let per_pixel = (l1 + cosine).reshape([h, w]) * mask.clone();
    per_pixel.sum() / mask.sum().clamp_min(1.0)
}

/// The Huber function `ρ_δ(x) = ½ x²` for `|x| ≤ δ`, else `δ (|x| − ½ δ)`, element-wise.
pub fn huber<const D: usize>(x: Tensor<D>, delta: f64) -> Tensor<D> {
    assert!(
        delta > 0.0,
        "the Huber threshold must be positive, got {delta}"
    );
    let a = x.abs();
    let quadratic = a.clone().powi_scalar(2) * 0.5;
    let linear = (a.clone() - 0.5 * delta) * delta;
    quadratic.mask_where(a.greater_elem(delta), linear)
}

/// The thresholds of [`huber_prior`].
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct HuberConfig {
    /// On RGB in [0, 1].
    pub colour_delta: f64,
    /// On log-radius (natural log units).
    pub scale_delta: f64,
}

impl Default for HuberConfig {
    fn default() -> Self {
        Self {
            colour_delta: 0.1,
            scale_delta: 0.1,
        }
    }
}

/// The Huber prior regulariser (§4.4.4 of Prior-4D; the form is the spec's): the avatar's
/// colours `[G, 3]` and log-radii `[G]` kept near the stage-B avatar's (`*_prior`, constant),
/// `mean_i Σ_c ρ(C − C⁰) + mean_i ρ(ln S − ln S⁰)`, so Gaussians the acting video never sees keep
/// the prior's look.
pub fn huber_prior(
    colours: Tensor<2>,
    colours_prior: Tensor<2>,
    log_radii: Tensor<1>,
    log_radii_prior: Tensor<1>,
    config: &HuberConfig,
) -> Tensor<1> {
    let [g, _] = colours.dims();
    assert_eq!(
        colours_prior.dims(),
        [g, 3],
        "prior colours must be [{g}, 3]"
    );
    assert_eq!(log_radii.dims(), [g], "log-radii must be [{g}]");
    assert_eq!(log_radii_prior.dims(), [g], "prior log-radii must be [{g}]");
    let colour = huber(colours - colours_prior, config.colour_delta)
        .sum_dim(1)
        .mean();
    let scale = huber(log_radii - log_radii_prior, config.scale_delta).mean();
    colour + scale
}
