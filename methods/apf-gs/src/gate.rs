//! The reliability gate σ_t of Adaptive Prior Fusion (§II-C) and how it "modulates the output
//! scale of the residual deformation".
//!
//! The paper's text fixes the semantics (σ → 0: the prior is unreliable and large corrections
//! must be possible; σ → 1: only micro detail), but neither literal reading does both: `Δ = σ F`
//! switches the residual off exactly when correction is needed and `Δ = (1 − σ) F` switches it
//! off when detail is wanted. The default is the spec's blend `a(σ) = (1 − σ) + κ σ` (full
//! amplitude at σ = 0, κ at σ = 1); the literal readings are [`GateForm::Sigma`] and
//! [`GateForm::OneMinus`]. σ itself is learned by the guidance module, or fixed (Table II's
//! "strong prior" σ ≡ 1 and "weak prior" σ ≡ 0).
//!
//! σ is one scalar per (person, frame), as the paper has it; the spec's optional variant
//! ([`GateGranularity::Gaussian`]) reads "in regions with high photometric error" per Gaussian:
//! `σ_{t,i} = sigmoid(ℓ_t + δℓ_i)`, the frame's logit from the guidance module plus an offset
//! from an eleventh output of `F_φ` (zero at the start, so every Gaussian starts at σ_t).

use burn::tensor::Tensor;
use burn::tensor::activation::sigmoid;
use serde::{Deserialize, Serialize};

/// How σ scales the residual.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GateForm {
    /// `a(σ) = (1 − σ) + κ σ` (our reading of the text).
    Blend,
    /// `a(σ) = σ` (the sentence's literal "modulates the output scale").
    Sigma,
    /// `a(σ) = 1 − σ`.
    OneMinus,
}

/// How finely σ is resolved.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GateGranularity {
    /// One σ per (person, frame) (the paper's "scalar").
    PersonFrame,
    /// One σ per Gaussian around the frame's (the spec's optional variant).
    Gaussian,
}

/// Where σ comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GateMode {
    /// The guidance module's sigmoid output per (person, frame).
    Learned,
    /// A constant `gate.value` (Table II's strong prior is 1, weak prior 0).
    Fixed,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GateConfig {
    pub mode: GateMode,
    /// σ when `mode = "fixed"`.
    pub value: f64,
    pub form: GateForm,
    /// The blend's amplitude at σ = 1.
    pub kappa: f64,
    pub granularity: GateGranularity,
}

impl Default for GateConfig {
    fn default() -> Self {
        Self {
            mode: GateMode::Learned,
            value: 1.0,
            form: GateForm::Blend,
            kappa: 0.1,
            granularity: GateGranularity::PersonFrame,
        }
    }
}

impl GateConfig {
    pub fn validate(&self) -> Result<(), String> {
        if !(0.0..=1.0).contains(&self.value) {
            return Err(format!("gate.value in [0, 1], got {}", self.value));
        }
        if !(0.0..=1.0).contains(&self.kappa) {
            return Err(format!("gate.kappa in [0, 1], got {}", self.kappa));
        }
        if self.granularity == GateGranularity::Gaussian && self.mode == GateMode::Fixed {
            return Err(
                "gate.granularity = \"gaussian\" needs gate.mode = \"learned\" (a fixed σ has \
                 no per-Gaussian offsets)"
                    .into(),
            );
        }
        Ok(())
    }

    /// Columns of `F_φ`'s output: `(δμ, δq, δs)`, plus the gate offset `δℓ` per Gaussian.
    pub fn residual_columns(&self) -> usize {
        match self.granularity {
            GateGranularity::PersonFrame => 10,
            GateGranularity::Gaussian => 11,
        }
    }

    /// σ per Gaussian `[G, 1]`: `sigmoid(ℓ_t + δℓ_i)` from the frame's logit `[1, 1]` and the
    /// offsets `[G, 1]`.
    pub fn sigma_per_gaussian(&self, logit: Tensor<2>, offsets: Tensor<2>) -> Tensor<2> {
        let [g, _] = offsets.dims();
        sigmoid(logit.expand([g, 1]) + offsets)
    }

    /// σ `[B, 1]` from the guidance logits `[B, 1]` (a constant in fixed mode).
    pub fn sigma(&self, logits: Tensor<2>) -> Tensor<2> {
        match self.mode {
            GateMode::Learned => sigmoid(logits),
            GateMode::Fixed => logits.zeros_like().detach() + self.value,
        }
    }

    /// The residual's amplitude `a(σ)` (Eq. 4's gate).
    pub fn amplitude(&self, sigma: Tensor<2>) -> Tensor<2> {
        match self.form {
            GateForm::Blend => sigma.clone() * (self.kappa - 1.0) + 1.0,
            GateForm::Sigma => sigma,
            GateForm::OneMinus => sigma * -1.0 + 1.0,
        }
    }

    /// The scalar reference of [`Self::amplitude`].
    pub fn amplitude_of(&self, sigma: f64) -> f64 {
        match self.form {
            GateForm::Blend => (1.0 - sigma) + self.kappa * sigma,
            GateForm::Sigma => sigma,
            GateForm::OneMinus => 1.0 - sigma,
        }
    }
}
