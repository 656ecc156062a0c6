//! Every knob of a `train-apf` run, with the spec's defaults (§4) compressed to a CPU
//! schedule that fits 20 minutes on two cores: 1500 steps, the residual field, gate and
//! accessory deformation switched on at step 150 (drivestudio's 30k steps and
//! `use_deformgs_after: 3000` × 0.05; `--iterations 30000 --set warmup=3000` is theirs).

use crate::accessory::AttachRates;
use crate::data::ApfDataConfig;
use crate::decouple::DecoupleConfig;
use crate::gate::GateConfig;
use crate::networks::NetworkConfig;
use serde::{Deserialize, Serialize};
use splatzoo_train::TrainError;
use splatzoo_train::backend::Backend;
use splatzoo_train::densify::{DensifyConfig, Strategy};
use splatzoo_train::harness::MethodConfig;
use splatzoo_train::optimizer::LearningRates;
use splatzoo_train::scene::skinned::{Placement, SkinnedConfig};
use std::path::PathBuf;

/// Eq. 6–7's weights and the other loss terms.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LossWeights {
    /// `L_photo = (1 − λ) L1 + λ (1 − SSIM)`.
    pub lambda_dssim: f64,
    /// `λ_pose`: second-order smoothness of the refined pose and root.
    pub pose: f64,
    /// `λ_sparse` (weighted by σ) and `λ_kine` (weighted by 1 − σ).
    pub sparse: f64,
    pub kine: f64,
    /// Eq. 7's `λ_bone`, `λ_limit`.
    pub bone: f64,
    pub limit: f64,
    /// Whether σ's gradient reads `(1 − σ) λ_kine λ_limit L_limit` (the paper's Eq. 6). `false`
    /// detaches σ in that product only: `L_limit` depends on θ alone, so through σ it can only
    /// push σ up, and most where the prior's pose is wrong (README, "What moves σ").
    pub sigma_reads_limit: bool,
    /// What `L_sparse` reads: `"gated"`, the residual Δ the node adds (spec §4), or `"field"`,
    /// F_φ's output before the gate.
    pub sparsity_of: SparsityOf,
    /// `λ_σ` of `λ_σ (σ − σ₀)²`, σ₀ = `network.initial_sigma` (our choice, not the paper's; 0
    /// = off): Eq. 6 is linear in σ, so without a term that curves it σ runs to a bound or
    /// sits where its two regularisers cancel (README, "What moves σ").
    pub sigma_prior: f64,
    /// The node mask term: BCE of each node type's alpha against `M_kine` / `M_acc` inside the
    /// people's boxes.
    pub mask: f64,
    /// LiDAR depth L1 on the rendered depth.
    pub depth: f64,
}

impl Default for LossWeights {
    fn default() -> Self {
        Self {
            lambda_dssim: 0.2,
            pose: 0.01,
            sparse: 1e-3,
            kine: 0.1,
            bone: 1.0,
            limit: 1.0,
            sigma_reads_limit: true,
            sparsity_of: SparsityOf::Gated,
            sigma_prior: 0.0,
            mask: 0.1,
            depth: 0.01,
        }
    }
}

/// The residual Eq. 6's sparsity term reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SparsityOf {
    /// `Δ = a(σ) F_φ`, what the node adds: `σ a(σ) S` falls with σ past the blend's turn.
    Gated,
    /// `F_φ`'s output before `a(σ)`: `σ S` rises with σ everywhere.
    Field,
}

/// Learning rates of the networks (Adam, ε = 1e-8), decayed exponentially to 1/10.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NetworkRates {
    pub encoder: f64,
    pub guidance: f64,
    pub residual: f64,
    pub accessory: f64,
    pub embeddings: f64,
}

impl Default for NetworkRates {
    fn default() -> Self {
        Self {
            encoder: 1e-4,
            guidance: 1e-3,
            residual: 1.6e-3,
            accessory: 1.6e-3,
            embeddings: 1e-3,
        }
    }
}

/// The residual field's switches.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ResidualConfig {
    /// Off: LBS only (with decoupling off too, what OmniRe's human node does).
    pub enabled: bool,
    /// `r_max`: bound of each offset component, metres.
    pub max_offset: f64,
}

impl Default for ResidualConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            max_offset: 0.25,
        }
    }
}

/// Eq. 8's switches.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AttachConfig {
    /// `D_ψ`'s non-rigid offsets (off: accessories move rigidly with `T_acc`).
    pub deform: bool,
    /// Stop the accessory's gradients at `T_parent`.
    pub detach_parent: bool,
    pub rates: AttachRates,
    /// Most Gaussians an accessory starts with.
    pub initial_gaussians: usize,
}

