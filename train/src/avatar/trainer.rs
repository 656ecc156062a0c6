//! The `train-avatar` [`Method`]: one skinned node trained frame by frame; its whole state (the
//! node's Gaussians, moments, density statistics, anchors, pose table and random state; the
//! frame order) in one checkpoint, so a resumed run continues bit for bit.

use super::AvatarConfig;
use super::data::{AvatarCapture, AvatarView};
use super::eval::{
    HUMAN_REGION, ViewScores, accumulate_colours, mpjpe_mm, score_views, track_joints,
};
use crate::checkpoint::Checkpoint;
use crate::error::TrainError;
use crate::gaussians::{GaussianSet, SH_C0};
use crate::harness::{EpochOrder, Evaluation, Method, MethodConfig, Say, Scores, StepReport};
use crate::host_f32;
use crate::images::{side_by_side, srgb_image, write_png};
use crate::loss::{photometric, scalar, silhouette};
use crate::lpips::Lpips;
use crate::ply::write_ply;
use crate::scene::{FrameContext, FrameQuery, SceneNode, SkinnedGaussianNode, StepEnd};
use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_datasets::pose_sequence::{PoseSequence, write_pose_sequence};
use splatzoo_models::body::{BodyModel, builtin_body};
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
    /// Train with the prior's poses as they are (the ablation arm).
    #[arg(long)]
    pub no_pose_refinement: bool,
}

pub struct AvatarTrainer {
    pub config: AvatarConfig,
    pub capture: AvatarCapture,
    pub node: SkinnedGaussianNode,
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

    fn score(&self, views: &[AvatarView], lpips: Option<&Lpips>) -> Result<ViewScores, TrainError> {
        let renders = views
            .iter()
            .map(|v| self.render_view(v))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(score_views(
            renders.into_iter(),
            views,
            &self.background,
            lpips,
        ))
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
            accumulate_colours(view, &means, &depth, 0.02, &mut sum, &mut count);
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
        let capture = config.data.build(device);
        let model = builtin_body().model.clone();
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
        let background = Tensor::<1>::from_floats(config.background.as_slice(), device);
        Ok(Self {
            order: EpochOrder::new(config.seed ^ 0xA7A7_0000),
            config,
            capture,
            node,
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
        if args.no_pose_refinement {
            sets.push("node.refine_rotations=false".into());
            sets.push("node.refine_translation=false".into());
            sets.push("node.refine_shape=false".into());
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

    fn baselines(&self, lpips: Option<&Lpips>) -> Result<Vec<(String, Scores)>, TrainError> {
        let template = self.plain_template()?;
        let mut out = Vec::new();
        for (name, views) in [
            ("plain_template/novel_view", &self.capture.novel_view),
            ("plain_template/novel_pose", &self.capture.novel_pose),
        ] {
            let renders = views
                .iter()
                .map(|v| {
                    let posed = self.node.posed(template.clone(), v.frame).splats;
                    self.raster(&posed, v.camera, false)
                })
                .collect::<Result<Vec<_>, _>>()?;
            let scores = score_views(renders.into_iter(), views, &self.background, lpips);
            out.push((name.to_owned(), scores.human));
        }
        Ok(out)
    }

    /// One optimiser step on the next training frame.
    fn step(&mut self) -> Result<StepReport, TrainError> {
        let index = self.order.next(self.capture.train.len());
        self.node.begin_step();
        let view = &self.capture.train[index];
        let render = self.raster(&self.splats(&view.camera, view.frame), view.camera, true)?;
        let target = view.masked_target(&self.background).autodiff();
        let photo = photometric(render.color.clone(), target, self.config.lambda_dssim);
        let mut loss = photo.clone()
            + silhouette(render.alpha.clone(), view.mask.clone().autodiff())
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
        let grads = loss.backward();
        let rows = 0..self.node.gaussians();
        let end = StepEnd {
            grads: &grads,
            renders: vec![(&render, rows)],
            step: self.step,
            progress: self.step as f64 / self.config.iterations as f64,
        };
        let report = self.node.end_step(&end);
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
        let truth = track_joints(&self.model, &self.capture.truth, &device);
        let prior = track_joints(&self.model, &self.capture.prior, &device);
        Ok(Evaluation::new(self.step, view.human)
            .with("scores", "novel view, human region")
            .with("human_region", HUMAN_REGION)
            .with("novel_view_full_psnr", view.full.psnr)
            .with("novel_view_full_ssim", view.full.ssim)
            .with("novel_pose_human_psnr", novel_pose.human.psnr)
            .with("novel_pose_human_ssim", novel_pose.human.ssim)
            .with("novel_pose_full_psnr", novel_pose.full.psnr)
            .with("mpjpe_mm", mpjpe_mm(self.refined_joints(), truth.clone()))
            .with("prior_mpjpe_mm", mpjpe_mm(prior, truth))
            .with("gaussians", self.node.gaussians()))
    }

    fn checkpoint(&self) -> Checkpoint {
        let mut c = Checkpoint::default();
        self.node.save(&mut c, HUMAN);
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
                let target = view.masked_target(&self.background);
                let pair = side_by_side(&[srgb_image(&render.color), srgb_image(&target)]);
                write_png(&renders.join(format!("{set}_{}.png", view.name)), &pair)?;
            }
        }
        let mut summary = serde_json::Map::new();
        summary.insert("gaussians".into(), self.node.gaussians().into());
        Ok(summary)
    }
}
