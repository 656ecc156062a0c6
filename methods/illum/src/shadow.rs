//! Illum's implicit scene shadows (§3.3, Eq. 8–9): scene Gaussians inside a box around the
//! human ask a small decoder how much the human occludes them, `ao = F_ao(γ(r), γ(δ), z)`,
//! and their colour is scaled by it.
//!
//! - [`ShadowBox`]: the human's observation-space AABB, padded by a fraction of the body height
//!   `H` (spec: `0.5·H`, so the floor shadow falls inside). Outside it `ao ≡ 1`.
//! - [`ShadowDecoder`]: `γ(r)` (4 frequencies, 27-D) ‖ `γ(δ)` (6 frequencies, 13-D) ‖ `z`
//!   (`d_z`, default 16) → 3 × 64 ReLU → 1 sigmoid; the last bias starts at +4 and its weights
//!   at `±1e-3`, so `ao ≈ sigmoid(4) ≈ 0.982` everywhere at first while every layer still gets
//!   a gradient. `r = (x_s − c_h)/‖x_s − c_h‖` in world axes (0 at the centre), `δ = ‖x_s −
//!   c_h‖/H`, `z` the light volume's latent interpolated at `x_s` (Eq. 6).
//! - [`scene_occlusion`]: ao for every scene Gaussian; the in-box rows are picked on the host,
//!   decoded, and scattered back, so the decoder and latents see only those rows.
//! - Eq. 9, `SH' = ao·SH`: under the rasterizer's rule `max(Σ c Y + 0.5, 0)`, scaling every
//!   coefficient gives `ao·(colour − 0.5) + 0.5`, which fades a full shadow (`ao = 0`) to grey
//!   0.5 instead of black. The spec's reading is [`shadowed_colour`]: `ao · max(SH(d) + 0.5, 0)`
//!   on colours evaluated beforehand. As an SH edit ([`sh_equivalent`]) that is
//!   `c₀' = ao·c₀ + (ao − 1)·0.5/Y₀₀`, `c_k' = ao·c_k` (k ≥ 1).
//!
//! Scene positions only condition the decoder: they are detached here, so a shadow never pulls
//! scene Gaussians about (and the centre, where `r` is undefined, has no gradient to blow up).

use crate::IllumError;
use crate::light_volume::LightVolume;
use burn::module::{Module, Param};
use burn::nn::{Initializer, Linear, LinearConfig};
use burn::tensor::activation::sigmoid;
use burn::tensor::{Device, IndexingUpdateOp, Int, Tensor, TensorData};
use splatzoo_models::networks::encoding::{
    encoded_width, frequency_encoding, frequency_encoding_reference,
};
use splatzoo_models::networks::mlp::SkipMlp;
use splatzoo_rasterizer::sh::SH_C0;

/// Frequencies of `γ(r)` (spec: L = 4, 27-D).
pub const DIRECTION_LEVELS: usize = 4;
/// Frequencies of `γ(δ)` (spec: L = 6, 13-D).
pub const DISTANCE_LEVELS: usize = 6;
/// Hidden layers of `F_ao` (spec: 3 × 64).
pub const HIDDEN_DEPTH: usize = 3;
/// Width of `F_ao`'s hidden layers.
pub const HIDDEN_WIDTH: usize = 64;
/// The output bias at initialisation: `ao = sigmoid(4) ≈ 0.982`.
pub const INITIAL_LOGIT: f64 = 4.0;
/// Half-width of the uniform initial output weights.
const OUTPUT_WEIGHT_INIT: f64 = 1e-3;
/// Below this distance to the box centre `r` is `offset / MIN_DISTANCE` (≈ 0), not a unit.
const MIN_DISTANCE: f64 = 1e-9;

/// The shadow region of one frame: the posed human's AABB padded by `pad·H` on every side,
/// with `H` the body's extent along the world's up axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShadowBox {
    /// `c_h`, the box centre (δ and r are measured from it).
    pub centre: [f64; 3],
    /// Half the box's size along each world axis, padding included.
    pub half_extent: [f64; 3],
    /// `H`, the human's height: it scales the padding and `δ`.
    pub height: f64,
}

