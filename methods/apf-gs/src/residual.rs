//! Eq. 4–5 of APF-GS on the engine's skinned node: `g_i(t) = T_h(t) ⊗ (LBS(ḡ_i, θ(t)) ⊕ Δ_i)`
//! with `Δ_i = a(σ_t) · F_φ(γ(μ̄_i), c_t)`.
//!
//! The node already applies LBS with the refined pose, whose root rotation and translation are
//! `T_h` (initialised from the track, refined per frame). Δ is written in the body frame, after
//! LBS and before `T_h`, as the paper orders it; applied to the node's world-space output that
//! is: `μ = μ_posed + R_h δμ`, `q = (R_h n((1,0,0,0) + δq) R_hᵀ) ⊗ q_posed` (conjugating a unit
//! quaternion by `R_h` keeps its scalar and rotates its vector part), `log s = log s_posed + δs`.
//! `δμ` is bounded to `r_max · tanh(· / r_max)` for stability at the extremes. `γ` reads the
//! canonical mean normalised to the canonical body's bounding box, `[−1, 1]³` (the frequency
//! encoding, or the field's hash table: [`ResidualField::encode_positions`]).
//!
//! [`GatedResidual::compute`] also returns the gated body-frame residual, which Eq. 6's
//! sparsity term reads, and with a per-Gaussian gate each Gaussian's σ.

use crate::gate::GateConfig;
use crate::networks::ResidualField;
use burn::tensor::Tensor;
use splatzoo_models::networks::encoding::frequency_encoding;
use splatzoo_rasterizer::Splats;
use splatzoo_train::scene::skinned::skinning::{quaternion_product, unit_quaternions};
use splatzoo_train::scene::skinned::{NonRigidField, Residual, ResidualInput, ResidualSpace};

/// How one person-frame's residual is gated.
pub enum ResidualGate {
    /// `a(σ_t)` `[1, 1]`: one σ for the person at the frame.
    PersonFrame(Tensor<2>),
    /// The frame's logit `ℓ_t` `[1, 1]`: each Gaussian's `σ_i = sigmoid(ℓ_t + δℓ_i)`, `δℓ_i`
    /// the field's eleventh column, then `a(σ_i)` by `gate`.
    Gaussian { logit: Tensor<2>, gate: GateConfig },
}

/// One person-frame's residual: the field and what conditions it.
pub struct GatedResidual {
    pub field: ResidualField,
    /// `[1, condition]` the guidance's `c_t`.
    pub condition: Tensor<2>,
    pub gate: ResidualGate,
    pub levels: usize,
    /// The canonical body's bounding box (centre, half extent), for `γ`'s normalisation.
    pub centre: [f32; 3],
    pub half_extent: [f32; 3],
    /// Bound of each component of `δμ`, metres.
    pub max_offset: f64,
}

/// The last residual: `[G, 3]` body-frame offsets, `[G, 4]` quaternion residuals, `[G, 3]`
/// log-scale residuals, all gated; each Gaussian's σ `[G, 1]` where the gate is per Gaussian;
/// and `[G, 10]` F_φ's output before the gate (what `loss.sparsity_of = "field"` reads).
#[derive(Clone)]
pub struct Produced {
    pub offsets: Tensor<2>,
    pub rotations: Tensor<2>,
    pub log_scales: Tensor<2>,
    pub sigma: Option<Tensor<2>>,
    pub ungated: Tensor<2>,
}

/// `‖δμ_i‖₁ / 0.01 m + ‖δq_i‖₁ + ‖δs_i‖₁` of each row of `[G, 3]`, `[G, 4]`, `[G, 3]`, `[G]`.
fn sparsity_of(offsets: Tensor<2>, rotations: Tensor<2>, log_scales: Tensor<2>) -> Tensor<1> {
    let [g, _] = offsets.dims();
    (offsets.abs().sum_dim(1) / 0.01 + rotations.abs().sum_dim(1) + log_scales.abs().sum_dim(1))
        .reshape([g])
}

impl Produced {
    /// Each Gaussian's `‖δμ_i‖₁ / 0.01 m + ‖δq_i‖₁ + ‖δs_i‖₁` of the gated residual, `[G]`;
    /// their mean is Eq. 6's `L_sparse` (spec §4).
    pub fn sparsity_rows(&self) -> Tensor<1> {
        sparsity_of(
            self.offsets.clone(),
            self.rotations.clone(),
            self.log_scales.clone(),
        )
    }

    /// The same rows of F_φ's output before the gate (its offsets bounded as the gated ones
    /// are): a sparsity whose σ-weight `σ S` has `∂/∂σ = S ≥ 0` at every σ, where the gated
    /// one's `σ a(σ) S` falls with σ past the blend's turning point.
    pub fn field_sparsity_rows(&self, max_offset: f64) -> Tensor<1> {
        let [g, _] = self.ungated.dims();
        let raw = self.ungated.clone();
        sparsity_of(
            bounded_offsets(raw.clone().slice([0..g, 0..3]), max_offset),
            raw.clone().slice([0..g, 3..7]),
            raw.slice([0..g, 7..10]),
        )
    }
}

