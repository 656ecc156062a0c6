//! The diffusion noise schedule SDS samples from (Eq. 3 of AAGaussian: `x_t = α_t x + σ_t ε`
//! with `α_t = √ᾱ_t`, `σ_t = √(1 − ᾱ_t)`) and the timestep distribution with its annealing.
//!
//! - [`NoiseSchedule::scaled_linear`]: Stable Diffusion 2's schedule (β from 0.00085 to 0.012,
//!   linear in √β, T = 1000), so ᾱ_0 = 0.99915 and ᾱ_999 = 0.00466.
//! - [`NoiseSchedule::zero_snr`]: the same rescaled to zero terminal SNR (Lin et al. 2024,
//!   Algorithm 1), the schedule of HumanGaussian's v-prediction UNet: ᾱ_999 = 0 exactly.
//! - [`TimestepRange`]: `t ~ U{t_min..=t_max}` per batch element, `t_max` dropping to
//!   `t_max_annealed` after `anneal_step` optimiser steps (HumanGaussian: {20..980}, then
//!   {20..550} after step 1500).

use serde::{Deserialize, Serialize};
use splatzoo_datasets::synth::rng::Rng;

/// Which schedule a model was trained on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum ScheduleKind {
    /// SD-2 `scaled_linear`.
    ScaledLinear,
    /// SD-2 `scaled_linear` rescaled to zero terminal SNR.
    ZeroSnr,
}

/// `ᾱ_t` for `t = 0..T`, in f64.
#[derive(Debug, Clone, PartialEq)]
pub struct NoiseSchedule {
    alphas_cumprod: Vec<f64>,
}

impl NoiseSchedule {
    /// β_t = (√β_0 + t/(T−1) (√β_1 − √β_0))², ᾱ_t = Π_{s≤t} (1 − β_s).
    pub fn scaled_linear(beta_start: f64, beta_end: f64, steps: usize) -> Self {
        assert!(steps >= 2, "a schedule needs at least two steps");
        let (a, b) = (beta_start.sqrt(), beta_end.sqrt());
        let mut product = 1.0;
        let alphas_cumprod = (0..steps)
            .map(|t| {
                let root = a + (b - a) * t as f64 / (steps - 1) as f64;
                product *= 1.0 - root * root;
                product
            })
            .collect();
        Self { alphas_cumprod }
    }

    /// Stable Diffusion 2's schedule (the base pipeline's scheduler constants).
    pub fn sd2() -> Self {
        Self::scaled_linear(0.00085, 0.012, 1000)
    }

    /// `self` rescaled so that `√ᾱ` keeps its first value and reaches 0 at the last step,
    /// linearly in between (Lin et al., "Common diffusion noise schedules and sample steps are
    /// flawed", Algorithm 1).
    pub fn zero_snr(&self) -> Self {
        let roots: Vec<f64> = self.alphas_cumprod.iter().map(|a| a.sqrt()).collect();
        let (first, last) = (roots[0], roots[roots.len() - 1]);
        let alphas_cumprod = roots
            .iter()
            .map(|r| {
                let rescaled = (r - last) * first / (first - last);
                rescaled * rescaled
            })
            .collect();
        Self { alphas_cumprod }
    }

    pub fn of(kind: ScheduleKind) -> Self {
        match kind {
            ScheduleKind::ScaledLinear => Self::sd2(),
            ScheduleKind::ZeroSnr => Self::sd2().zero_snr(),
        }
    }

    /// Number of timesteps T.
    pub fn len(&self) -> usize {
        self.alphas_cumprod.len()
    }

    pub fn is_empty(&self) -> bool {
        self.alphas_cumprod.is_empty()
    }

    /// ᾱ_t.
    pub fn alpha_bar(&self, t: usize) -> f64 {
        self.alphas_cumprod[t]
    }

    /// α_t = √ᾱ_t (Eq. 3).
    pub fn alpha(&self, t: usize) -> f64 {
        self.alphas_cumprod[t].sqrt()
    }

    /// σ_t = √(1 − ᾱ_t) (Eq. 3).
    pub fn sigma(&self, t: usize) -> f64 {
        (1.0 - self.alphas_cumprod[t]).max(0.0).sqrt()
    }
}

/// Where t is drawn from and when the range shrinks.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TimestepRange {
    pub t_min: usize,
    pub t_max: usize,
    /// `t_max` after `anneal_step` optimiser steps.
    pub t_max_annealed: usize,
    /// Steps (0-based step index ≥ this) drawn from the annealed range; `usize::MAX`: never.
    pub anneal_step: usize,
}

impl Default for TimestepRange {
    /// HumanGaussian's: 0.02 and 0.98 of T, then 0.55 after step 1500.
    fn default() -> Self {
        Self {
            t_min: 20,
            t_max: 980,
            t_max_annealed: 550,
            anneal_step: 1500,
        }
    }
}

impl TimestepRange {
    /// The inclusive range at optimiser step `step` (0-based: the step about to be taken).
    pub fn at(&self, step: usize) -> (usize, usize) {
        if step >= self.anneal_step {
            (self.t_min, self.t_max_annealed)
        } else {
            (self.t_min, self.t_max)
        }
    }

    /// One t per batch element, uniform on the range at `step`.
    pub fn sample(&self, step: usize, batch: usize, rng: &mut Rng) -> Vec<usize> {
        let (lo, hi) = self.at(step);
        (0..batch).map(|_| lo + rng.below(hi - lo + 1)).collect()
    }

    /// Every range must lie inside a schedule of `steps` timesteps.
    pub fn validate(&self, steps: usize) -> Result<(), String> {
        if self.t_min > self.t_max || self.t_min > self.t_max_annealed {
            return Err(format!(
                "sds.timesteps: t_min {} must not exceed t_max {} or t_max_annealed {}",
                self.t_min, self.t_max, self.t_max_annealed
            ));
        }
        if self.t_max >= steps || self.t_max_annealed >= steps {
            return Err(format!(
                "sds.timesteps: t_max {} and t_max_annealed {} must be below the schedule's {steps} steps",
                self.t_max, self.t_max_annealed
            ));
        }
        Ok(())
    }
}
