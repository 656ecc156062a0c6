//! Density control: where Gaussians are added and removed during training.
//!
//! - **Adaptive density control** (ADC, 3DGS §5.2): Gaussians whose mean screen-space position
//!   gradient exceeds a threshold are cloned (small ones) or split in two (large ones); nearly
//!   transparent ones, and after the first opacity reset over-large ones, are pruned; opacities
//!   are periodically reset so that floaters can die.
//! - **MCMC** (Kheradmand et al., "3D Gaussian Splatting as Markov Chain Monte Carlo", 2024):
//!   dead Gaussians are relocated onto live ones sampled by opacity with moment-preserving
//!   opacity and scale (their Eq. 9), the count grows by a fixed fraction up to a cap, positions
//!   get opacity-gated noise shaped by each covariance (their Eq. 7), and opacity and scale
//!   are regularised.
//!
//! Statistics are accumulated on the device every step; decisions are taken on the host every
//! `every` steps, where every row operation is mirrored in the optimiser's moments.

use crate::checkpoint::{Checkpoint, CheckpointError};
use crate::gaussians::{GaussianRows, GaussianSet};
use crate::host_f32 as host;
use crate::optimizer::GaussianOptimizer;
use burn::tensor::{Device, Gradients, Tensor, TensorData};
use serde::{Deserialize, Serialize};
use splatzoo_datasets::synth::rng::Rng;
use splatzoo_rasterizer::Render;
use std::ops::Range;

pub mod kl;
pub mod strategy;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Strategy {
    /// Clone, split, prune and opacity reset (3DGS).
    Adc,
    /// Relocation, growth to a cap, position noise and regularisers (3DGS-MCMC).
    Mcmc,
    /// A fixed set of Gaussians.
    None,
    /// ADC's growth where the KL divergence to the nearest neighbour exceeds `kl_split`,
    /// merging where it is below `kl_merge` (GauHuman; [`kl`]).
    Kl,
}

/// Every knob of density control. Step numbers are optimiser steps (1-based).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DensifyConfig {
    pub strategy: Strategy,
    /// Density decisions are taken at steps `start < step ≤ stop` that are multiples of `every`.
    pub start: usize,
    pub stop: usize,
    pub every: usize,
    /// Most Gaussians; growth stops there (both strategies).
    pub max_gaussians: usize,
    /// Opacity below which a Gaussian is dead (pruned by ADC, relocated by MCMC).
    pub min_opacity: f64,
    /// ADC: mean screen-position gradient that triggers growth, in INRIA's NDC units
    /// (`‖(∂L/∂x · W/2, ∂L/∂y · H/2)‖` with `x, y` in pixels), so 3DGS's 0.0002 carries over.
    pub grad_threshold: f64,
    /// ADC: Gaussians larger than this fraction of the scene extent split, smaller ones clone.
    pub percent_dense: f64,
    /// ADC: opacity reset to 0.01 every this many steps (0: never), while densifying.
    pub opacity_reset_every: usize,
    /// ADC, after the first opacity reset: prune Gaussians wider than this many pixels on
    /// screen, or than `max_world_scale` × extent in the world.
    pub max_screen_radius: f64,
    pub max_world_scale: f64,
    /// MCMC: fraction added at each growth step.
    pub growth: f64,
    /// MCMC: position noise scale (λ_noise; multiplies the position learning rate).
    pub noise_lr: f64,
    /// MCMC: weights of the mean-opacity and mean-scale regularisers.
    pub opacity_reg: f64,
    pub scale_reg: f64,
    /// KL: grow only Gaussians farther than this from their nearest neighbour, and merge
    /// pairs closer than `kl_merge` (GauHuman: 0.4 and 0.1).
    pub kl_split: f64,
    pub kl_merge: f64,
    /// ADC: prune-only decisions after these steps (HumanGaussian's late phase, no growth):
    /// rows with opacity below `prune_only_min_opacity` or a largest scale above
    /// `prune_only_max_scale` (world units) go.
    pub prune_only_steps: Vec<usize>,
    pub prune_only_min_opacity: f64,
    pub prune_only_max_scale: f64,
}

