//! Static-scene 3D Gaussian splatting as a [`Method`]: one [`GaussianNode`] (the background,
//! with its own per-group Adam and ADC or MCMC density control) in a [`SceneGraph`],
//! `(1 − λ) L1 + λ D-SSIM`, the SH degree raised on a schedule. Its whole state (the node's
//! parameters, moments, density statistics and random state; the view order) goes into one
//! checkpoint, so a resumed run continues bit for bit. `train-3dgs` runs it through the
//! harness; later methods reuse it as their scene-prior stage.

use crate::backend::Backend;
use crate::checkpoint::Checkpoint;
use crate::densify::{DensifyConfig, Strategy};
use crate::error::TrainError;
use crate::gaussians::GaussianSet;
use crate::harness::{
    EpochOrder, Evaluation, Method, MethodConfig, ModuleChoice, Say, ScoreSum, StepReport,
    read_back,
};
use crate::images::{side_by_side, srgb_image, write_png};
use crate::loss::{masked_l1, masked_psnr, masked_ssim, photometric, psnr, scalar, ssim};
use crate::lpips::Lpips;
use crate::optimizer::LearningRates;
use crate::ply::write_ply;
use crate::scene::{FrameQuery, GaussianNode, SceneGraph};
use crate::views::{CaptureArgs, DataConfig, Frame, ViewSet};
use burn::tensor::{Device, Tensor};
use serde::{Deserialize, Serialize};
use splatzoo_rasterizer::{Camera, ColorMode, RasterSettings, Render};
use std::path::{Path, PathBuf};

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
    /// View-dependent colour (SH degree ≥ 1). Absent: the degree is limited to what the
    /// training views support (see [`supported_sh_degree`]); `true`: `sh_degree` whatever the
    /// views; `false`: degree 0.
    pub view_dependence: Option<bool>,
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
            view_dependence: None,
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

impl MethodConfig for StaticConfig {
    crate::schedule_fields!();

    fn validate(&self) -> Result<(), TrainError> {
        if self.iterations == 0 {
            return Err(TrainError::Config("iterations ≥ 1".into()));
        }
        if self.sh_degree > 3 {
            return Err(TrainError::Config("sh_degree ≤ 3".into()));
        }
        if !(0.0..=1.0).contains(&self.lambda_dssim) {
            return Err(TrainError::Config("lambda_dssim in [0, 1]".into()));
        }
        Ok(())
    }
}

/// `train-3dgs`'s shorthands.
#[derive(clap::Args, Debug)]
pub struct StaticArgs {
    #[command(flatten)]
    pub capture: CaptureArgs,
    /// Shorthand for `--set data.size=N` (synthetic image side).
    #[arg(long)]
    pub size: Option<u32>,
    /// Shorthand for `--set densify.strategy=…`.
    #[arg(long, value_enum)]
    pub densify: Option<Strategy>,
}

/// The name of the one node (its checkpoint prefix).
pub const BACKGROUND: &str = "background";

/// The highest SH degree `views` training views support: degree `d` has `(d + 1)²`
/// coefficients per colour channel, and a Gaussian's view-dependent colour is fitted from at
/// most one direction per view, so `d` needs `(d + 1)² ≤ views` (3 views: 0; 4–8: 1; 9–15: 2;
/// 16 or more: 3).
pub fn supported_sh_degree(views: usize) -> u32 {
    let mut degree = 0u32;
    while degree < 3 && ((degree + 2) as usize).pow(2) <= views {
        degree += 1;
    }
    degree
}

/// Whether the scene gets view-dependent colour and up to which SH degree.
fn view_dependence(config: &StaticConfig, views: usize) -> (ModuleChoice, u32) {
    let supported = supported_sh_degree(views);
    let wanted = config.sh_degree;
    let why = if wanted == 0 {
        "sh_degree = 0".to_owned()
    } else if supported >= wanted {
        format!("{views} training views support SH degree {wanted}")
    } else {
        format!(
            "{views} training views support SH degree {supported} of {wanted} ((d + 1)² \
             coefficients a channel need as many views)"
        )
    };
    let choice = ModuleChoice::decide(
        "view-dependent colour (SH)",
        "view_dependence",
        config.view_dependence,
        wanted.min(supported) > 0,
        why,
    );
    let degree = match config.view_dependence {
        Some(true) => wanted,
        Some(false) => 0,
        None => wanted.min(supported),
    };
    // Forced on with `sh_degree = 0` there is still none.
    let choice = ModuleChoice {
        enabled: degree > 0,
        ..choice
    };
    (choice, degree)
}