impl ShadowBox {
    /// The box around posed human points (vertices or Gaussian centres), `up_axis` naming the
    /// world's up axis (0, 1 or 2; 1 = y for SMPL-aligned and the synthetic worlds), padded by
    /// `pad_fraction_of_height · H` on all six sides (spec default 0.5).
    pub fn around(
        points: &[[f64; 3]],
        up_axis: usize,
        pad_fraction_of_height: f64,
    ) -> Result<Self, IllumError> {
        if points.is_empty() {
            return Err(IllumError::input("shadow box", "no human points"));
        }
        if let Some(k) = points.iter().position(|p| p.iter().any(|v| !v.is_finite())) {
            return Err(IllumError::input(
                "shadow box",
                format!("human point {k} is not finite: {:?}", points[k]),
            ));
        }
        if up_axis > 2 {
            return Err(IllumError::input(
                "shadow box up axis",
                format!("must be 0, 1 or 2, got {up_axis}"),
            ));
        }
        if !(pad_fraction_of_height.is_finite() && pad_fraction_of_height >= 0.0) {
            return Err(IllumError::input(
                "shadow box padding",
                format!("must be finite and ≥ 0, got {pad_fraction_of_height}"),
            ));
        }
        let lo = [0, 1, 2].map(|a| points.iter().map(|p| p[a]).fold(f64::INFINITY, f64::min));
        let hi = [0, 1, 2].map(|a| {
            points
                .iter()
                .map(|p| p[a])
                .fold(f64::NEG_INFINITY, f64::max)
        });
        let height = hi[up_axis] - lo[up_axis];
        if height <= 0.0 {
            return Err(IllumError::input(
                "shadow box",
                format!("the human points have no extent along the up axis {up_axis}"),
            ));
        }
        let pad = pad_fraction_of_height * height;
        Ok(Self {
            centre: [0, 1, 2].map(|a| 0.5 * (lo[a] + hi[a])),
            half_extent: [0, 1, 2].map(|a| 0.5 * (hi[a] - lo[a]) + pad),
            height,
        })
    }

    /// Whether `point` lies in the box (faces included).
    pub fn contains(&self, point: [f64; 3]) -> bool {
        (0..3).all(|a| (point[a] - self.centre[a]).abs() <= self.half_extent[a])
    }

    /// The box's corners `(min, max)`, e.g. to size the light volume around it.
    pub fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        (
            [0, 1, 2].map(|a| self.centre[a] - self.half_extent[a]),
            [0, 1, 2].map(|a| self.centre[a] + self.half_extent[a]),
        )
    }

    /// [`Self::contains`] for every row of `[M, 3]` positions (read back to the host): the one
    /// in-box rule [`scene_occlusion`] and Eq. 12's pair selection share.
    pub fn inside(&self, positions: &Tensor<2>) -> Vec<bool> {
        let [m, d] = positions.dims();
        assert_eq!(d, 3, "positions must be [M, 3], got [{m}, {d}]");
        let host = positions
            .to_data()
            .convert::<f32>()
            .try_into_vec::<f32>()
            .expect("positions read back as f32");
        host.chunks_exact(3)
            .map(|p| self.contains([p[0], p[1], p[2]].map(f64::from)))
            .collect()
    }
}

/// `F_ao` (Eq. 8): `[γ(r) ‖ γ(δ) ‖ z]` → `ao ∈ (0, 1)`.
#[derive(Module, Debug)]
pub struct ShadowDecoder {
    /// 3 × 64 ReLU layers.
    pub trunk: SkipMlp,
    /// The logit of `ao`, `[64] → [1]`.
    pub output: Linear,
}

