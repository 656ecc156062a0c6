//! The 3DGS optimiser: one Adam state per parameter tensor of a [`GaussianSet`], each group with
//! its own learning rate (the INRIA defaults), positions decaying exponentially over training
//! and scaled by the scene extent.

use crate::adam::{AdamConfig, AdamState};
use crate::checkpoint::{Checkpoint, CheckpointError};
use crate::gaussians::GaussianSet;
use burn::tensor::{Gradients, Int, Tensor, TensorData};
use serde::{Deserialize, Serialize};

/// Learning rate per parameter group.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LearningRates {
    /// Positions at the start and the end of training, per metre of scene extent.
    pub means_start: f64,
    pub means_end: f64,
    pub quats: f64,
    pub log_scales: f64,
    pub opacity: f64,
    pub sh_dc: f64,
    pub sh_rest: f64,
}

impl Default for LearningRates {
    /// INRIA 3DGS: positions 1.6e-4 → 1.6e-6, rotation 1e-3, scaling 5e-3, opacity 0.05,
    /// features DC 2.5e-3 and rest 1/20 of it.
    fn default() -> Self {
        Self {
            means_start: 1.6e-4,
            means_end: 1.6e-6,
            quats: 1e-3,
            log_scales: 5e-3,
            opacity: 0.05,
            sh_dc: 2.5e-3,
            sh_rest: 2.5e-3 / 20.0,
        }
    }
}

pub struct GaussianOptimizer {
    pub config: AdamConfig,
    pub rates: LearningRates,
    /// Scene extent in metres (scales the position rate).
    pub extent: f64,
    means: AdamState<2>,
    quats: AdamState<2>,
    log_scales: AdamState<2>,
    opacity: AdamState<1>,
    sh_dc: AdamState<3>,
    sh_rest: AdamState<3>,
}

impl GaussianOptimizer {
    pub fn new(set: &GaussianSet, rates: LearningRates, extent: f64) -> Self {
        Self {
            config: AdamConfig::default(),
            rates,
            extent,
            means: AdamState::new(&set.means),
            quats: AdamState::new(&set.quats),
            log_scales: AdamState::new(&set.log_scales),
            opacity: AdamState::new(&set.opacity_logits),
            sh_dc: AdamState::new(&set.sh_dc),
            sh_rest: AdamState::new(&set.sh_rest),
        }
    }

    /// The position learning rate at `progress` ∈ [0, 1] (log-linear from start to end).
    pub fn means_rate(&self, progress: f64) -> f64 {
        let r = &self.rates;
        let t = progress.clamp(0.0, 1.0);
        if r.means_start <= 0.0 || r.means_end <= 0.0 {
            // No log-linear path through zero (ln 0 · 0 is NaN): linear, so 0 → 0 freezes.
            return self.extent * (r.means_start * (1.0 - t) + r.means_end * t);
        }
        self.extent * (r.means_start.ln() * (1.0 - t) + r.means_end.ln() * t).exp()
    }

    /// One step on `set` from the gradients of `leaves` (taken from `set` for this step). A
    /// group whose leaf got no gradient (a method that renders a fixed value in its place, say
    /// an avatar's constant opacity) keeps its values and moments.
    pub fn step(
        &mut self,
        set: &mut GaussianSet,
        leaves: &GaussianSet,
        grads: &Gradients,
        progress: f64,
    ) {
        fn group<const D: usize>(
            adam: &mut AdamState<D>,
            value: &mut Tensor<D>,
            leaf: &Tensor<D>,
            grads: &Gradients,
            rate: f64,
            config: &AdamConfig,
        ) {
            if let Some(g) = leaf.grad(grads) {
                *value = adam.step(value.clone(), g, rate, config);
            }
        }
        let (c, r) = (self.config, self.rates);
        let means_rate = self.means_rate(progress);
        group(
            &mut self.means,
            &mut set.means,
            &leaves.means,
            grads,
            means_rate,
            &c,
        );
        group(
            &mut self.quats,
            &mut set.quats,
            &leaves.quats,
            grads,
            r.quats,
            &c,
        );
        group(
            &mut self.log_scales,
            &mut set.log_scales,
            &leaves.log_scales,
            grads,
            r.log_scales,
            &c,
        );
        group(
            &mut self.opacity,
            &mut set.opacity_logits,
            &leaves.opacity_logits,
            grads,
            r.opacity,
            &c,
        );
        group(
            &mut self.sh_dc,
            &mut set.sh_dc,
            &leaves.sh_dc,
            grads,
            r.sh_dc,
            &c,
        );
        group(
            &mut self.sh_rest,
            &mut set.sh_rest,
            &leaves.sh_rest,
            grads,
            r.sh_rest,
            &c,
        );
    }