/// Centre and half extent (at least `min_half` per axis) of flat `[N·3]` points' box: what `γ`
/// normalises canonical positions to.
pub fn bounding_box(points: &[f32], min_half: f32) -> ([f32; 3], [f32; 3]) {
    if points.is_empty() {
        return ([0.0; 3], [1.0; 3]);
    }
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for p in points.chunks(3) {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    (
        std::array::from_fn(|a| 0.5 * (lo[a] + hi[a])),
        std::array::from_fn(|a| (0.5 * (hi[a] - lo[a])).max(min_half)),
    )
}

/// Canonical means `[G, 3]` normalised to a box: `[−1, 1]³` inside it.
pub fn normalise_positions(means: Tensor<2>, centre: [f32; 3], half_extent: [f32; 3]) -> Tensor<2> {
    let device = means.device();
    let lift = |t: Tensor<2>| if means.is_autodiff() { t.autodiff() } else { t };
    let c = lift(Tensor::<1>::from_floats(centre, &device).reshape([1, 3]));
    let h =
        lift(Tensor::<1>::from_floats(half_extent.map(|v| v.max(1e-6)), &device).reshape([1, 3]));
    (means - c) / h
}

/// `γ` (NeRF's frequency encoding) of canonical means `[G, 3]` normalised to a box.
pub fn encode_positions(
    means: Tensor<2>,
    centre: [f32; 3],
    half_extent: [f32; 3],
    levels: usize,
) -> Tensor<2> {
    frequency_encoding(normalise_positions(means, centre, half_extent), levels)
}

/// `r_max · tanh(δμ / r_max)` of `[G, 3]` offsets: each component bounded by `max_offset`.
fn bounded_offsets(offsets: Tensor<2>, max_offset: f64) -> Tensor<2> {
    (offsets / max_offset).tanh() * max_offset
}

/// Raw field outputs `[G, 10]` gated by `amplitude` (`[1, 1]`, or `[G, 1]` per Gaussian) into
/// body-frame (δμ, δq, δs).
pub fn gate_outputs(raw: Tensor<2>, amplitude: Tensor<2>, max_offset: f64) -> Produced {
    let [g, _] = raw.dims();
    let gated = raw.clone() * amplitude.expand([g, 10]);
    Produced {
        offsets: bounded_offsets(gated.clone().slice([0..g, 0..3]), max_offset),
        rotations: gated.clone().slice([0..g, 3..7]),
        log_scales: gated.slice([0..g, 7..10]),
        sigma: None,
        ungated: raw,
    }
}

/// Applies body-frame `produced` to posed splats whose body frame has root rotation `root`
/// `[3, 3]` (Eq. 4's `⊕` then `⊗ T_h`): the additive [`Residual`] the node adds.
pub fn world_residual(posed: &Splats, produced: &Produced, root: Tensor<2>) -> Residual {
    let g = posed.len();
    let device = root.device();
    let offsets = produced.offsets.clone().matmul(root.clone().transpose());
    let identity = Tensor::<1>::from_floats([1.0, 0.0, 0.0, 0.0], &device)
        .reshape([1, 4])
        .expand([g, 4]);
    let body = unit_quaternions(identity + produced.rotations.clone());
    let w = body.clone().slice([0..g, 0..1]);
    let v = body.slice([0..g, 1..4]).matmul(root.transpose());
    let world = Tensor::cat(vec![w, v], 1);
    let rotated = quaternion_product(world, posed.quats.clone());
    Residual {
        means: Some(offsets),
        quats: Some(rotated - posed.quats.clone()),
        log_scales: Some(produced.log_scales.clone()),
        opacity_logits: None,
    }
}

impl GatedResidual {
    /// The node's additive residual and the gated body-frame one.
    pub fn compute(&self, input: &ResidualInput) -> (Residual, Produced) {
        let g = input.splats.len();
        let normalised =
            normalise_positions(input.canonical.means.clone(), self.centre, self.half_extent);
        let encoded = self.field.encode_positions(normalised, self.levels);
        let [_, c] = self.condition.dims();
        let condition = self.condition.clone().expand([g, c]);
        let raw = self.field.forward(Tensor::cat(vec![encoded, condition], 1));
        let produced = match &self.gate {
            ResidualGate::PersonFrame(amplitude) => {
                gate_outputs(raw, amplitude.clone(), self.max_offset)
            }
            ResidualGate::Gaussian { logit, gate } => {
                let sigma =
                    gate.sigma_per_gaussian(logit.clone(), raw.clone().slice([0..g, 10..11]));
                let produced = gate_outputs(
                    raw.slice([0..g, 0..10]),
                    gate.amplitude(sigma.clone()),
                    self.max_offset,
                );
                Produced {
                    sigma: Some(sigma),
                    ..produced
                }
            }
        };
        let root = input
            .pose
            .clone()
            .slice([0..1, 0..1, 0..3, 0..3])
            .reshape([3, 3]);
        (world_residual(input.splats, &produced, root), produced)
    }
}

impl NonRigidField for GatedResidual {
    fn space(&self) -> ResidualSpace {
        ResidualSpace::Posed
    }

    fn residual(&self, input: &ResidualInput) -> Residual {
        self.compute(input).0
    }
}