impl Default for DensifyConfig {
    /// 3DGS's schedule compressed to the default 2000-step run (growth over the first 60 %).
    fn default() -> Self {
        Self {
            strategy: Strategy::Adc,
            start: 200,
            stop: 1200,
            every: 100,
            max_gaussians: 200_000,
            min_opacity: 0.005,
            grad_threshold: 0.0002,
            percent_dense: 0.01,
            opacity_reset_every: 0,
            max_screen_radius: 20.0,
            max_world_scale: 0.1,
            growth: 0.05,
            noise_lr: 5e5,
            opacity_reg: 0.01,
            scale_reg: 0.01,
            kl_split: 0.4,
            kl_merge: 0.1,
            prune_only_steps: Vec::new(),
            prune_only_min_opacity: 0.005,
            prune_only_max_scale: f64::MAX,
        }
    }
}

impl DensifyConfig {
    /// Whether density decisions are taken after step `step` (1-based).
    pub fn refines_at(&self, step: usize) -> bool {
        self.strategy != Strategy::None
            && self.every > 0
            && step > self.start
            && step <= self.stop
            && step.is_multiple_of(self.every)
    }

    /// Whether ADC resets opacities after step `step`.
    pub fn resets_opacity_at(&self, step: usize) -> bool {
        self.strategy == Strategy::Adc
            && self.opacity_reset_every > 0
            && step <= self.stop
            && step.is_multiple_of(self.opacity_reset_every)
    }
}

/// Per-Gaussian statistics since the last density decision.
#[derive(Debug, Clone)]
pub struct DensityStats {
    /// `[N]` sum over views of the NDC-unit screen gradient norm, where visible.
    pub grad_sum: Tensor<1>,
    /// `[N]` views in which the Gaussian was visible.
    pub count: Tensor<1>,
    /// `[N]` largest screen radius seen, in pixels.
    pub max_radius: Tensor<1>,
}

impl DensityStats {
    pub fn new(n: usize, device: &Device) -> Self {
        Self {
            grad_sum: Tensor::zeros([n], device),
            count: Tensor::zeros([n], device),
            max_radius: Tensor::zeros([n], device),
        }
    }

    /// Adds one rendered view (after its backward pass); `range` is this set's rows in the
    /// render (the whole render for a one-node scene).
    pub fn record(&mut self, render: &Render, grads: &Gradients, range: Range<usize>) {
        let Some(offset_grad) = render.screen_offsets.grad(grads) else {
            return;
        };
        let device = offset_grad.device();
        let camera_half = |v: u32| v as f32 / 2.0;
        let [w, h] = [render.color.dims()[1] as u32, render.color.dims()[0] as u32];
        let to_ndc = Tensor::<2>::from_data(
            TensorData::new(vec![camera_half(w), camera_half(h)], [1, 2]),
            &device,
        );
        let norm = (offset_grad.slice(range.clone()) * to_ndc)
            .powi_scalar(2)
            .sum_dim(1)
            .sqrt()
            .squeeze_dim(1);
        let radii = render.radii.clone().inner().slice(range);
        let visible = radii.clone().greater_elem(0.0).float();
        self.grad_sum = self.grad_sum.clone() + norm * visible.clone();
        self.count = self.count.clone() + visible;
        self.max_radius = self.max_radius.clone().max_pair(radii);
    }

    pub fn save(&self, checkpoint: &mut Checkpoint, prefix: &str) {
        checkpoint.put(&format!("{prefix}.grad_sum"), &self.grad_sum);
        checkpoint.put(&format!("{prefix}.count"), &self.count);
        checkpoint.put(&format!("{prefix}.max_radius"), &self.max_radius);
    }

    pub fn load(
        checkpoint: &Checkpoint,
        prefix: &str,
        n: usize,
        device: &Device,
    ) -> Result<Self, CheckpointError> {
        let name = |s: &str| format!("{prefix}.{s}");
        Ok(Self {
            grad_sum: checkpoint.tensor(&name("grad_sum"), [Some(n)], device)?,
            count: checkpoint.tensor(&name("count"), [Some(n)], device)?,
            max_radius: checkpoint.tensor(&name("max_radius"), [Some(n)], device)?,
        })
    }
}

