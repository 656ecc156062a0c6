//! The `train-avatar` [`Method`]: one skinned node trained frame by frame; its whole state (the
//! node's Gaussians, moments, density statistics, anchors, pose table and random state; the
//! frame order) in one checkpoint, so a resumed run continues bit for bit.

use super::AvatarConfig;
use super::data::{AvatarCapture, AvatarView};
use super::eval::{
    HUMAN_REGION, ViewScores, accumulate_colours, mpjpe_mm, score_views, track_joints,
};
use super::refinement;
use super::scenery::{SCENERY, build_node, decide};
use crate::checkpoint::Checkpoint;
use crate::error::TrainError;
use crate::gaussians::{GaussianSet, SH_C0};
use crate::harness::{
    EpochOrder, Evaluation, Method, MethodConfig, ModuleChoice, Say, Scores, StepReport, read_back,
};
use crate::host_f32;
use crate::images::{side_by_side, srgb_image, write_png};
use crate::loss::{photometric, psnr, scalar, silhouette};
use crate::lpips::Lpips;
use crate::ply::write_ply;
use crate::scene::{
    FrameContext, FrameQuery, GaussianNode, SceneNode, SkinnedGaussianNode, StepEnd, concatenate,
};
use crate::views::CaptureArgs;
use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_datasets::pose_sequence::{PoseSequence, write_pose_sequence};
use splatzoo_models::body::BodyModel;
use splatzoo_models::rotation_scalar::matrix_axis_angle;
use splatzoo_rasterizer::{Camera, ColorMode, RasterSettings, Render, Splats, rasterize};
use std::path::Path;

/// The avatar node's name (its checkpoint prefix).
pub const HUMAN: &str = "human";

/// `train-avatar`'s shorthands.
#[derive(clap::Args, Debug)]
pub struct AvatarArgs {
    /// Shorthand for `--set data.frames=N`.
    #[arg(long)]
    pub frames: Option<usize>,
    /// Train with the prior's poses as they are (the ablation arm; `--set
    /// pose_refinement=false`).
    #[arg(long)]
    pub no_pose_refinement: bool,
    /// The synthetic capture: `monocular` (default) or `multiview` (shorthand for
    /// `--set data.preset=…`).
    #[arg(long, value_enum)]
    pub preset: Option<super::data::AvatarPreset>,
    /// A capture with person masks and a pose track, instead of the synthetic preset.
    #[command(flatten)]
    pub capture: CaptureArgs,
    /// An SMPL, SMPL-H or SMPL-X model file (`.npz` or `.pkl`) instead of the built-in body.
    #[arg(long)]
    pub body_model: Option<std::path::PathBuf>,
}

pub struct AvatarTrainer {
    pub config: AvatarConfig,
    pub capture: AvatarCapture,
    pub node: SkinnedGaussianNode,
    /// The static background node, where the capture gets one ([`super::scenery`]).
    pub scenery: Option<GaussianNode>,
    /// Why it has one or not.
    pub scenery_choice: ModuleChoice,
    /// Whether the body track is refined, and why ([`super::refinement`]).
    pub refinement_choice: ModuleChoice,
    model: BodyModel,
    pub step: usize,
    /// Orders the training frames.
    order: EpochOrder,
    background: Tensor<1>,
}

impl AvatarTrainer {
    /// The SH degree trained at the current step.
    pub fn sh_degree(&self) -> u32 {
        let every = self.config.sh_degree_every.max(1);
        ((self.step / every) as u32).min(self.config.sh_degree)
    }

    fn raster(&self, splats: &Splats, camera: Camera, in_step: bool) -> Result<Render, TrainError> {
        let settings = RasterSettings::new(
            camera,
            ColorMode::Sh {
                degree: self.sh_degree(),
            },
        );
        let background = if in_step {
            self.background.clone().autodiff()
        } else {
            self.background.clone()
        };
        Ok(rasterize(splats, background, &settings)?)
    }