pub struct StaticTrainer {
    pub config: StaticConfig,
    pub views: ViewSet,
    /// The background node alone.
    pub graph: SceneGraph,
    /// Steps taken.
    pub step: usize,
    /// Orders the training views.
    order: EpochOrder,
    background: Tensor<1>,
    /// The highest SH degree trained (the configuration's, limited by the views' support).
    max_sh_degree: u32,
    view_dependence: ModuleChoice,
}

impl StaticTrainer {
    /// The SH degree trained at the current step.
    pub fn sh_degree(&self) -> u32 {
        let every = self.config.sh_degree_every.max(1);
        ((self.step / every) as u32).min(self.max_sh_degree)
    }

    /// The scene's Gaussians now (what `point_cloud.ply` holds).
    pub fn gaussian_set(&self) -> GaussianSet {
        let camera = self.any_camera();
        let query = FrameQuery {
            camera: &camera,
            frame: 0,
            time: 0.0,
        };
        let parts = self.graph.outputs(&query);
        GaussianSet::from_splats(&crate::scene::concatenate(
            parts.into_iter().map(|(_, o)| o.splats).collect(),
        ))
    }

    fn any_camera(&self) -> Camera {
        self.views
            .train
            .first()
            .or(self.views.test.first())
            .map(|v| v.camera)
            .expect("a view set has views")
    }

    fn settings(&self, camera: Camera) -> RasterSettings {
        RasterSettings::new(
            camera,
            ColorMode::Sh {
                degree: self.sh_degree(),
            },
        )
    }

    /// Renders the current Gaussians (no autodiff) from held-out view `k`.
    pub fn render_test(&self, k: usize) -> Result<Render, TrainError> {
        let camera = self.views.test[k].camera;
        let query = FrameQuery {
            camera: &camera,
            frame: 0,
            time: 0.0,
        };
        let out = self
            .graph
            .render(&query, self.background.clone(), &self.settings(camera))?;
        Ok(out.render)
    }

    /// The loss of one render against a view's frame: photometric over the pixels that count.
    fn view_loss(&self, image: Tensor<3>, frame: &Frame, in_step: bool) -> Tensor<1> {
        let lift = |t: Tensor<3>| if in_step { t.autodiff() } else { t };
        let target = lift(frame.image.clone());
        match self.views.loss_weight(frame) {
            None => photometric(image, target, self.config.lambda_dssim),
            Some(weight) => {
                let weight = if in_step { weight.autodiff() } else { weight };
                let lambda = self.config.lambda_dssim;
                let l1 = masked_l1(image.clone(), target.clone(), weight.clone());
                let structure = (masked_ssim(image, target, weight) - 1.0) * -1.0;
                l1 * (1.0 - lambda) + structure * lambda
            }
        }
    }

    fn assemble(config: StaticConfig, views: ViewSet, device: &Device) -> Result<Self, TrainError> {
        let p = &views.points;
        if p.positions.is_empty() {
            return Err(TrainError::Config("the data gave no initial points".into()));
        }
        let set = GaussianSet::from_points(&p.positions, &p.colours, &p.sigmas, device);
        let node = GaussianNode::new(
            BACKGROUND,
            set,
            config.rates,
            &config.densify,
            views.extent,
            config.seed ^ 0x3D65_0001,
        );
        let background = Tensor::<1>::from_floats(views.background.as_slice(), device);
        let (view_dependence, max_sh_degree) = view_dependence(&config, views.train.len());
        Ok(Self {
            order: EpochOrder::new(config.seed ^ 0x3D65_0000),
            config,
            views,
            graph: SceneGraph::new().with(node),
            step: 0,
            background,
            max_sh_degree,
            view_dependence,
        })
    }
}

impl Method for StaticTrainer {
    const NAME: &'static str = "3dgs";
    const FORMAT: &'static str = "splatzoo-3dgs-2";
    const ABOUT: &'static str = "Static-scene 3D Gaussian splatting (synthetic default, or a capture in any format the loaders read)";
    type Config = StaticConfig;
    type Args = StaticArgs;

    fn overrides(args: &StaticArgs) -> Vec<String> {
        let mut sets = Vec::new();
        if args.capture.data.is_some() {
            sets.push("data.source=\"dataset\"".into());
        }
        sets.extend(args.capture.overrides());
        if let Some(size) = args.size {
            sets.push(format!("data.size={size}"));
        }
        if let Some(strategy) = args.densify {
            let name = format!("{strategy:?}").to_lowercase();
            sets.push(format!("densify.strategy=\"{name}\""));
        }
        sets
    }

    /// Loads the data and initialises the Gaussians from its points.
    fn new(config: StaticConfig, device: &Device) -> Result<Self, TrainError> {
        config.validate()?;
        let views = ViewSet::load(&config.data, device)?;
        Self::assemble(config, views, device)
    }