/// What one density decision did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct DensifyReport {
    pub cloned: usize,
    pub split: usize,
    pub pruned: usize,
    /// Pairs merged into one (KL density control).
    pub merged: usize,
    /// Of `pruned`, those farther from the node's mesh than KL density control allows.
    pub off_surface: usize,
    pub relocated: usize,
    pub added: usize,
}

fn logit(p: f64) -> f32 {
    (p / (1.0 - p)).ln() as f32
}

/// One ADC decision (3DGS §5.2): prune, clone, split; resets the statistics.
/// `prune_large` enables the screen- and world-size pruning (3DGS enables it after the first
/// opacity reset). `old_from_new` is overwritten with, for every row after the decision, the
/// row it was copied from (so per-row data a node keeps beside the set, such as skinning
/// weights, can follow).
#[allow(clippy::too_many_arguments)] // each is one input of the decision, as in 3DGS
pub fn adaptive_density_control(
    config: &DensifyConfig,
    set: &mut GaussianSet,
    optimizer: &mut GaussianOptimizer,
    stats: &mut DensityStats,
    extent: f64,
    prune_large: bool,
    rng: &mut Rng,
    old_from_new: &mut Vec<usize>,
) -> DensifyReport {
    let rows = set.to_rows();
    let n = rows.len();
    let (grad_sum, count, max_radius) = (
        host(&stats.grad_sum),
        host(&stats.count),
        host(&stats.max_radius),
    );
    let mut report = DensifyReport::default();
    let mut keep = Vec::with_capacity(n);
    let mut added = GaussianRows::default();
    let mut added_from = Vec::new();
    let mut budget = config.max_gaussians.saturating_sub(n);
    let dense = (config.percent_dense * extent) as f32;
    for i in 0..n {
        let scale = rows.scale(i);
        let largest = scale[0].max(scale[1]).max(scale[2]);
        let too_large = prune_large
            && (max_radius[i] as f64 > config.max_screen_radius
                || largest as f64 > config.max_world_scale * extent);
        if (rows.opacity(i) as f64) < config.min_opacity || too_large {
            report.pruned += 1;
            continue;
        }
        let mean_grad = grad_sum[i] / count[i].max(1.0);
        if budget == 0 || (mean_grad as f64) < config.grad_threshold {
            keep.push(i);
        } else if largest <= dense {
            keep.push(i);
            added.push_from(&rows, i);
            added_from.push(i);
            report.cloned += 1;
            budget -= 1;
        } else {
            push_split(&rows, i, &mut added, &mut added_from, rng);
            report.split += 1;
            budget -= 1;
        }
    }
    replace_rows(
        set,
        optimizer,
        stats,
        keep,
        &added,
        added_from,
        old_from_new,
    );
    report
}

/// Appends two samples of row `i` drawn from the Gaussian itself, each 1.6× narrower (3DGS's
/// split), recording `i` as their source.
pub(crate) fn push_split(
    rows: &GaussianRows,
    i: usize,
    added: &mut GaussianRows,
    added_from: &mut Vec<usize>,
    rng: &mut Rng,
) {
    let (mean, rotation, scale) = (rows.mean(i), rows.rotation(i), rows.scale(i));
    for _ in 0..2 {
        let z: [f32; 3] = std::array::from_fn(|k| rng.normal() as f32 * scale[k]);
        let row = added.len();
        added.push_from(rows, i);
        added_from.push(i);
        for a in 0..3 {
            added.means[3 * row + a] = mean[a] + (0..3).map(|b| rotation[a][b] * z[b]).sum::<f32>();
            added.log_scales[3 * row + a] = (scale[a] / 1.6).ln();
        }
    }
}

/// The set becomes rows `keep` followed by `added` (each from row `added_from`), the
/// optimiser's moments follow (new rows start at zero), the statistics restart, and
/// `old_from_new` receives the lineage.
pub(crate) fn replace_rows(
    set: &mut GaussianSet,
    optimizer: &mut GaussianOptimizer,
    stats: &mut DensityStats,
    keep: Vec<usize>,
    added: &GaussianRows,
    added_from: Vec<usize>,
    old_from_new: &mut Vec<usize>,
) {
    let device = set.means.device();
    *set = set
        .select(&keep)
        .append(&GaussianSet::from_rows(added, &device));
    optimizer.select(&keep);
    optimizer.grow(added.len());
    *stats = DensityStats::new(set.len(), &device);
    *old_from_new = keep;
    old_from_new.extend(added_from);
}