    /// The avatar's splats at `frame` seen by `camera` (the step's leaves inside a step).
    fn splats(&self, camera: &Camera, frame: usize) -> Splats {
        let query = FrameQuery {
            camera,
            frame,
            time: frame as f64 / self.capture.fps,
        };
        self.node
            .render(&query, &FrameContext { outputs: &[] })
            .splats
    }

    /// Renders the current avatar (no autodiff) for a view.
    pub fn render_view(&self, view: &AvatarView) -> Result<Render, TrainError> {
        self.raster(&self.splats(&view.camera, view.frame), view.camera, false)
    }

    /// The background node's splats (`None` without one).
    fn scenery_splats(&self, camera: &Camera, frame: usize) -> Option<Splats> {
        let query = FrameQuery {
            camera,
            frame,
            time: frame as f64 / self.capture.fps,
        };
        let scenery = self.scenery.as_ref()?;
        Some(
            scenery
                .render(&query, &FrameContext { outputs: &[] })
                .splats,
        )
    }

    /// Human and background in one render (no autodiff), where there is a background node.
    pub fn render_scene(&self, view: &AvatarView) -> Result<Option<Render>, TrainError> {
        let Some(scenery) = self.scenery_splats(&view.camera, view.frame) else {
            return Ok(None);
        };
        let human = self.splats(&view.camera, view.frame);
        Ok(Some(self.raster(
            &concatenate(vec![human, scenery]),
            view.camera,
            false,
        )?))
    }

    /// Full-image PSNR of the composite render over `views`.
    fn scene_psnr(&self, views: &[AvatarView]) -> Result<Option<f64>, TrainError> {
        let mut sum = 0.0;
        for view in views {
            let Some(render) = self.render_scene(view)? else {
                return Ok(None);
            };
            let image = self.capture.frame(view)?.image;
            sum += psnr(render.color.clamp(0.0, 1.0), image);
        }
        Ok((!views.is_empty()).then(|| sum / views.len() as f64))
    }

    fn score(&self, views: &[AvatarView], lpips: Option<&Lpips>) -> Result<ViewScores, TrainError> {
        let pairs = views
            .iter()
            .map(|v| Ok((self.render_view(v)?, self.capture.frame(v)?)))
            .collect::<Result<Vec<_>, TrainError>>()?;
        Ok(score_views(pairs.into_iter(), &self.background, lpips))
    }

    /// `[F, J, 3]` the joints of the refined track (interpolated at held-out frames).
    pub fn refined_joints(&self) -> Tensor<3> {
        let rows = (0..self.capture.trained.len())
            .map(|t| self.node.joint_positions(t))
            .collect();
        Tensor::stack(rows, 0)
    }

    /// The refined track as a pose sequence (axis-angles, the prior's shape).
    pub fn refined_track(&self) -> PoseSequence {
        let mut track = self.capture.prior.clone();
        let j = track.joints;
        for t in 0..track.frames() {
            let pose = self.node.poses.frame(t, false);
            let rotations = host_f32(&pose.rotations);
            for k in 0..j {
                let m: [[f64; 3]; 3] = std::array::from_fn(|r| {
                    std::array::from_fn(|c| rotations[k * 9 + r * 3 + c] as f64)
                });
                let a = matrix_axis_angle(&m);
                track.poses[(t * j + k) * 3..(t * j + k) * 3 + 3].copy_from_slice(&a);
            }
            let translation = host_f32(&pose.translation);
            for (a, &v) in translation.iter().enumerate() {
                track.translations[3 * t + a] = v as f64;
            }
        }
        track
    }

