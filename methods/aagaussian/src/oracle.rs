//! The in-project guidance (S1 and S2 of the spec): the exact MMSE denoiser of an explicit data
//! set. The data are K identities seen from the sampled camera ([`Targets`]), each blurred by a
//! Gaussian of standard deviation `s` (the data noise), so for a noisy `x_t = α_t x_0 + σ_t ε`
//!
//! `ε*(x_t) = Σ_k π_k σ_t (x_t − α_t y_k) / (α_t² s² + σ_t²)`,
//! `π_k = softmax_k(−‖x_t − α_t y_k‖² / (2 (α_t² s² + σ_t²)))`,
//! `x̂_0 = Σ_k π_k (y_k + α_t s² (x_t − α_t y_k) / (α_t² s² + σ_t²))`,
//!
//! evaluated in f64 with a log-sum-exp. A prompt is an identity label: the `Cond` rows use the
//! prompted identities, `Null` the unconditional set (every identity by default), `Negative`
//! the negative ones. With one identity and `s = 0` it is the point-mass oracle S1, for which
//! SDS is exactly a weighted L2 (`g = w_t α_t (x − y)/σ_t`). The joint (RGB, depth) item is one
//! data point, so both branches share π (one t per item, as the paper's Eq. 5 does).
//!
//! This is not text-to-3D: it is a prior whose optimum is known, so the distillation machinery
//! (t, noise, guidance, weighting, clipping, the rasterizer chain) is checkable against formulas.

use crate::error::AagError;
use crate::schedule::NoiseSchedule;
use crate::score::{Conditioning, LatentBatch, Prediction, PromptKind, ScoreModel, v_from};
use rayon::prelude::*;
use splatzoo_rasterizer::Camera;

/// A data set seen from any camera: identity `label`'s branches at `camera`, each `[C, H, W]`
/// in the model's space.
pub trait Targets: Send + Sync {
    /// Number of identities K.
    fn count(&self) -> usize;
    fn target(&self, label: usize, camera: &Camera) -> Vec<Vec<f32>>;
}

/// The same images from every camera (tests, and the one-camera fixed-point checks).
#[derive(Debug, Clone)]
pub struct FixedTargets {
    /// `[label][branch]` flattened `[C, H, W]`.
    pub images: Vec<Vec<Vec<f32>>>,
}

impl Targets for FixedTargets {
    fn count(&self) -> usize {
        self.images.len()
    }

    fn target(&self, label: usize, _camera: &Camera) -> Vec<Vec<f32>> {
        self.images[label].clone()
    }
}

/// Which identities each prompt row stands for.
#[derive(Debug, Clone, PartialEq)]
pub struct Components {
    pub cond: Vec<usize>,
    pub negative: Vec<usize>,
    pub null: Vec<usize>,
}

impl Components {
    /// Prompted identity `cond`, negative `negative`, unconditional over all `count`.
    pub fn labels(cond: usize, negative: usize, count: usize) -> Self {
        Self {
            cond: vec![cond],
            negative: vec![negative],
            null: (0..count).collect(),
        }
    }

    fn of(&self, kind: PromptKind) -> &[usize] {
        match kind {
            PromptKind::Cond => &self.cond,
            PromptKind::Negative => &self.negative,
            PromptKind::Null => &self.null,
        }
    }
}

/// The mixture oracle (S2; S1 with one identity and `data_noise = 0`).
pub struct MixtureOracle {
    pub schedule: NoiseSchedule,
    pub prediction: Prediction,
    /// s: standard deviation of each identity's blur, in model units.
    pub data_noise: f64,
    pub components: Components,
    pub branches: usize,
    pub targets: Box<dyn Targets>,
}

/// The posterior under one set of components, for one item: `(ε̂, x̂_0)` over all branches.
pub fn posterior(
    x_t: &[f64],
    targets: &[Vec<f64>],
    alpha: f64,
    sigma: f64,
    data_noise: f64,
) -> (Vec<f64>, Vec<f64>) {
    let spread = alpha * alpha * data_noise * data_noise + sigma * sigma;
    let logits: Vec<f64> = targets
        .iter()
        .map(|y| {
            let d2: f64 = x_t
                .iter()
                .zip(y)
                .map(|(x, y)| (x - alpha * y).powi(2))
                .sum();
            -d2 / (2.0 * spread)
        })
        .collect();
    let top = logits.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let weights: Vec<f64> = logits.iter().map(|l| (l - top).exp()).collect();
    let total: f64 = weights.iter().sum();
    let mut epsilon = vec![0.0; x_t.len()];
    let mut x0 = vec![0.0; x_t.len()];
    for (y, w) in targets.iter().zip(&weights) {
        let pi = w / total;
        for i in 0..x_t.len() {
            let residual = x_t[i] - alpha * y[i];
            epsilon[i] += pi * sigma * residual / spread;
            x0[i] += pi * (y[i] + alpha * data_noise * data_noise * residual / spread);
        }
    }
    (epsilon, x0)
}

