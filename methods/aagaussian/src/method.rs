//! AAGaussian as one harness [`Method`]: the synthetic portrait capture and its mixture
//! oracle, the trainer's steps, the synthetic protocol's scores, a checkpoint that resumes
//! bit-exactly on the CPU (the capture is rebuilt from its seed; the avatar, its optimiser,
//! density statistics and both random states are stored) and the exports.

use crate::config::{AagConfig, VaeSpec};
use crate::data::PortraitCapture;
use crate::error::AagError;
use crate::onnx_score::OnnxScore;
use crate::score::ScoreModel;
use crate::trainer::{AVATAR, AagTrainer, mixture_oracle, render_views};
use burn::module::Module;
use burn::tensor::Device;
use splatzoo_datasets::synth::rng::Rng;
use splatzoo_models::networks::vae::{VaeConfig, VaeEncoder};
use splatzoo_models::networks::weights::WeightFile;
use splatzoo_train::TrainError;
use splatzoo_train::checkpoint::Checkpoint;
use splatzoo_train::clip_score::ClipScorer;
use splatzoo_train::harness::{
    Evaluation, Method, ModuleChoice, Say, Scores, StepReport, read_back,
};
use splatzoo_train::lpips::Lpips;
use splatzoo_train::scene::SceneNode;
use std::path::Path;

/// The trainer's random state in checkpoints (cameras, t, noise, the face-view draw).
const RNG: &str = "aag.rng";

/// Shorthands for the ablations (each one `--set` line).
#[derive(Debug, Clone, Default, clap::Args)]
pub struct AagArgs {
    /// Without the facial rendering loss (Fig. 5b).
    #[arg(long)]
    pub no_face: bool,
    /// The face loss ×100 (Fig. 5d).
    #[arg(long)]
    pub face_x100: bool,
    /// Without the line-of-sight term (U6).
    #[arg(long)]
    pub no_line_of_sight: bool,
    /// Without the depth branch (λ₂ = 0).
    #[arg(long)]
    pub no_depth: bool,
    /// Start from a random box instead of the body prior (§3.2's comparison).
    #[arg(long)]
    pub box_init: bool,
    /// HumanGaussian's annealed negative-prompt guidance instead of classic CFG.
    #[arg(long)]
    pub anpg: bool,
    /// Guidance by a user's ONNX denoiser described by this TOML (see the README).
    #[arg(long)]
    pub guidance_config: Option<std::path::PathBuf>,
    /// A user's portrait (PNG or JPEG) in place of the synthetic identities (`data.photo`).
    #[arg(long)]
    pub photo: Option<std::path::PathBuf>,
    /// Its OpenPose JSON (`data.photo_keypoints`; default `<stem>_keypoints.json` beside it).
    #[arg(long)]
    pub photo_keypoints: Option<std::path::PathBuf>,
}

/// `key="path"` as a TOML basic string (backslashes and quotes escaped).
fn path_override(key: &str, path: &Path) -> String {
    let text = path.display().to_string();
    let escaped = text.replace('\\', "\\\\").replace('"', "\\\"");
    format!("{key}=\"{escaped}\"")
}

pub struct Aag {
    pub trainer: AagTrainer,
    decisions: Vec<String>,
}

