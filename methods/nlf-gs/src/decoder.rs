//! NLF-GS's shared MLP decoder: one fused feature per Gaussian in, its attributes out, each
//! mapped to a valid range with a bounded activation (section 3.6 of NLF-GS): the offset from
//! its anchor `max_offset · tanh`, a normalised quaternion, scales `max_scale · sigmoid` (as
//! log-scales for the rasterizer), an opacity logit (the rasterizer applies the sigmoid) and a
//! colour `sigmoid` in [0, 1] (as the SH DC coefficient the rasterizer takes).

use burn::module::Module;
use burn::nn::{Linear, LinearConfig};
use burn::tensor::activation::{relu, sigmoid};
use burn::tensor::{Device, Tensor};

/// `C0` of the degree-0 spherical harmonic: colour = `C0 · dc + 0.5`.
use splatzoo_rasterizer::sh::SH_C0;

#[derive(Module, Debug)]
pub struct Decoder {
    layers: Vec<Linear>,
    head: Linear,
    max_offset: f64,
    max_scale: f64,
}

/// What the decoder predicts for `P` Gaussians.
#[derive(Debug, Clone)]
pub struct Attributes {
    /// `[P, 3]` offset from the anchor (in the anchor face's frame).
    pub offset: Tensor<2>,
    /// `[P, 4]` unit quaternions (w, x, y, z).
    pub quats: Tensor<2>,
    /// `[P, 3]` natural-log standard deviations.
    pub log_scales: Tensor<2>,
    /// `[P]`
    pub opacity_logits: Tensor<1>,
    /// `[P, 3]` colour in [0, 1].
    pub rgb: Tensor<2>,
}

/// Columns of [`Attributes::packed`]: offset 3, quaternion 4, log-scale 3, opacity logit 1,
/// colour 3.
pub const PACKED_COLUMNS: usize = 14;

impl Attributes {
    /// All attributes side by side, `[P, 14]`: offset (3), quaternion w x y z (4), log-scale
    /// (3), opacity logit (1), colour (3); the decoder's ONNX output.
    pub fn packed(&self) -> Tensor<2> {
        let [p, _] = self.offset.dims();
        Tensor::cat(
            vec![
                self.offset.clone(),
                self.quats.clone(),
                self.log_scales.clone(),
                self.opacity_logits.clone().reshape([p, 1]),
                self.rgb.clone(),
            ],
            1,
        )
    }

    /// The colour as SH DC coefficients `[P, 1, 3]`.
    pub fn sh_dc(&self) -> Tensor<3> {
        let [p, _] = self.rgb.dims();
        ((self.rgb.clone() - 0.5) / SH_C0).reshape([p, 1, 3])
    }
}

impl Decoder {
    /// `inputs` features → `hidden` wide layers (ReLU) → 14 outputs.
    pub fn new(
        inputs: usize,
        hidden: &[usize],
        max_offset: f64,
        max_scale: f64,
        device: &Device,
    ) -> Self {
        let mut layers = Vec::new();
        let mut width = inputs;
        for &h in hidden {
            layers.push(LinearConfig::new(width, h).init(device));
            width = h;
        }
        Self {
            layers,
            head: LinearConfig::new(width, 14).init(device),
            max_offset,
            max_scale,
        }
    }

    pub fn forward(&self, features: Tensor<2>) -> Attributes {
        let mut x = features;
        for layer in &self.layers {
            x = relu(layer.forward(x));
        }
        let out = self.head.forward(x);
        let [p, _] = out.dims();
        let part = |a: usize, b: usize| out.clone().slice([0..p, a..b]);
        let quat = part(3, 7)
            + Tensor::<1>::from_floats([1.0, 0.0, 0.0, 0.0], &out.device()).reshape([1, 4]);
        let norm = floor_at(quat.clone().powi_scalar(2).sum_dim(1).sqrt(), 1e-8);
        Attributes {
            offset: part(0, 3).tanh() * self.max_offset,
            quats: quat / norm,
            // ln(max_scale · sigmoid(x)) computed in the log domain: the same function, but a
            // saturated sigmoid no longer turns float rounding into large log differences.
            log_scales: floor_at(
                log_sigmoid(part(7, 10)) + self.max_scale.ln(),
                MIN_LOG_SCALE,
            ),
            opacity_logits: part(10, 11).reshape([p]),
            rgb: sigmoid(part(11, 14)),
        }
    }
}

/// Scales never go below 1e-8 m.
const MIN_LOG_SCALE: f64 = -18.420_680_743_952_367;

/// `ln σ(x) = −(relu(−x) + ln(1 + e^{−|x|}))`, stable at any `x` and lowerable to ONNX.
fn log_sigmoid(x: Tensor<2>) -> Tensor<2> {
    -(relu(-x.clone()) + ((-x.abs()).exp() + 1.0).log())
}

/// `max(x, floor)` written as `relu(x − floor) + floor`, which ONNX export lowers (burn-onnx
/// 0.22 does not lower `clamp_min`).
fn floor_at(x: Tensor<2>, floor: f64) -> Tensor<2> {
    relu(x - floor) + floor
}