/// A prune-only decision: rows with opacity below `min_opacity` or a largest scale above
/// `max_scale` are removed (moments and statistics follow, `old_from_new` gets the lineage);
/// returns how many went.
pub fn prune_only(
    set: &mut GaussianSet,
    optimizer: &mut GaussianOptimizer,
    stats: &mut DensityStats,
    min_opacity: f64,
    max_scale: f64,
    old_from_new: &mut Vec<usize>,
) -> usize {
    let rows = set.to_rows();
    let keep: Vec<usize> = (0..rows.len())
        .filter(|&i| {
            let largest = rows.scale(i).into_iter().fold(0.0f32, f32::max);
            f64::from(rows.opacity(i)) >= min_opacity && f64::from(largest) <= max_scale
        })
        .collect();
    let pruned = rows.len() - keep.len();
    if pruned > 0 {
        replace_rows(
            set,
            optimizer,
            stats,
            keep,
            &GaussianRows::default(),
            Vec::new(),
            old_from_new,
        );
    }
    pruned
}

/// 3DGS's opacity reset: every opacity capped at 0.01, its optimiser state restarted.
pub fn reset_opacity(set: &mut GaussianSet, optimizer: &mut GaussianOptimizer) {
    set.opacity_logits = set.opacity_logits.clone().clamp_max(logit(0.01));
    optimizer.reset_opacity();
}

/// Eq. 9 of 3DGS-MCMC: the opacity and scale factor each of `copies` Gaussians gets when one
/// of opacity `opacity` is split into that many at the same place, so that the composite
/// opacity `1 − (1 − o′)ᴺ` and the density at the centre are preserved.
pub fn relocation(opacity: f64, copies: usize) -> (f64, f64) {
    let copies = copies.clamp(1, 51) as i32;
    let new = (1.0 - (1.0 - opacity).powf(1.0 / copies as f64)).clamp(1e-6, 1.0 - 1e-6);
    let mut denominator = 0.0;
    for i in 1..=copies {
        let mut binomial = 1.0; // C(i − 1, k)
        for k in 0..i {
            let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
            denominator += binomial * sign * new.powi(k + 1) / ((k + 1) as f64).sqrt();
            binomial = binomial * (i - 1 - k) as f64 / (k + 1) as f64;
        }
    }
    (new, opacity / denominator)
}