impl Aag {
    /// A fresh run, guided by the configured model (the mixture oracle by default).
    pub fn assemble(config: AagConfig, device: &Device) -> Result<Self, AagError> {
        device.seed(config.seed);
        let capture = PortraitCapture::build(&config.data, device)?;
        let data = &config.data;
        let (model, guidance): (Box<dyn ScoreModel>, String) = match &config.guidance_model {
            Some(path) => {
                let model = OnnxScore::load(path)?;
                let about = format!(
                    "guidance: the ONNX denoiser {} in tract ({} branch(es), {:?} prediction, \
                     latent scale {})",
                    model.config.graph.display(),
                    model.branches(),
                    model.prediction(),
                    model.latent_scale()
                );
                (Box::new(model), about)
            }
            None => (
                Box::new(mixture_oracle(&config, &capture).ok_or_else(|| {
                    AagError::input(
                        "data.photo",
                        "a user's photo needs a guidance model (guidance_model = its TOML, or \
                         --guidance-config): the mixture oracle knows only the synthetic \
                         identities",
                    )
                })?),
                format!(
                    "guidance: the mixture oracle over {} synthetic identities (prompt = identity {}, \
                 negative = identity {}, data noise {}), {:?} schedule, {:?} prediction, {} \
                 branch(es) — an exact denoiser standing in for a text-to-image model, not \
                 text-to-3D",
                    data.identities,
                    data.prompt,
                    data.negative,
                    config.oracle.data_noise,
                    config.oracle.schedule,
                    config.oracle.prediction,
                    config.oracle.branches
                ),
            ),
        };
        let decisions = vec![
            guidance,
            match (&capture.body_fit, &data.photo) {
                (Some(fit), Some(photo)) => format!(
                    "body prior: the {} body ({:?}, {} vertices, {} joints) fitted to the \
                     OpenPose keypoints of the photo {} (no floor, {:.0}° field of view): \
                     reprojection {:.2} px, rest height {:.2} m (a single photo fixes the \
                     proportions; the shape prior, the size); {:?} canonical pose, {:.4} m per \
                     unit",
                    capture.body.source,
                    capture.body.model.kind,
                    capture.body.model.vertex_count(),
                    capture.body.model.joint_count(),
                    photo.display(),
                    data.photo_fovy_degrees,
                    fit.reprojection_rms_px,
                    fit.rest_height_m,
                    data.canonical,
                    capture.metres_per_unit
                ),
                (Some(fit), None) => format!(
                    "body prior: the {} body ({:?}, {} vertices, {} joints) fitted to the {}² \
                     portrait's BODY_25 keypoints ({} px noise): reprojection {:.2} px, joints \
                     {:.0} mm from the truth, rest height {:+.1} %; {:?} canonical pose, {:.4} m \
                     per unit",
                    capture.body.source,
                    capture.body.model.kind,
                    capture.body.model.vertex_count(),
                    capture.body.model.joint_count(),
                    data.portrait_size,
                    data.keypoint_noise_px,
                    fit.reprojection_rms_px,
                    fit.mpjpe_m.unwrap_or(f64::NAN) * 1e3,
                    fit.height_error.unwrap_or(f64::NAN) * 100.0,
                    data.canonical,
                    capture.metres_per_unit
                ),
                (None, _) => format!(
                    "body prior: the prompted identity's true shape (data.body_fit = false) in the \
                     {:?} canonical pose, {:.4} m per unit",
                    data.canonical, capture.metres_per_unit
                ),
            },
            format!(
                "face loss: crop {}, weight {} from step {}, line of sight ×{}",
                match (capture.face_alignment, &data.photo) {
                    (Some((px, points)), Some(photo)) => format!(
                        "cut from the photo {} by U8's alignment of {points} face points \
                         ({px:.2} px residual)",
                        photo.display()
                    ),
                    (Some((px, points)), None) => format!(
                        "of identity {} cut from its {}² portrait by U8's alignment of {points} \
                         face points ({px:.2} px residual)",
                        data.face_identity, data.portrait_size
                    ),
                    (None, _) => format!(
                        "of identity {} rendered from the fixed face camera",
                        data.face_identity
                    ),
                },
                config.face.weight,
                config.face.start,
                config.face.line_of_sight
            ),
        ];
        let vae = match &config.vae {
            Some(spec) => Some(load_vae(
                spec,
                model.latent_scale(),
                config.render_size,
                device,
            )?),
            None => None,
        };
        let clip = match &config.clip {
            Some(path) => Some(ClipScorer::load(path).map_err(TrainError::from)?),
            None => None,
        };
        let mut trainer = AagTrainer::new(config, capture, model, &device.clone());
        trainer.vae = vae;
        trainer.clip = clip;
        Ok(Self { trainer, decisions })
    }
}