    /// The plain-template baseline's Gaussians at `frame`: the initial canonical set posed by
    /// the prior, nearly opaque, each the mean colour of its projections into the training
    /// images (a visibility test against the template's own depth).
    fn plain_template(&self) -> Result<Splats, TrainError> {
        let base = self.node.canonical_set().clone();
        let g = base.len();
        let device = base.means.device();
        let mut opaque = base.clone();
        opaque.opacity_logits = Tensor::full([g], 4.0, &device);
        let (mut sum, mut count) = (vec![[0.0f64; 3]; g], vec![0usize; g]);
        for view in &self.capture.train {
            let posed = self.node.posed(opaque.splats(), view.frame).splats;
            let depth = self.raster(&posed, view.camera, false)?.depth;
            let means: Vec<[f32; 3]> = host_f32(&posed.means)
                .chunks(3)
                .map(|p| [p[0], p[1], p[2]])
                .collect();
            let frame = self.capture.frame(view)?;
            accumulate_colours(
                &view.camera,
                &frame,
                &means,
                &depth,
                0.02,
                &mut sum,
                &mut count,
            );
        }
        let dc: Vec<f32> = sum
            .iter()
            .zip(&count)
            .flat_map(|(s, &n)| {
                let mean = if n > 0 {
                    s.map(|v| v / n as f64)
                } else {
                    [0.5; 3]
                };
                mean.map(|c| ((c - 0.5) / SH_C0) as f32)
            })
            .collect();
        opaque.sh_dc = Tensor::from_data(TensorData::new(dc, [g, 1, 3]), &device);
        opaque.sh_rest = opaque.sh_rest.zeros_like();
        Ok(opaque.splats())
    }

    fn assemble(config: AvatarConfig, device: &Device) -> Result<Self, TrainError> {
        config.validate()?;
        let model = config.body()?;
        let capture = match config.data.path {
            Some(_) => super::capture::load(&config.data, &model, device)?,
            None => config.data.build(device),
        };
        let refinement_choice = refinement::decide(&config, &capture);
        let config = refinement::apply(config, &refinement_choice);
        let node = SkinnedGaussianNode::new(
            HUMAN,
            &model,
            &capture.prior,
            capture.trained.clone(),
            &config.node,
            config.rates,
            &config.densify,
            1.0,
            config.seed ^ 0xA7A7_0001,
            device,
        )?;
        let scenery_choice = decide(&config, &capture);
        let scenery = if scenery_choice.enabled {
            Some(build_node(&config, &capture, device)?)
        } else {
            None
        };
        let background = Tensor::<1>::from_floats(config.background.as_slice(), device);
        Ok(Self {
            order: EpochOrder::new(config.seed ^ 0xA7A7_0000),
            config,
            capture,
            node,
            scenery,
            scenery_choice,
            refinement_choice,
            model,
            step: 0,
            background,
        })
    }
}

impl Method for AvatarTrainer {
    const NAME: &'static str = "avatar";
    const FORMAT: &'static str = "splatzoo-avatar-1";
    const ABOUT: &'static str =
        "Animatable Gaussian avatar from a monocular video (skinned Gaussians, pose refinement)";
    type Config = AvatarConfig;
    type Args = AvatarArgs;

    fn overrides(args: &AvatarArgs) -> Vec<String> {
        let mut sets = Vec::new();
        if let Some(frames) = args.frames {
            sets.push(format!("data.frames={frames}"));
        }
        if let Some(preset) = args.preset {
            let name = format!("{preset:?}").to_lowercase();
            sets.push(format!("data.preset=\"{name}\""));
        }
        sets.extend(args.capture.overrides());
        if let Some(path) = &args.body_model {
            sets.push(format!(
                "body_model={}",
                toml::Value::from(path.display().to_string())
            ));
        }
        if args.no_pose_refinement {
            sets.push("pose_refinement=false".into());
        }
        sets
    }

    fn new(config: AvatarConfig, device: &Device) -> Result<Self, TrainError> {
        Self::assemble(config, device)
    }

    fn resume(
        config: AvatarConfig,
        checkpoint: &Checkpoint,
        device: &Device,
    ) -> Result<Self, TrainError> {
        let mut trainer = Self::assemble(config, device)?;
        trainer.node.load(checkpoint, HUMAN, device)?;
        if let Some(scenery) = &mut trainer.scenery {
            scenery.load(checkpoint, SCENERY, device)?;
        }
        trainer.step = checkpoint.meta_parsed("step")?;
        trainer.order = EpochOrder::load(checkpoint, trainer.capture.train.len())?;
        Ok(trainer)
    }

    fn steps(&self) -> usize {
        self.step
    }