/// One MCMC decision: dead Gaussians (opacity below `min_opacity`) move onto live ones sampled
/// in proportion to opacity, then `growth` × N new ones are added the same way, up to the
/// cap. Sources and destinations share the Eq. 9 opacity and scale; their moments restart.
/// `old_from_new` is overwritten with the row each row after the decision was copied from
/// (itself where it did not move), as in [`adaptive_density_control`].
pub fn mcmc_relocate(
    config: &DensifyConfig,
    set: &mut GaussianSet,
    optimizer: &mut GaussianOptimizer,
    rng: &mut Rng,
    old_from_new: &mut Vec<usize>,
) -> DensifyReport {
    let mut rows = set.to_rows();
    let n = rows.len();
    let opacity: Vec<f64> = (0..n).map(|i| rows.opacity(i) as f64).collect();
    let dead: Vec<usize> = (0..n)
        .filter(|&i| opacity[i] <= config.min_opacity)
        .collect();
    let mut cumulative = Vec::with_capacity(n);
    let mut total = 0.0;
    for &o in &opacity {
        total += if o > config.min_opacity { o } else { 0.0 };
        cumulative.push(total);
    }
    if total <= 0.0 {
        return DensifyReport::default();
    }
    let mut sample = || {
        let u = rng.next() * total;
        cumulative.partition_point(|&c| c <= u).min(n - 1)
    };
    let mut copies = vec![0usize; n];
    let moved: Vec<(usize, usize)> = dead
        .iter()
        .map(|&d| {
            let s = sample();
            copies[s] += 1;
            (d, s)
        })
        .collect();
    let target = ((n as f64 * (1.0 + config.growth)) as usize).min(config.max_gaussians);
    let new_sources: Vec<usize> = (n..target.max(n))
        .map(|_| {
            let s = sample();
            copies[s] += 1;
            s
        })
        .collect();
    let mut restart = vec![false; n];
    for (i, &c) in copies.iter().enumerate() {
        if c > 0 {
            let (o, factor) = relocation(opacity[i], c + 1);
            rows.opacity_logits[i] = logit(o);
            for k in 0..3 {
                rows.log_scales[3 * i + k] += factor.ln() as f32;
            }
            restart[i] = true;
        }
    }
    let mut relocated = GaussianRows::default();
    for &(_, s) in &moved {
        relocated.push_from(&rows, s);
    }
    for (k, &(d, _)) in moved.iter().enumerate() {
        rows.means[3 * d..3 * d + 3].copy_from_slice(&relocated.means[3 * k..3 * k + 3]);
        rows.quats[4 * d..4 * d + 4].copy_from_slice(&relocated.quats[4 * k..4 * k + 4]);
        rows.log_scales[3 * d..3 * d + 3].copy_from_slice(&relocated.log_scales[3 * k..3 * k + 3]);
        rows.opacity_logits[d] = relocated.opacity_logits[k];
        rows.sh_dc[3 * d..3 * d + 3].copy_from_slice(&relocated.sh_dc[3 * k..3 * k + 3]);
        let r = rows.sh_rest.len() / n;
        rows.sh_rest[r * d..r * d + r].copy_from_slice(&relocated.sh_rest[r * k..r * k + r]);
        restart[d] = true;
    }
    let mut added = GaussianRows::default();
    for &s in &new_sources {
        added.push_from(&rows, s);
    }
    *old_from_new = (0..n).collect();
    for &(d, s) in &moved {
        old_from_new[d] = s;
    }
    old_from_new.extend(&new_sources);
    let device = set.means.device();
    *set = GaussianSet::from_rows(&rows, &device).append(&GaussianSet::from_rows(&added, &device));
    optimizer.restart_rows(&restart);
    optimizer.grow(added.len());
    DensifyReport {
        relocated: moved.len(),
        added: added.len(),
        ..Default::default()
    }
}

/// Eq. 7 of 3DGS-MCMC: after each step, every mean moves by
/// `λ_noise · lr · σ(−k (o − t)) · Σ η` with `η ~ N(0, I)`, `k = 100`, `t = 0.005` and `Σ`
/// the Gaussian's covariance, so nearly transparent Gaussians explore and opaque ones stay.
pub fn mcmc_noise(config: &DensifyConfig, set: &mut GaussianSet, means_rate: f64, rng: &mut Rng) {
    let rows = GaussianRows {
        quats: host(&set.quats),
        log_scales: host(&set.log_scales),
        opacity_logits: host(&set.opacity_logits),
        ..Default::default()
    };
    let n = rows.len();
    let mut noise = vec![0.0f32; 3 * n];
    for i in 0..n {
        let gate = 1.0 / (1.0 + (100.0 * (rows.opacity(i) as f64 - 0.005)).exp());
        let r = rows.rotation(i);
        let s = rows.scale(i);
        let eta: [f32; 3] = std::array::from_fn(|_| rng.normal() as f32);
        // Σ η = R S² Rᵀ η.
        let local: [f32; 3] =
            std::array::from_fn(|b| s[b] * s[b] * (0..3).map(|a| r[a][b] * eta[a]).sum::<f32>());
        let step = (config.noise_lr * means_rate * gate) as f32;
        for a in 0..3 {
            noise[3 * i + a] = step * (0..3).map(|b| r[a][b] * local[b]).sum::<f32>();
        }
    }
    let device = set.means.device();
    set.means = set.means.clone() + Tensor::from_data(TensorData::new(noise, [n, 3]), &device);
}

/// The MCMC regularisers `λ_o · mean(opacity) + λ_Σ · mean(scale)` on the step's leaves.
pub fn mcmc_regulariser(config: &DensifyConfig, leaves: &GaussianSet) -> Tensor<1> {
    let opacity = burn::tensor::activation::sigmoid(leaves.opacity_logits.clone()).mean();
    let scale = leaves.log_scales.clone().exp().mean();
    opacity * config.opacity_reg + scale * config.scale_reg
}
