//! Density control as a strategy a scene node owns: the node hands its strategy the renders of
//! each step (for statistics), asks it for regularisers on the step's leaves, and after the
//! optimiser step lets it add, remove or move rows of its Gaussian set, mirrored in the node's
//! optimiser moments. [`Adc`], [`Mcmc`], [`Fixed`] and GauHuman's
//! [`super::kl::KlDensity`] are the strategies so far; a method picks
//! one per node through [`DensifyConfig::strategy`] and [`strategy`].

use super::{
    DensifyConfig, DensifyReport, DensityStats, Strategy, adaptive_density_control, mcmc_noise,
    mcmc_regulariser, mcmc_relocate, prune_only, reset_opacity,
};
use crate::checkpoint::{Checkpoint, CheckpointError};
use crate::gaussians::GaussianSet;
use crate::optimizer::GaussianOptimizer;
use burn::tensor::{Device, Gradients, Tensor};
use splatzoo_datasets::synth::rng::Rng;
use splatzoo_rasterizer::Render;
use std::ops::Range;

/// What a strategy may change after an optimiser step.
pub struct RowEdit<'a> {
    pub set: &'a mut GaussianSet,
    pub optimizer: &'a mut GaussianOptimizer,
    pub rng: &'a mut Rng,
    /// Optimiser steps taken so far (the step just applied; 1-based).
    pub step: usize,
    /// Training progress in [0, 1] (for the position learning rate).
    pub progress: f64,
    /// Left alone when no row moved; otherwise overwritten with, for every row after the
    /// edit, the row before it that it was copied from (see [`adaptive_density_control`]).
    pub old_from_new: &'a mut Vec<usize>,
}

pub trait DensityStrategy {
    fn kind(&self) -> Strategy;
    /// A loss term on the step's leaves (MCMC's opacity and scale regularisers).
    fn regulariser(&self, _leaves: &GaussianSet) -> Option<Tensor<1>> {
        None
    }
    /// Statistics from one render of the step; `rows` are the node's rows in it.
    fn observe(&mut self, _render: &Render, _grads: &Gradients, _rows: Range<usize>) {}
    /// Density decisions after the optimiser step.
    fn after_step(&mut self, edit: RowEdit<'_>) -> Option<DensifyReport>;
    fn save(&self, _checkpoint: &mut Checkpoint, _prefix: &str) {}
    /// Restores the state saved under `prefix` for a set of `rows` Gaussians.
    fn load(
        &mut self,
        _checkpoint: &Checkpoint,
        _prefix: &str,
        _rows: usize,
        _device: &Device,
    ) -> Result<(), CheckpointError> {
        Ok(())
    }
}

/// The strategy `config` names, for a node of `rows` Gaussians in a scene of `extent` metres.
pub fn strategy(
    config: &DensifyConfig,
    rows: usize,
    extent: f64,
    device: &Device,
) -> Box<dyn DensityStrategy> {
    match config.strategy {
        Strategy::Adc => Box::new(Adc {
            config: config.clone(),
            stats: DensityStats::new(rows, device),
            extent,
            opacity_resets: 0,
        }),
        Strategy::Mcmc => Box::new(Mcmc {
            config: config.clone(),
        }),
        Strategy::None => Box::new(Fixed),
        Strategy::Kl => Box::new(super::kl::KlDensity {
            config: config.clone(),
            stats: DensityStats::new(rows, device),
            extent,
            surface: None,
        }),
    }
}

/// 3DGS's adaptive density control: screen-gradient statistics, clone/split/prune on the
/// schedule, opacity resets.
pub struct Adc {
    pub config: DensifyConfig,
    pub stats: DensityStats,
    /// Scene extent in metres (split threshold and world-size pruning).
    pub extent: f64,
    opacity_resets: usize,
}

impl DensityStrategy for Adc {
    fn kind(&self) -> Strategy {
        Strategy::Adc
    }

    fn observe(&mut self, render: &Render, grads: &Gradients, rows: Range<usize>) {
        self.stats.record(render, grads, rows);
    }

    fn after_step(&mut self, edit: RowEdit<'_>) -> Option<DensifyReport> {
        let mut report = None;
        if self.config.refines_at(edit.step) {
            report = Some(adaptive_density_control(
                &self.config,
                edit.set,
                edit.optimizer,
                &mut self.stats,
                self.extent,
                self.opacity_resets > 0,
                edit.rng,
                edit.old_from_new,
            ));
        }
        if self.config.resets_opacity_at(edit.step) {
            reset_opacity(edit.set, edit.optimizer);
            self.opacity_resets += 1;
        }
        if self.config.prune_only_steps.contains(&edit.step) {
            let pruned = prune_only(
                edit.set,
                edit.optimizer,
                &mut self.stats,
                self.config.prune_only_min_opacity,
                self.config.prune_only_max_scale,
                edit.old_from_new,
            );
            report = Some(DensifyReport {
                pruned,
                ..DensifyReport::default()
            });
        }
        report
    }

    fn save(&self, checkpoint: &mut Checkpoint, prefix: &str) {
        self.stats.save(checkpoint, prefix);
        checkpoint.put_meta(&format!("{prefix}.opacity_resets"), self.opacity_resets);
    }

    fn load(
        &mut self,
        checkpoint: &Checkpoint,
        prefix: &str,
        rows: usize,
        device: &Device,
    ) -> Result<(), CheckpointError> {
        self.stats = DensityStats::load(checkpoint, prefix, rows, device)?;
        self.opacity_resets = checkpoint.meta_parsed(&format!("{prefix}.opacity_resets"))?;
        Ok(())
    }
}

/// 3DGS-MCMC: regularisers, position noise every step, relocation and growth on the schedule.
pub struct Mcmc {
    pub config: DensifyConfig,
}

impl DensityStrategy for Mcmc {
    fn kind(&self) -> Strategy {
        Strategy::Mcmc
    }

    fn regulariser(&self, leaves: &GaussianSet) -> Option<Tensor<1>> {
        Some(mcmc_regulariser(&self.config, leaves))
    }

    fn after_step(&mut self, edit: RowEdit<'_>) -> Option<DensifyReport> {
        let rate = edit.optimizer.means_rate(edit.progress);
        mcmc_noise(&self.config, edit.set, rate, edit.rng);
        self.config.refines_at(edit.step).then(|| {
            mcmc_relocate(
                &self.config,
                edit.set,
                edit.optimizer,
                edit.rng,
                edit.old_from_new,
            )
        })
    }
}

/// A fixed set of Gaussians.
pub struct Fixed;

impl DensityStrategy for Fixed {
    fn kind(&self) -> Strategy {
        Strategy::None
    }

    fn after_step(&mut self, _edit: RowEdit<'_>) -> Option<DensifyReport> {
        None
    }
}