impl ShadowDecoder {
    /// The decoder for latents of width `latent_dim`, at `ao ≈ sigmoid(4)`.
    pub fn new(latent_dim: usize, device: &Device) -> Self {
        let trunk = SkipMlp::new(
            Self::input_width(latent_dim),
            HIDDEN_DEPTH,
            HIDDEN_WIDTH,
            None,
            device,
        );
        let mut output = LinearConfig::new(HIDDEN_WIDTH, 1)
            .with_initializer(Initializer::Uniform {
                min: -OUTPUT_WEIGHT_INIT,
                max: OUTPUT_WEIGHT_INIT,
            })
            .init(device);
        output.bias = Some(Param::from_tensor(Tensor::<1>::from_floats(
            [INITIAL_LOGIT as f32],
            device,
        )));
        Self { trunk, output }
    }

    /// Width of the decoder's input: `27 + 13 + d_z`.
    pub fn input_width(latent_dim: usize) -> usize {
        encoded_width(3, DIRECTION_LEVELS) + encoded_width(1, DISTANCE_LEVELS) + latent_dim
    }

    /// The latent width `d_z` the decoder reads.
    pub fn latent_dim(&self) -> usize {
        self.trunk.layers[0].weight.val().dims()[0] - Self::input_width(0)
    }

    /// Input rows `[R, 40 + d_z]` (from [`decoder_inputs`]) → `ao` `[R]`.
    pub fn forward(&self, inputs: Tensor<2>) -> Tensor<1> {
        let r = inputs.dims()[0];
        self.forward_rows(inputs).reshape([r])
    }

    /// Input rows `[R, 40 + d_z]` → `ao` `[R, 1]` (the ONNX graph's map).
    pub fn forward_rows(&self, inputs: Tensor<2>) -> Tensor<2> {
        sigmoid(self.output.forward(self.trunk.forward(inputs)))
    }
}

/// The decoder's input rows for scene points `[R, 3]` (detached) with their interpolated
/// latents `[R, d_z]`: `[γ(r) ‖ γ(δ) ‖ z]`, `[R, 40 + d_z]`.
pub fn decoder_inputs(shadow_box: &ShadowBox, points: Tensor<2>, latent: Tensor<2>) -> Tensor<2> {
    let [r, d] = points.dims();
    assert_eq!(
        d, 3,
        "decoder_inputs: points must be [R, 3], got [{r}, {d}]"
    );
    assert_eq!(
        latent.dims()[0],
        r,
        "decoder_inputs: {r} points but {} latent rows",
        latent.dims()[0]
    );
    let device = points.device();
    let centre = Tensor::<2>::from_data(
        TensorData::new(shadow_box.centre.map(|v| v as f32).to_vec(), [1, 3]),
        &device,
    );
    let offset = points.detach() - centre;
    let distance = offset.clone().powi_scalar(2).sum_dim(1).sqrt(); // [R, 1]
    let direction = offset / distance.clone().clamp_min(MIN_DISTANCE);
    let delta = distance / shadow_box.height;
    Tensor::cat(
        vec![
            frequency_encoding(direction, DIRECTION_LEVELS),
            frequency_encoding(delta, DISTANCE_LEVELS),
            latent,
        ],
        1,
    )
}

/// [`decoder_inputs`] in f64 for one point and its latent.
pub fn decoder_inputs_reference(
    shadow_box: &ShadowBox,
    point: [f64; 3],
    latent: &[f64],
) -> Vec<f64> {
    let offset = [0, 1, 2].map(|a| point[a] - shadow_box.centre[a]);
    let distance = offset.iter().map(|v| v * v).sum::<f64>().sqrt();
    let direction = offset.map(|v| v / distance.max(MIN_DISTANCE));
    let mut row = frequency_encoding_reference(&direction, DIRECTION_LEVELS);
    row.extend(frequency_encoding_reference(
        &[distance / shadow_box.height],
        DISTANCE_LEVELS,
    ));
    row.extend_from_slice(latent);
    row
}

