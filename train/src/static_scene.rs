//! The 3DGS training loop for a static scene: one [`StaticNode`] in a [`SceneGraph`], Adam with
//! the 3DGS learning rates, `(1 − λ) L1 + λ D-SSIM`, SH degree raised on a schedule, and ADC or
//! MCMC density control. Its whole state (parameters, moments, density statistics, random
//! state, the pending view order) goes into one checkpoint, so a resumed run continues bit for
//! bit. `train-3dgs` drives it; later methods reuse it as their scene-prior stage.

use crate::backend::Backend;
use crate::checkpoint::{Checkpoint, CheckpointError};
use crate::densify::{
    DensifyConfig, DensifyReport, DensityStats, Strategy, adaptive_density_control, mcmc_noise,
    mcmc_regulariser, mcmc_relocate, reset_opacity,
};
use crate::gaussians::GaussianSet;
use crate::loss::{photometric, psnr, scalar, ssim};
use crate::lpips::Lpips;
use crate::optimizer::{GaussianOptimizer, LearningRates};
use crate::scene_graph::{FrameQuery, SceneGraph, StaticNode};
use crate::views::{DataConfig, DataError, ViewSet};
use burn::tensor::{Device, Tensor};
use serde::{Deserialize, Serialize};
use splatzoo_datasets::synth::rng::Rng;
use splatzoo_rasterizer::{ColorMode, RasterError, RasterSettings, Render};
use std::path::PathBuf;

/// Every knob of a static-scene run (the `train-3dgs` configuration file).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct StaticConfig {
    pub backend: Backend,
    pub iterations: usize,
    /// Weight of D-SSIM in the photometric loss.
    pub lambda_dssim: f64,
    /// Highest SH degree, reached one degree per `sh_degree_every` steps.
    pub sh_degree: u32,
    pub sh_degree_every: usize,
    /// Held-out evaluation every this many steps (and at the end).
    pub eval_every: usize,
    /// Checkpoint every this many steps (0: only at the end and on Ctrl-C).
    pub checkpoint_every: usize,
    /// Seed of the training randomness (view order, splits, noise).
    pub seed: u64,
    /// LPIPS backbone weights (AlexNet or VGG-16 in torchvision naming, safetensors).
    pub lpips_weights: Option<PathBuf>,
    pub data: DataConfig,
    pub rates: LearningRates,
    pub densify: DensifyConfig,
}