impl MixtureOracle {
    fn check(
        &self,
        noisy: &[LatentBatch],
        t: &[usize],
        cond: &Conditioning,
    ) -> Result<(), AagError> {
        if noisy.len() != self.branches {
            return Err(AagError::input(
                "oracle",
                format!(
                    "{} branches given, the model has {}",
                    noisy.len(),
                    self.branches
                ),
            ));
        }
        for (k, batch) in noisy.iter().enumerate() {
            if batch.shape[0] != t.len() || batch.shape[0] != cond.len() {
                return Err(AagError::input(
                    "oracle",
                    format!(
                        "branch {k}: batch {} but {} timesteps and {} conditioning rows",
                        batch.shape[0],
                        t.len(),
                        cond.len()
                    ),
                ));
            }
        }
        let k = self.targets.count();
        for label in [
            &self.components.cond,
            &self.components.negative,
            &self.components.null,
        ]
        .into_iter()
        .flatten()
        {
            if *label >= k {
                return Err(AagError::input(
                    "oracle",
                    format!("identity label {label} but the bank holds {k}"),
                ));
            }
        }
        Ok(())
    }
}

impl ScoreModel for MixtureOracle {
    fn schedule(&self) -> &NoiseSchedule {
        &self.schedule
    }

    fn prediction(&self) -> Prediction {
        self.prediction
    }

    fn branches(&self) -> usize {
        self.branches
    }

    fn predict(
        &self,
        noisy: &[LatentBatch],
        t: &[usize],
        cond: &Conditioning,
    ) -> Result<Vec<LatentBatch>, AagError> {
        self.check(noisy, t, cond)?;
        // Render each distinct camera's identities once (the CFG rows repeat the cameras).
        let mut distinct: Vec<Camera> = Vec::new();
        let camera_of_item: Vec<usize> = cond
            .cameras
            .iter()
            .map(|c| match distinct.iter().position(|d| d == c) {
                Some(i) => i,
                None => {
                    distinct.push(*c);
                    distinct.len() - 1
                }
            })
            .collect();
        let k = self.targets.count();
        let bank: Vec<Vec<Vec<f64>>> = distinct
            .par_iter()
            .map(|camera| {
                (0..k)
                    .map(|label| {
                        // A one-branch model denoises the targets' RGB alone.
                        let branches = self.targets.target(label, camera);
                        branches
                            .into_iter()
                            .take(self.branches)
                            .flatten()
                            .map(f64::from)
                            .collect()
                    })
                    .collect()
            })
            .collect();
        let lens: Vec<usize> = noisy.iter().map(|b| b.item_len()).collect();
        let joint = lens.iter().sum::<usize>();
        if let Some(bad) = bank.iter().flatten().find(|y| y.len() != joint) {
            return Err(AagError::input(
                "oracle",
                format!(
                    "a target holds {} values, the noisy input {joint}",
                    bad.len()
                ),
            ));
        }
        let items: Vec<Vec<f64>> = (0..t.len())
            .into_par_iter()
            .map(|i| {
                let x_t: Vec<f64> = noisy
                    .iter()
                    .flat_map(|b| b.item(i).iter().map(|&v| f64::from(v)))
                    .collect();
                let (alpha, sigma) = (self.schedule.alpha(t[i]), self.schedule.sigma(t[i]));
                let labels = self.components.of(cond.prompts[i]);
                let targets: Vec<Vec<f64>> = labels
                    .iter()
                    .map(|&l| bank[camera_of_item[i]][l].clone())
                    .collect();
                let (epsilon, x0) = posterior(&x_t, &targets, alpha, sigma, self.data_noise);
                match self.prediction {
                    Prediction::Epsilon => epsilon,
                    Prediction::V => epsilon
                        .iter()
                        .zip(&x0)
                        .map(|(e, x)| v_from(*e, *x, alpha, sigma))
                        .collect(),
                }
            })
            .collect();
        let mut out: Vec<LatentBatch> = noisy.iter().map(|b| LatentBatch::zeros(b.shape)).collect();
        for (i, item) in items.iter().enumerate() {
            let mut offset = 0;
            for (branch, len) in out.iter_mut().zip(&lens) {
                for (o, v) in branch
                    .item_mut(i)
                    .iter_mut()
                    .zip(&item[offset..offset + len])
                {
                    *o = *v as f32;
                }
                offset += len;
            }
        }
        Ok(out)
    }
}