/// Eq. 8 for every scene Gaussian: `ao` `[M]` at positions `[M, 3]`, exactly 1 outside
/// `shadow_box`, the decoder's output inside. Only the in-box rows are interpolated and decoded
/// (none: all ones, nothing evaluated), so gradients reach the decoder and the latents of the
/// probes around in-box Gaussians only; positions get none.
pub fn scene_occlusion(
    decoder: &ShadowDecoder,
    volume: &LightVolume,
    shadow_box: &ShadowBox,
    positions: Tensor<2>,
) -> Tensor<1> {
    assert_eq!(
        decoder.latent_dim(),
        volume.latent_dim(),
        "scene_occlusion: the decoder reads latents of another width than the volume's"
    );
    let m = positions.dims()[0];
    let device = positions.device();
    let inside = shadow_box.inside(&positions);
    let rows: Vec<i64> = (0..m).filter(|&i| inside[i]).map(|i| i as i64).collect();
    let outside: Vec<f32> = inside.iter().map(|&i| if i { 0.0 } else { 1.0 }).collect();
    let outside = Tensor::<1>::from_data(TensorData::new(outside, [m]), &device);
    if rows.is_empty() {
        return outside;
    }
    let count = rows.len();
    let rows = Tensor::<1, Int>::from_data(TensorData::new(rows, [count]), &device);
    let points = positions.detach().select(0, rows.clone());
    let latent = volume.interpolate_latent(points.clone());
    let ao = decoder.forward(decoder_inputs(shadow_box, points, latent));
    // 1 outside, 0 + ao inside: exact in both places.
    outside
        .zeros_like()
        .select_assign(0, rows, ao, IndexingUpdateOp::Add)
        + outside
}

/// Eq. 9 as the spec reads it: shadowed colours `ao · colour`, `[M, 3]`, from colours already
/// evaluated as `max(SH(d) + 0.5, 0)` (`[M, 3]`) and `ao` `[M]`. `ao = 0` is black, 1 the
/// identity. (Its f64 reference is the definition itself, `ao·c` per channel.)
pub fn shadowed_colour(colour: Tensor<2>, ao: Tensor<1>) -> Tensor<2> {
    let [m, c] = colour.dims();
    assert_eq!(
        ao.dims(),
        [m],
        "shadowed_colour: ao must be [{m}], colours are [{m}, {c}]"
    );
    colour * ao.reshape([m, 1])
}

/// [`shadowed_colour`] as an edit of SH coefficients `[M, K, C]`: `c₀' = ao·c₀ +
/// (ao − 1)·0.5/Y₀₀`, `c_k' = ao·c_k`. Then `Σ c' Y + 0.5 = ao·(Σ c Y + 0.5)`, and since
/// `ao ≥ 0` the clamp commutes: `max(ao·x, 0) = ao·max(x, 0)`, so the edited SH renders
/// exactly `ao · colour` in every direction.
pub fn sh_equivalent(coefficients: Tensor<3>, ao: Tensor<1>) -> Tensor<3> {
    let [m, k, c] = coefficients.dims();
    assert_eq!(ao.dims(), [m], "sh_equivalent: ao must be [{m}]");
    let ao = ao.reshape([m, 1, 1]);
    let scaled = coefficients * ao.clone();
    let dc = scaled.clone().slice([0..m, 0..1, 0..c]) + (ao - 1.0) * (0.5 / SH_C0);
    if k == 1 {
        dc
    } else {
        Tensor::cat(vec![dc, scaled.slice([0..m, 1..k, 0..c])], 1)
    }
}

/// [`sh_equivalent`] in f64 for one Gaussian's coefficients `[K, C]` (row-major).
pub fn sh_equivalent_reference(coefficients: &[f64], channels: usize, ao: f64) -> Vec<f64> {
    coefficients
        .iter()
        .enumerate()
        .map(|(i, &v)| {
            if i < channels {
                ao * v + (ao - 1.0) * 0.5 / SH_C0
            } else {
                ao * v
            }
        })
        .collect()
}