impl Default for StaticConfig {
    fn default() -> Self {
        Self {
            backend: Backend::Flex,
            iterations: 2000,
            lambda_dssim: 0.2,
            sh_degree: 3,
            sh_degree_every: 500,
            eval_every: 1000,
            checkpoint_every: 1000,
            seed: 0,
            lpips_weights: None,
            data: DataConfig::default(),
            rates: LearningRates::default(),
            densify: DensifyConfig::default(),
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum TrainError {
    #[error(transparent)]
    Data(#[from] DataError),
    #[error(transparent)]
    Raster(#[from] RasterError),
    #[error(transparent)]
    Checkpoint(#[from] CheckpointError),
    #[error("configuration: {0}")]
    Config(String),
}

/// One step's outcome.
#[derive(Debug, Clone, Copy)]
pub struct StepReport {
    pub loss: f64,
    pub density: Option<DensifyReport>,
}

/// Held-out metrics at one step.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Evaluation {
    pub step: usize,
    pub psnr: f64,
    pub ssim: f64,
    pub lpips: Option<f64>,
    pub gaussians: usize,
}

pub struct StaticTrainer {
    pub config: StaticConfig,
    pub views: ViewSet,
    pub set: GaussianSet,
    pub optimizer: GaussianOptimizer,
    pub stats: DensityStats,
    /// Steps taken.
    pub step: usize,
    rng: Rng,
    /// Training views still to visit in this epoch (taken from the back).
    order: Vec<usize>,
    opacity_resets: usize,
    background: Tensor<1>,
    device: Device,
}

const FORMAT: &str = "splatzoo-static-1";

impl StaticTrainer {
    /// Loads the data and initialises the Gaussians from its points.
    pub fn new(config: StaticConfig, device: &Device) -> Result<Self, TrainError> {
        validate(&config)?;
        let views = ViewSet::load(&config.data, device)?;
        let p = &views.points;
        if p.positions.is_empty() {
            return Err(TrainError::Config("the data gave no initial points".into()));
        }
        let set = GaussianSet::from_points(&p.positions, &p.colours, &p.sigmas, device);
        let optimizer = GaussianOptimizer::new(&set, config.rates, views.extent);
        let stats = DensityStats::new(set.len(), device);
        let rng = Rng(config.seed ^ 0x3D65_0000);
        Ok(Self::assemble(
            config, views, set, optimizer, stats, rng, device,
        ))
    }

    fn assemble(
        config: StaticConfig,
        views: ViewSet,
        set: GaussianSet,
        optimizer: GaussianOptimizer,
        stats: DensityStats,
        rng: Rng,
        device: &Device,
    ) -> Self {
        let background = Tensor::<1>::from_floats(views.background.as_slice(), device);
        Self {
            config,
            views,
            set,
            optimizer,
            stats,
            step: 0,
            rng,
            order: Vec::new(),
            opacity_resets: 0,
            background,
            device: device.clone(),
        }
    }

    /// The SH degree trained at the current step.
    pub fn sh_degree(&self) -> u32 {
        let every = self.config.sh_degree_every.max(1);
        ((self.step / every) as u32).min(self.config.sh_degree)
    }

    /// One optimiser step on the next training view, then density control where scheduled.
    pub fn step(&mut self) -> Result<StepReport, TrainError> {
        if self.order.is_empty() {
            self.order = (0..self.views.train.len()).collect();
            self.rng.shuffle(&mut self.order);
        }
        let view = &self.views.train[self.order.pop().expect("refilled above")];
        let settings = RasterSettings::new(
            view.camera,
            ColorMode::Sh {
                degree: self.sh_degree(),
            },
        );
        let leaves = self.set.leaves();
        let graph = SceneGraph::new().with(StaticNode {
            name: "background".into(),
            gaussians: leaves.clone(),
        });
        let query = FrameQuery {
            camera: &view.camera,
            frame: 0,
            time: 0.0,
        };
        let out = graph.render(&query, self.background.clone().autodiff(), &settings)?;
        let photo = photometric(
            out.render.color.clone(),
            view.image.clone().autodiff(),
            self.config.lambda_dssim,
        );
        let density = &self.config.densify;
        let loss = if density.strategy == Strategy::Mcmc {
            photo.clone() + mcmc_regulariser(density, &leaves)
        } else {
            photo.clone()
        };
        let grads = loss.backward();
        if density.strategy == Strategy::Adc {
            self.stats.record(&out.render, &grads, out.rows[0].clone());
        }
        let progress = self.step as f64 / self.config.iterations as f64;
        self.optimizer
            .step(&mut self.set, &leaves, &grads, progress);
        self.step += 1;
        let step = self.step;
        let mut report = None;
        match density.strategy {
            Strategy::Adc if density.refines_at(step) => {
                report = Some(adaptive_density_control(
                    density,
                    &mut self.set,
                    &mut self.optimizer,
                    &mut self.stats,
                    self.views.extent,
                    self.opacity_resets > 0,
                    &mut self.rng,
                ));
            }
            Strategy::Mcmc => {
                let rate = self.optimizer.means_rate(progress);
                mcmc_noise(density, &mut self.set, rate, &mut self.rng);
                if density.refines_at(step) {
                    report = Some(mcmc_relocate(
                        density,
                        &mut self.set,
                        &mut self.optimizer,
                        &mut self.rng,
                    ));
                    // Unused by MCMC, but kept the size of the set for checkpoints.
                    self.stats = DensityStats::new(self.set.len(), &self.device);
                }
            }
            _ => {}
        }
        if density.resets_opacity_at(step) {
            reset_opacity(&mut self.set, &mut self.optimizer);
            self.opacity_resets += 1;
        }
        Ok(StepReport {
            loss: scalar(photo.inner()),
            density: report,
        })
    }

    /// Renders the current Gaussians (no autodiff) from held-out view `k`.
    pub fn render_test(&self, k: usize) -> Result<Render, TrainError> {
        let settings = RasterSettings::new(
            self.views.test[k].camera,
            ColorMode::Sh {
                degree: self.sh_degree(),
            },
        );
        Ok(splatzoo_rasterizer::rasterize(
            &self.set.splats(),
            self.background.clone(),
            &settings,
        )?)
    }

    /// PSNR, SSIM (and LPIPS where given) averaged over the held-out views.
    pub fn evaluate(&self, lpips: Option<&Lpips>) -> Result<Evaluation, TrainError> {
        let (mut p, mut s, mut l) = (0.0, 0.0, 0.0);
        for (k, view) in self.views.test.iter().enumerate() {
            let image = self.render_test(k)?.color.clamp(0.0, 1.0);
            p += psnr(image.clone(), view.image.clone());
            s += scalar(ssim(image.clone(), view.image.clone()));
            if let Some(lpips) = lpips {
                l += scalar(lpips.distance(image, view.image.clone()));
            }
        }
        let n = self.views.test.len().max(1) as f64;
        Ok(Evaluation {
            step: self.step,
            psnr: p / n,
            ssim: s / n,
            lpips: lpips.map(|_| l / n),
            gaussians: self.set.len(),
        })
    }

    /// Everything needed to continue exactly where this run is.
    pub fn checkpoint(&self) -> Checkpoint {
        let mut c = Checkpoint::default();
        self.set.save(&mut c, "splats");
        self.optimizer.save(&mut c, "optimizer");
        self.stats.save(&mut c, "densify");
        c.put_meta("format", FORMAT);
        c.put_meta("step", self.step);
        c.put_meta("rng", self.rng.0);
        c.put_meta("opacity_resets", self.opacity_resets);
        let order: Vec<String> = self.order.iter().map(|i| i.to_string()).collect();
        c.put_meta("order", order.join(","));
        c.put_meta("config", crate::config::to_toml(&self.config));
        c
    }

    /// The configuration a checkpoint was written with.
    pub fn checkpoint_config(checkpoint: &Checkpoint) -> Result<StaticConfig, CheckpointError> {
        let text = checkpoint.meta("config")?;
        toml::from_str(text).map_err(|e| CheckpointError::Entry {
            file: checkpoint.origin.clone(),
            name: "config".into(),
            problem: format!("not a train-3dgs configuration: {e}"),
        })
    }

    /// Continues from `checkpoint` with `config` (normally [`Self::checkpoint_config`], perhaps
    /// with overrides such as more iterations).
    pub fn resume(
        config: StaticConfig,
        checkpoint: &Checkpoint,
        device: &Device,
    ) -> Result<Self, TrainError> {
        validate(&config)?;
        let format = checkpoint.meta("format")?;
        if format != FORMAT {
            return Err(CheckpointError::Entry {
                file: checkpoint.origin.clone(),
                name: "format".into(),
                problem: format!("`{format}`, expected `{FORMAT}` (a train-3dgs checkpoint)"),
            }
            .into());
        }
        let views = ViewSet::load(&config.data, device)?;
        let set = GaussianSet::load(checkpoint, "splats", device)?;
        let optimizer =
            GaussianOptimizer::load(checkpoint, "optimizer", &set, config.rates, views.extent)?;
        let stats = DensityStats::load(checkpoint, "densify", set.len(), device)?;
        let rng = Rng(checkpoint.meta_parsed("rng")?);
        let mut trainer = Self::assemble(config, views, set, optimizer, stats, rng, device);
        trainer.step = checkpoint.meta_parsed("step")?;
        trainer.opacity_resets = checkpoint.meta_parsed("opacity_resets")?;
        let order = checkpoint.meta("order")?;
        let train_views = trainer.views.train.len();
        trainer.order = order
            .split(',')
            .filter(|s| !s.is_empty())
            .map(|s| s.parse::<usize>().ok().filter(|&i| i < train_views))
            .collect::<Option<Vec<_>>>()
            .ok_or_else(|| CheckpointError::Entry {
                file: checkpoint.origin.clone(),
                name: "order".into(),
                problem: format!("expected view indices below {train_views}"),
            })?;
        Ok(trainer)
    }

    pub fn device(&self) -> &Device {
        &self.device
    }
}

fn validate(config: &StaticConfig) -> Result<(), TrainError> {
    if config.iterations == 0 {
        return Err(TrainError::Config("iterations ≥ 1".into()));
    }
    if config.sh_degree > 3 {
        return Err(TrainError::Config("sh_degree ≤ 3".into()));
    }
    if !(0.0..=1.0).contains(&config.lambda_dssim) {
        return Err(TrainError::Config("lambda_dssim in [0, 1]".into()));
    }
    Ok(())
}