    fn resume(
        config: StaticConfig,
        checkpoint: &Checkpoint,
        device: &Device,
    ) -> Result<Self, TrainError> {
        config.validate()?;
        let views = ViewSet::load(&config.data, device)?;
        let mut trainer = Self::assemble(config, views, device)?;
        trainer.graph.load(checkpoint, device)?;
        trainer.step = checkpoint.meta_parsed("step")?;
        trainer.order = EpochOrder::load(checkpoint, trainer.views.train.len())?;
        Ok(trainer)
    }

    fn steps(&self) -> usize {
        self.step
    }

    fn describe(&self) -> String {
        format!(
            "{} train / {} held-out views, {} Gaussians, extent {:.2} m",
            self.views.train.len(),
            self.views.test.len(),
            self.graph.gaussians(),
            self.views.extent,
        )
    }

    fn decisions(&self) -> Vec<String> {
        self.views.decisions.clone()
    }

    fn modules(&self) -> Vec<ModuleChoice> {
        vec![self.view_dependence.clone()]
    }

    /// One optimiser step on the next training view, then density control where scheduled.
    fn step(&mut self) -> Result<StepReport, TrainError> {
        let view = &self.views.train[self.order.next(self.views.train.len())];
        let frame = self.views.frame(view)?;
        let settings = self.settings(view.camera);
        self.graph.begin_step();
        let query = FrameQuery {
            camera: &view.camera,
            frame: 0,
            time: 0.0,
        };
        let out = self
            .graph
            .render(&query, self.background.clone().autodiff(), &settings)?;
        let photo = self.view_loss(out.render.color.clone(), &frame, true);
        let loss = match self.graph.regularisers() {
            Some(r) => photo.clone() + r,
            None => photo.clone(),
        };
        let grads = loss.backward();
        let progress = self.step as f64 / self.config.iterations as f64;
        let reports = self.graph.end_step(&grads, &[out], self.step, progress);
        self.step += 1;
        let note = (!reports.is_empty()).then(|| {
            let parts: Vec<String> = reports
                .iter()
                .map(|(node, d)| format!("{node}: density {d:?}"))
                .collect();
            format!(
                "{} → {} Gaussians",
                parts.join("; "),
                self.graph.gaussians()
            )
        });
        Ok(StepReport {
            loss: scalar(photo.inner()),
            note,
        })
    }

    /// PSNR, SSIM (and LPIPS where given) averaged over the held-out views.
    fn evaluate(&self, lpips: Option<&Lpips>) -> Result<Evaluation, TrainError> {
        let mut sum = ScoreSum::default();
        for (k, view) in self.views.test.iter().enumerate() {
            let image = self.render_test(k)?.color.clamp(0.0, 1.0);
            let frame = self.views.frame(view)?;
            let target = frame.image.clone();
            let perceptual = lpips.map(|l| scalar(l.distance(image.clone(), target.clone())));
            match self.views.loss_weight(&frame) {
                None => sum.add(
                    psnr(image.clone(), target.clone()),
                    scalar(ssim(image, target)),
                    perceptual,
                ),
                // Scored where it was trained: people and invalid pixels left out.
                Some(weight) => sum.add(
                    masked_psnr(image.clone(), target.clone(), weight.clone()),
                    scalar(masked_ssim(image, target, weight)),
                    perceptual,
                ),
            }
        }
        Ok(Evaluation::new(self.step, sum.mean()).with("gaussians", self.graph.gaussians()))
    }

    fn render_held_out(&self) -> Result<usize, TrainError> {
        for k in 0..self.views.test.len() {
            read_back(&self.render_test(k)?.color);
        }
        Ok(self.views.test.len())
    }

    fn gaussians(&self) -> usize {
        self.graph.gaussians()
    }

    fn checkpoint(&self) -> Checkpoint {
        let mut c = Checkpoint::default();
        self.graph.save(&mut c);
        self.order.save(&mut c);
        c
    }

    /// `point_cloud.ply` and the held-out renders (render | truth).
    fn finish(
        &self,
        run: &Path,
        _say: &mut dyn Say,
    ) -> Result<serde_json::Map<String, serde_json::Value>, TrainError> {
        write_ply(&run.join("point_cloud.ply"), &self.gaussian_set())?;
        let renders = run.join("renders");
        std::fs::create_dir_all(&renders).map_err(|e| {
            splatzoo_datasets::DatasetError::file(&renders, format!("cannot create ({e})"))
        })?;
        for (k, view) in self.views.test.iter().enumerate() {
            let render = self.render_test(k)?;
            let truth = self.views.frame(view)?.image;
            let pair = side_by_side(&[srgb_image(&render.color), srgb_image(&truth)]);
            write_png(&renders.join(format!("{}.png", view.name)), &pair)?;
        }
        let mut summary = serde_json::Map::new();
        summary.insert("gaussians".into(), self.graph.gaussians().into());
        Ok(summary)
    }
}