impl Default for AttachConfig {
    fn default() -> Self {
        Self {
            deform: true,
            detach_parent: false,
            rates: AttachRates::default(),
            initial_gaussians: 3000,
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ApfConfig {
    pub backend: Backend,
    pub iterations: usize,
    pub eval_every: usize,
    pub checkpoint_every: usize,
    pub seed: u64,
    pub lpips_weights: Option<PathBuf>,
    /// Export `C`, `F_φ` and `D_ψ` as ONNX graphs at the end (checked in tract).
    pub onnx: bool,
    /// At the end, re-pose every pedestrian with an accessory for this many frames (0: none)
    /// of a built-in walk, or of `repose_poses` (an AMASS-layout `.npz`, z-up).
    pub repose_frames: usize,
    pub repose_poses: Option<PathBuf>,
    /// Stage S1 (LBS only, pose refinement on) lasts this many steps; then the residual field,
    /// the gate and the accessory deformation switch on (S2).
    pub warmup: usize,
    /// Highest SH degree of the background and accessories (humans use `human_sh_degree`).
    pub sh_degree: u32,
    pub human_sh_degree: u32,
    pub sh_degree_every: usize,
    pub data: ApfDataConfig,
    pub decouple: DecoupleConfig,
    pub gate: GateConfig,
    pub residual: ResidualConfig,
    pub attach: AttachConfig,
    pub network: NetworkConfig,
    pub loss: LossWeights,
    pub network_rates: NetworkRates,
    /// The human nodes (one Gaussian per body vertex, no density control, as OmniRe).
    pub human: SkinnedConfig,
    pub human_rates: LearningRates,
    pub background_rates: LearningRates,
    pub background_densify: DensifyConfig,
    pub accessory_densify: DensifyConfig,
}

impl Default for ApfConfig {
    fn default() -> Self {
        let adc = |max: usize| DensifyConfig {
            strategy: Strategy::Adc,
            start: 300,
            stop: 1200,
            every: 100,
            max_gaussians: max,
            grad_threshold: 0.0005,
            ..DensifyConfig::default()
        };
        Self {
            backend: Backend::Flex,
            iterations: 1500,
            eval_every: 0,
            checkpoint_every: 500,
            seed: 0,
            lpips_weights: None,
            onnx: true,
            repose_frames: 24,
            repose_poses: None,
            warmup: 150,
            sh_degree: 3,
            human_sh_degree: 1,
            sh_degree_every: 1000,
            data: ApfDataConfig::default(),
            decouple: DecoupleConfig::default(),
            gate: GateConfig::default(),
            residual: ResidualConfig::default(),
            attach: AttachConfig::default(),
            network: NetworkConfig::default(),
            loss: LossWeights::default(),
            network_rates: NetworkRates::default(),
            human: SkinnedConfig {
                placement: Placement::Vertices,
                initial_opacity: 0.99,
                refine_sequence_offset: false,
                refine_shape: false,
                smoothness_weight: 0.0,
                ..SkinnedConfig::default()
            },
            human_rates: LearningRates {
                means_start: 3.0 * 1.6e-4,
                means_end: 3.0 * 1.6e-6,
                quats: 5e-3,
                sh_dc: 5e-3,
                sh_rest: 2.5e-4,
                ..LearningRates::default()
            },
            background_rates: LearningRates::default(),
            background_densify: adc(150_000),
            accessory_densify: adc(20_000),
        }
    }
}

impl MethodConfig for ApfConfig {
    splatzoo_train::schedule_fields!();

    fn validate(&self) -> Result<(), TrainError> {
        let bad = |m: String| Err(TrainError::Config(m));
        if self.iterations == 0 {
            return bad("iterations ≥ 1".into());
        }
        if self.sh_degree > 3 || self.human_sh_degree > 3 {
            return bad("sh_degree and human_sh_degree ≤ 3".into());
        }
        if !(0.0..=1.0).contains(&self.loss.lambda_dssim) {
            return bad("loss.lambda_dssim in [0, 1]".into());
        }
        for (name, v) in [
            ("loss.pose", self.loss.pose),
            ("loss.sparse", self.loss.sparse),
            ("loss.kine", self.loss.kine),
            ("loss.bone", self.loss.bone),
            ("loss.limit", self.loss.limit),
            ("loss.sigma_prior", self.loss.sigma_prior),
            ("loss.mask", self.loss.mask),
            ("loss.depth", self.loss.depth),
            ("residual.max_offset", self.residual.max_offset),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return bad(format!("{name} must be finite and ≥ 0, got {v}"));
            }
        }
        if self.residual.max_offset <= 0.0 {
            return bad("residual.max_offset > 0".into());
        }
        self.data.validate().map_err(TrainError::Config)?;
        self.gate.validate().map_err(TrainError::Config)?;
        self.network.validate().map_err(TrainError::Config)?;
        self.human.validate()
    }
}