    /// Keeps the moments of rows `index` (in that order), as [`GaussianSet::select`] does.
    pub fn select(&mut self, index: &[usize]) {
        let device = self.means.first.device();
        let index = Tensor::<1, Int>::from_data(
            TensorData::new(index.iter().map(|&i| i as i64).collect(), [index.len()]),
            &device,
        );
        self.means.select(index.clone());
        self.quats.select(index.clone());
        self.log_scales.select(index.clone());
        self.opacity.select(index.clone());
        self.sh_dc.select(index.clone());
        self.sh_rest.select(index);
    }

    /// Appends `count` rows of fresh state, as [`GaussianSet::append`] does.
    pub fn grow(&mut self, count: usize) {
        self.means.grow(count);
        self.quats.grow(count);
        self.log_scales.grow(count);
        self.opacity.grow(count);
        self.sh_dc.grow(count);
        self.sh_rest.grow(count);
    }

    /// Restarts the rows where `restart[i]` is true.
    pub fn restart_rows(&mut self, restart: &[bool]) {
        let factor: Vec<f32> = restart.iter().map(|&r| if r { 0.0 } else { 1.0 }).collect();
        let factor = Tensor::<1>::from_data(
            TensorData::new(factor, [restart.len()]),
            &self.means.first.device(),
        );
        self.means.scale_rows(factor.clone());
        self.quats.scale_rows(factor.clone());
        self.log_scales.scale_rows(factor.clone());
        self.opacity.scale_rows(factor.clone());
        self.sh_dc.scale_rows(factor.clone());
        self.sh_rest.scale_rows(factor);
    }

    /// Restarts the opacity group (after an opacity reset, as 3DGS does).
    pub fn reset_opacity(&mut self) {
        self.opacity.reset();
    }

    /// Stores every group's state under `{prefix}.{group}` (the parameter names of
    /// [`GaussianSet::save`]).
    pub fn save(&self, checkpoint: &mut Checkpoint, prefix: &str) {
        let name = |s: &str| format!("{prefix}.{s}");
        self.means.save(checkpoint, &name("means"));
        self.quats.save(checkpoint, &name("quats"));
        self.log_scales.save(checkpoint, &name("scales"));
        self.opacity.save(checkpoint, &name("opacities"));
        self.sh_dc.save(checkpoint, &name("sh0"));
        self.sh_rest.save(checkpoint, &name("shN"));
    }

    /// The state saved by [`Self::save`] for `set`.
    pub fn load(
        checkpoint: &Checkpoint,
        prefix: &str,
        set: &GaussianSet,
        rates: LearningRates,
        extent: f64,
    ) -> Result<Self, CheckpointError> {
        let name = |s: &str| format!("{prefix}.{s}");
        Ok(Self {
            config: AdamConfig::default(),
            rates,
            extent,
            means: AdamState::load(checkpoint, &name("means"), &set.means)?,
            quats: AdamState::load(checkpoint, &name("quats"), &set.quats)?,
            log_scales: AdamState::load(checkpoint, &name("scales"), &set.log_scales)?,
            opacity: AdamState::load(checkpoint, &name("opacities"), &set.opacity_logits)?,
            sh_dc: AdamState::load(checkpoint, &name("sh0"), &set.sh_dc)?,
            sh_rest: AdamState::load(checkpoint, &name("shN"), &set.sh_rest)?,
        })
    }
}