/// The VAE encoder `spec` names, on `device`'s autodiff twin without parameter gradients,
/// scaling by the model's `latent_scale`.
fn load_vae(
    spec: &VaeSpec,
    latent_scale: f64,
    render_size: u32,
    device: &Device,
) -> Result<VaeEncoder, AagError> {
    let config = VaeConfig {
        block_out_channels: spec.block_out_channels.clone(),
        layers_per_block: spec.layers_per_block,
        latent_channels: spec.latent_channels,
        norm_groups: spec.norm_groups,
        scaling_factor: latent_scale,
    };
    let what = format!("vae {}", spec.weights.display());
    if config.block_out_channels.is_empty()
        || config.norm_groups == 0
        || config
            .block_out_channels
            .iter()
            .any(|c| !c.is_multiple_of(config.norm_groups))
    {
        return Err(AagError::input(
            what,
            "block_out_channels must be non-empty multiples of norm_groups",
        ));
    }
    if !(render_size as usize).is_multiple_of(config.downsampling()) {
        return Err(AagError::input(
            what,
            format!(
                "render_size {render_size} is not a multiple of the encoder's downsampling {}",
                config.downsampling()
            ),
        ));
    }
    let file = WeightFile::read(&spec.weights)
        .map_err(|e| AagError::input(what.clone(), e.to_string()))?;
    let vae = VaeEncoder::load(&config, &file, &device.clone().autodiff())
        .map_err(|e| AagError::input(what, e.to_string()))?;
    Ok(vae.no_grad())
}

impl Method for Aag {
    const NAME: &'static str = "aag";
    const FORMAT: &'static str = "splatzoo-aag-1";
    const ABOUT: &'static str =
        "AAGaussian: an avatar from a portrait and a prompt by dual-branch score distillation";
    type Config = AagConfig;
    type Args = AagArgs;

    fn overrides(args: &AagArgs) -> Vec<String> {
        let mut sets = Vec::new();
        let mut on = |flag: bool, set: &str| {
            if flag {
                sets.push(set.to_owned());
            }
        };
        on(args.no_face, "face.weight=0.0");
        on(args.face_x100, "face.weight=100.0");
        on(args.no_line_of_sight, "face.line_of_sight=0.0");
        on(args.no_depth, "sds.lambda_depth=0.0");
        on(args.box_init, "init=\"box\"");
        on(args.anpg, "sds.guidance=\"anpg\"");
        for (key, path) in [
            ("guidance_model", &args.guidance_config),
            ("data.photo", &args.photo),
            ("data.photo_keypoints", &args.photo_keypoints),
        ] {
            if let Some(path) = path {
                sets.push(path_override(key, path));
            }
        }
        sets
    }

    fn new(config: AagConfig, device: &Device) -> Result<Self, TrainError> {
        Ok(Self::assemble(config, device)?)
    }

    fn resume(
        config: AagConfig,
        checkpoint: &Checkpoint,
        device: &Device,
    ) -> Result<Self, TrainError> {
        let mut method = Self::assemble(config, device)?;
        let trainer = &mut method.trainer;
        trainer.node.load(checkpoint, AVATAR, device)?;
        trainer.node.optimizer.config.beta2 = trainer.config.adam_beta2;
        trainer.rng = Rng(checkpoint.meta_parsed(RNG)?);
        trainer.step = checkpoint.meta_parsed("step")?;
        Ok(method)
    }

    fn steps(&self) -> usize {
        self.trainer.step
    }

    fn describe(&self) -> String {
        let c = &self.trainer.config;
        let source = match &c.data.photo {
            Some(photo) => format!("the photo {}", photo.display()),
            None => format!("{} synthetic identities", c.data.identities),
        };
        format!(
            "{} Gaussians on the canonical body, B = {} views of {}², {source}, face crop {}²",
            self.trainer.node.gaussians(),
            c.batch,
            c.render_size,
            c.data.face_size
        )
    }

    fn decisions(&self) -> Vec<String> {
        self.decisions.clone()
    }