    fn describe(&self) -> String {
        let c = &self.capture;
        format!(
            "{} training frames, {} novel-view and {} novel-pose images, {} Gaussians on the {}-joint body",
            c.train.len(),
            c.novel_view.len(),
            c.novel_pose.len(),
            self.node.gaussians(),
            self.model.joint_count(),
        )
    }

    fn decisions(&self) -> Vec<String> {
        self.capture.decisions.clone()
    }

    fn modules(&self) -> Vec<ModuleChoice> {
        vec![self.scenery_choice.clone(), self.refinement_choice.clone()]
    }

    fn baselines(&self, lpips: Option<&Lpips>) -> Result<Vec<(String, Scores)>, TrainError> {
        let template = self.plain_template()?;
        let mut out = Vec::new();
        for (name, views) in [
            ("plain_template/novel_view", &self.capture.novel_view),
            ("plain_template/novel_pose", &self.capture.novel_pose),
        ] {
            if views.is_empty() {
                continue;
            }
            let pairs = views
                .iter()
                .map(|v| {
                    let posed = self.node.posed(template.clone(), v.frame).splats;
                    Ok((
                        self.raster(&posed, v.camera, false)?,
                        self.capture.frame(v)?,
                    ))
                })
                .collect::<Result<Vec<_>, TrainError>>()?;
            let scores = score_views(pairs.into_iter(), &self.background, lpips);
            out.push((name.to_owned(), scores.human));
        }
        Ok(out)
    }

    /// One optimiser step on the next training frame.
    fn step(&mut self) -> Result<StepReport, TrainError> {
        let index = self.order.next(self.capture.train.len());
        self.node.begin_step();
        if let Some(scenery) = &mut self.scenery {
            scenery.begin_step();
        }
        let view = &self.capture.train[index];
        let frame = self.capture.frame(view)?;
        let human = self.splats(&view.camera, view.frame);
        let render = self.raster(&human, view.camera, true)?;
        let target = frame.masked_target(&self.background).autodiff();
        let photo = photometric(render.color.clone(), target, self.config.lambda_dssim);
        let mut loss = photo.clone()
            + silhouette(render.alpha.clone(), frame.mask.clone().autodiff())
                * self.config.mask_weight;
        if let Some(r) = self.node.regulariser() {
            loss = loss + r;
        }
        if self.config.scale_weight > 0.0
            && let Some(leaves) = self.node.canonical_leaves()
        {
            let excess = (leaves.log_scales.clone().exp() - self.config.max_scale).clamp_min(0.0);
            loss = loss + excess.mean() * self.config.scale_weight;
        }
        let g = human.len();
        let composite = match self.scenery_splats(&view.camera, view.frame) {
            None => None,
            Some(scenery) => {
                let b = scenery.len();
                let both = concatenate(vec![human, scenery]);
                let render = self.raster(&both, view.camera, true)?;
                let whole = photometric(
                    render.color.clone(),
                    frame.image.clone().autodiff(),
                    self.config.lambda_dssim,
                );
                loss = loss + whole * self.config.scenery_weight;
                Some((render, b))
            }
        };
        let grads = loss.backward();
        let progress = self.step as f64 / self.config.iterations as f64;
        let mut renders = vec![(&render, 0..g)];
        if let Some((both, _)) = &composite {
            renders.push((both, 0..g));
        }
        let end = StepEnd {
            grads: &grads,
            renders,
            step: self.step,
            progress,
        };
        let report = self.node.end_step(&end);
        if let (Some(scenery), Some((both, b))) = (&mut self.scenery, &composite) {
            let end = StepEnd {
                grads: &grads,
                renders: vec![(both, g..g + b)],
                step: self.step,
                progress,
            };
            scenery.end_step(&end);
        }
        self.step += 1;
        Ok(StepReport {
            loss: scalar(photo.inner()),
            note: report.map(|d| format!("density {d:?} → {} Gaussians", self.node.gaussians())),
        })
    }