    /// The latent encoder where the guidance model denoises latents, the depth branch where it
    /// denoises depth, the facial loss by its weight.
    fn modules(&self) -> Vec<ModuleChoice> {
        let c = &self.trainer.config;
        vec![
            ModuleChoice {
                module: "latent encoder (VAE)".into(),
                enabled: c.vae.is_some(),
                reason: if c.vae.is_some() {
                    "the guidance model denoises latents (`vae` given)".into()
                } else {
                    "the guidance model denoises pixels (no `vae`)".into()
                },
                forced_by: Some("vae".into()),
            },
            ModuleChoice::configured(
                "facial rendering loss (Eq. 6)",
                "face.weight > 0",
                c.face.weight > 0.0,
            ),
            ModuleChoice {
                module: "depth branch of SDS (Eq. 5)".into(),
                enabled: self.trainer.depth_branch(),
                reason: if self.trainer.depth_branch() {
                    format!(
                        "the guidance model denoises depth beside RGB (2 branches), weighted by \
                         sds.lambda_depth = {}",
                        c.sds.lambda_depth
                    )
                } else {
                    "the guidance model denoises RGB only (1 branch): no depth is encoded".into()
                },
                forced_by: None,
            },
        ]
    }

    fn step(&mut self) -> Result<StepReport, TrainError> {
        let record = self.trainer.train_step()?;
        if !record.loss.is_finite() {
            return Err(TrainError::NonFinite {
                step: self.trainer.step,
                value: record.loss,
            });
        }
        let mut notes = Vec::new();
        if let Some(d) = &record.density {
            notes.push(format!(
                "density after step {}: +{} cloned, +{} split, −{} pruned → {} Gaussians",
                self.trainer.step,
                d.cloned,
                d.split,
                d.pruned,
                self.trainer.node.gaussians()
            ));
        }
        let c = &self.trainer.config;
        if self.trainer.step == c.sds.timesteps.anneal_step {
            let (lo, hi) = c.sds.timesteps.at(self.trainer.step);
            notes.push(format!("t annealed: now drawn from {{{lo}..{hi}}}"));
        }
        if self.trainer.step == c.face.start && c.face.weight > 0.0 {
            notes.push("face loss and zoomed views on".into());
        }
        if record.nonfinite > 0 {
            notes.push(format!("{} non-finite SDS values zeroed", record.nonfinite));
        }
        Ok(StepReport {
            loss: record.loss,
            note: (!notes.is_empty()).then(|| notes.join("; ")),
        })
    }

    fn evaluate(&self, lpips: Option<&Lpips>) -> Result<Evaluation, TrainError> {
        let scores = self.trainer.evaluate(lpips)?;
        let evaluation = match &scores.held_out {
            Some(held_out) => Evaluation::new(
                self.trainer.step,
                Scores {
                    psnr: held_out.psnr,
                    ssim: held_out.ssim,
                    lpips: held_out.lpips,
                },
            )
            .with("scores", "held-out views of the prompted identity"),
            None => Evaluation::new(
                self.trainer.step,
                Scores {
                    psnr: scores.face_psnr,
                    ssim: scores.face_ssim,
                    lpips: None,
                },
            )
            .of_training_views()
            .with(
                "scores",
                "the face view against the photo's face crop (the face loss's target: a photo has \
                 no held-out view)",
            ),
        };
        Ok(evaluation.with("aag", serde_json::to_value(&scores).expect("plain data")))
    }

    /// The held-out cameras and the face camera.
    fn render_held_out(&self) -> Result<usize, TrainError> {
        let capture = &self.trainer.capture;
        let mut cameras = capture.eval_cameras.clone();
        cameras.push(capture.face_camera);
        let renders = render_views(&self.trainer.node.set.splats(), &cameras)?;
        for render in &renders {
            read_back(&render.color);
        }
        Ok(renders.len())
    }

    fn gaussians(&self) -> usize {
        self.trainer.node.gaussians()
    }

    fn checkpoint(&self) -> Checkpoint {
        let mut c = Checkpoint::default();
        self.trainer.node.save(&mut c, AVATAR);
        c.put_meta(RNG, self.trainer.rng.0);
        c
    }

    fn finish(
        &self,
        run: &Path,
        say: &mut dyn Say,
    ) -> Result<serde_json::Map<String, serde_json::Value>, TrainError> {
        Ok(crate::export::write_outputs(&self.trainer, run, say)?)
    }
}