    fn evaluate(&self, lpips: Option<&Lpips>) -> Result<Evaluation, TrainError> {
        let view = self.score(&self.capture.novel_view, lpips)?;
        let novel_pose = self.score(&self.capture.novel_pose, lpips)?;
        let device = self.background.device();
        // The headline: novel views where the capture has them, else novel poses.
        let (headline, what) = if self.capture.novel_view.is_empty() {
            (
                novel_pose.human,
                "novel pose, human region (the capture has no novel views)",
            )
        } else {
            (view.human, "novel view, human region")
        };
        let mut evaluation = Evaluation::new(self.step, headline)
            .with("scores", what)
            .with("human_region", HUMAN_REGION)
            .with("novel_view_full_psnr", view.full.psnr)
            .with("novel_view_full_ssim", view.full.ssim)
            .with("novel_pose_human_psnr", novel_pose.human.psnr)
            .with("novel_pose_human_ssim", novel_pose.human.ssim)
            .with("novel_pose_full_psnr", novel_pose.full.psnr)
            .with("novel_view_images", self.capture.novel_view.len())
            .with("novel_pose_images", self.capture.novel_pose.len())
            .with("gaussians", self.node.gaussians());
        if let Some(scenery) = &self.scenery {
            evaluation = evaluation
                .with("background_gaussians", scenery.gaussians())
                .with(
                    "novel_view_scene_psnr",
                    self.scene_psnr(&self.capture.novel_view)?,
                )
                .with(
                    "novel_pose_scene_psnr",
                    self.scene_psnr(&self.capture.novel_pose)?,
                );
        }
        if let Some(truth) = &self.capture.truth {
            let truth = track_joints(&self.model, truth, &device);
            let prior = track_joints(&self.model, &self.capture.prior, &device);
            evaluation = evaluation
                .with("mpjpe_mm", mpjpe_mm(self.refined_joints(), truth.clone()))
                .with("prior_mpjpe_mm", mpjpe_mm(prior, truth));
        }
        Ok(evaluation)
    }

    /// The human over its background at every novel view and pose (with the background node
    /// where there is one).
    fn render_held_out(&self) -> Result<usize, TrainError> {
        let views = self
            .capture
            .novel_view
            .iter()
            .chain(&self.capture.novel_pose);
        let mut frames = 0;
        for view in views {
            match self.render_scene(view)? {
                Some(render) => read_back(&render.color),
                None => read_back(&self.render_view(view)?.color),
            }
            frames += 1;
        }
        Ok(frames)
    }

    fn gaussians(&self) -> usize {
        self.node.gaussians() + self.scenery.as_ref().map_or(0, |s| s.gaussians())
    }

    fn checkpoint(&self) -> Checkpoint {
        let mut c = Checkpoint::default();
        self.node.save(&mut c, HUMAN);
        if let Some(scenery) = &self.scenery {
            scenery.save(&mut c, SCENERY);
        }
        self.order.save(&mut c);
        c
    }

    /// `canonical.ply`, `refined_poses.npz` and the held-out renders (render | truth).
    fn finish(
        &self,
        run: &Path,
        _say: &mut dyn Say,
    ) -> Result<serde_json::Map<String, serde_json::Value>, TrainError> {
        let canonical: &GaussianSet = self.node.canonical_set();
        write_ply(&run.join("canonical.ply"), canonical)?;
        if let Some(scenery) = &self.scenery {
            write_ply(&run.join("background.ply"), &scenery.set)?;
        }
        write_pose_sequence(&run.join("refined_poses.npz"), &self.refined_track())?;
        let renders = run.join("renders");
        std::fs::create_dir_all(&renders).map_err(|e| {
            splatzoo_datasets::DatasetError::file(&renders, format!("cannot create ({e})"))
        })?;
        for (set, views) in [
            ("novel_view", &self.capture.novel_view),
            ("novel_pose", &self.capture.novel_pose),
        ] {
            for view in views {
                let render = self.render_view(view)?;
                let target = self.capture.frame(view)?.masked_target(&self.background);
                let pair = side_by_side(&[srgb_image(&render.color), srgb_image(&target)]);
                write_png(&renders.join(format!("{set}_{}.png", view.name)), &pair)?;
            }
        }
        let mut summary = serde_json::Map::new();
        summary.insert("gaussians".into(), self.node.gaussians().into());
        Ok(summary)
    }
}
