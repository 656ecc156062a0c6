//! The four stages as one harness [`Method`]: steps `[0, A)` train the scene prior on the
//! scene scan, `[A, A + B)` the avatar prior on the human scan, and at `A + B` stage C
//! initialises stage D (floor plane, σ₀, the scan avatar carried onto the acting prior), which
//! runs to `iterations`. One checkpoint holds every stage's state; a resumed run rebuilds the
//! capture from its seed and continues bit-exactly on the CPU.

use crate::avatar::avatar_model;
use crate::avatar_stage::{AvatarStage, SCAN_AVATAR};
use crate::body_fit::refine_on_keypoints;
use crate::camera::refinement_choice;
use crate::config::Prior4dConfig;
use crate::data::Prior4dCapture;
use crate::error::Prior4dError;
use crate::eval::JointScores;
use crate::joint::{AVATAR, JOINT_SCENE, JointStage};
use crate::scene_stage::{SCENE, SceneStage};
use crate::sources::PriorSource;
use burn::module::Module;
use burn::tensor::Device;
use splatzoo_models::body::BodyModel;
use splatzoo_train::TrainError;
use splatzoo_train::checkpoint::Checkpoint;
use splatzoo_train::harness::{
    EpochOrder, Evaluation, Method, ModuleChoice, Say, Scores, StepReport,
};
use splatzoo_train::host_f32;
use splatzoo_train::lpips::Lpips;
use splatzoo_train::module_adam::{ModuleAdam, NETWORK_ADAM};
use splatzoo_train::scene::SceneNode;
use std::path::Path;

/// The offset network's tensors live under this prefix in checkpoints.
const OFFSETS: &str = "offsets";

/// Which stage a step belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    Scene,
    Avatar,
    Joint,
}

/// Shorthands for the ablations (each one `--set` line).
#[derive(Debug, Clone, Default, clap::Args)]
pub struct Prior4dArgs {
    /// Without the normal loss (Eq. 6).
    #[arg(long)]
    pub no_normal: bool,
    /// Without the contact loss (Eq. 7).
    #[arg(long)]
    pub no_contact: bool,
    /// Without the Huber prior regulariser.
    #[arg(long)]
    pub no_huber: bool,
    /// Without the pose-dependent offsets.
    #[arg(long)]
    pub no_pose_offsets: bool,
    /// With the acting cameras fixed (the paper's comparison setting).
    #[arg(long)]
    pub no_camera_refinement: bool,
    /// Every scene parameter free in stage D, not only its SH.
    #[arg(long)]
    pub free_scene: bool,
    /// The scene prior trained on the acting video instead of the scene scan (Fig. 5).
    #[arg(long)]
    pub no_scene_prior: bool,
    /// The avatar prior trained on the acting video instead of the human scan (Fig. 5).
    #[arg(long)]
    pub no_avatar_prior: bool,
}

pub struct Prior4d {
    pub config: Prior4dConfig,
    pub capture: Prior4dCapture,
    pub model: BodyModel,
    pub scene: SceneStage,
    pub avatar: AvatarStage,
    pub joint: Option<JointStage>,
    /// Stage D's scores before its first step: the priors alone (the spec's first baseline).
    pub priors_only: Option<JointScores>,
    pub step: usize,
    decisions: Vec<String>,
    /// Whether the capture called for camera refinement, and why (also kept, resolved, in
    /// `config.joint.camera_refinement`).
    pub camera_choice: ModuleChoice,
}

impl Prior4d {
    pub fn stage(&self, step: usize) -> Stage {
        if step < self.config.avatar_start() {
            Stage::Scene
        } else if step < self.config.joint_start() {
            Stage::Avatar
        } else {
            Stage::Joint
        }
    }

    fn assemble(mut config: Prior4dConfig, device: &Device) -> Result<Self, Prior4dError> {
        device.seed(config.seed);
        let mut capture = config.data.build(device)?;
        let missing = resolve_missing_inputs(&mut config, &capture);
        capture.decisions.extend(missing);
        if config.body_fit.keypoints {
            let (refined, report) = refine_on_keypoints(&capture, &config.body_fit, device)?;
            capture.acting_prior = refined;
            capture.decisions.push(report.line());
        }
        if config.scene.source == PriorSource::Acting {
            let line = capture.scene_from_acting();
            capture.decisions.push(line);
        }
        if config.avatar.source == PriorSource::Acting {
            let line = capture.avatar_from_acting();
            capture.decisions.push(line);
        }
        let camera_choice =
            refinement_choice(config.joint.camera_refinement, capture.acting_cameras);
        config.joint.camera_refinement = Some(camera_choice.enabled);
        let model = avatar_model(config.avatar.subdivisions);
        let scene = SceneStage::new(&capture, &config.scene, config.seed, device)?;
        let avatar = AvatarStage::new(&capture, &model, &config.avatar, config.seed, device)?;
        let mut decisions = capture.decisions.clone();
        let trained = capture.trained_indices().len();
        let scene_start = match &config.scene.initial_ply {
            Some(path) => format!(
                "from {} ({} Gaussians)",
                path.display(),
                scene.node.gaussians()
            ),
            None => format!("from {} points", capture.scene_points.len()),
        };
        let avatar_start = match &config.avatar.initial_ply {
            Some(path) => format!("from {}", path.display()),
            None => "built-in body".to_owned(),
        };
        decisions.push(format!(
            "stage A: scene prior {scene_start}, {} steps on {} views ({} held out); stage B: \
             avatar prior of {} Gaussians ({avatar_start}, {} subdivision(s)), {} steps on {} \
             views ({} held out); stage D on {} acting frames{}",
            config.scene.steps,
            scene.train.len(),
            scene.test.len(),
            model.vertex_count(),
            config.avatar.subdivisions,
            config.avatar.steps,
            avatar.train.len(),
            avatar.test.len(),
            trained,
            if trained < capture.acting.len() {
                format!(
                    " ({} held out for the scores)",
                    capture.acting.len() - trained
                )
            } else {
                String::new()
            }
        ));
        Ok(Self {
            config,
            capture,
            model,
            scene,
            avatar,
            joint: None,
            priors_only: None,
            step: 0,
            decisions,
            camera_choice,
        })
    }

    /// The true global scale for this avatar: the scene scale × the true body's height / the
    /// avatar's, both measured as the vertical extent in the avatar's canonical pose (the
    /// avatar's surface is its canonical Gaussians — its shape coefficients move the skeleton,
    /// not the surface — so its height is measured on them).
    /// `None` on a real capture, which has no truth.
    pub fn sigma_star(&self) -> Option<f64> {
        let truth = self.capture.truth.as_ref()?;
        let set = match &self.joint {
            Some(joint) => joint.avatar.canonical_set(),
            None => self.avatar.node.canonical_set(),
        };
        let extent = |ys: &mut dyn Iterator<Item = f64>| {
            let (lo, hi) = ys.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), y| {
                (lo.min(y), hi.max(y))
            });
            hi - lo
        };
        let avatar = extent(&mut host_f32(&set.means).chunks(3).map(|p| f64::from(p[1])));
        let true_height = true_canonical_vertices(
            &truth.betas,
            self.config.avatar.node.canonical_pose,
            &set.means.device(),
        );
        let true_height = extent(&mut true_height.chunks(3).map(|p| f64::from(p[1])));
        Some(truth.scale * true_height / avatar)
    }

    /// Stage C and a fresh stage D from the current scene and scan avatar.
    fn start_joint(&self) -> Result<JointStage, Prior4dError> {
        let device = self.scene.node.set.means.device();
        let degree = SceneStage::sh_degree(&self.config.scene, self.config.scene.steps);
        JointStage::new(
            &self.capture,
            &self.model,
            &self.config,
            &self.scene.node.set.splats(),
            self.scene.extent,
            degree,
            &self.avatar.node,
            &device,
        )
    }

    fn joint_scores(
        &self,
        joint: &JointStage,
        lpips: Option<&Lpips>,
    ) -> Result<JointScores, Prior4dError> {
        joint.evaluate(
            &self.capture,
            self.config.joint.refines_cameras(),
            self.config.joint.eval_stride,
            self.sigma_star(),
            lpips,
        )
    }

    /// Stage D's scores now.
    pub fn final_scores(&self, lpips: Option<&Lpips>) -> Result<JointScores, Prior4dError> {
        let joint = self
            .joint
            .as_ref()
            .ok_or_else(|| Prior4dError::input("train-prior4d", "stage D has not started"))?;
        self.joint_scores(joint, lpips)
    }

    fn train_step(&mut self) -> Result<StepReport, Prior4dError> {
        let (a, d0) = (self.config.avatar_start(), self.config.joint_start());
        let step = self.step;
        let mut note = None;
        let loss = match self.stage(step) {
            Stage::Scene => self.scene.step(&self.capture, &self.config.scene, step)?,
            Stage::Avatar => self
                .avatar
                .step(&self.capture, step - a, self.config.avatar.steps)?,
            Stage::Joint => {
                if self.joint.is_none() {
                    let joint = self.start_joint()?;
                    let scores = self.joint_scores(&joint, None)?;
                    let sigma_star = self
                        .sigma_star()
                        .map_or_else(|| "no truth".into(), |s| format!("σ* = {s:.4}"));
                    note = Some(format!(
                        "stage C: floor from {} of {} ground points (RMS {:.4}), σ₀ = {:.4} \
                         ({sigma_star}); priors alone: PSNR {:.2} dB, mask IoU {:.3}",
                        joint.init.fit.inliers.len(),
                        joint.init.candidates,
                        joint.init.fit.rms,
                        joint.init.sigma0,
                        scores.psnr,
                        scores.mask_iou
                    ));
                    self.priors_only = Some(scores);
                    self.joint = Some(joint);
                }
                let joint = self.joint.as_mut().expect("stage D exists");
                let steps = self.config.iterations - d0;
                let terms = joint.step(&self.capture, &self.config, step - d0, steps)?;
                terms.photo + terms.normal + terms.contact + terms.huber
            }
        };
        self.step += 1;
        Ok(StepReport { loss, note })
    }

    fn order(&self) -> &EpochOrder {
        match (&self.joint, self.stage(self.step)) {
            (Some(joint), _) => &joint.order,
            (None, Stage::Scene) => &self.scene.order,
            (None, _) => &self.avatar.order,
        }
    }
}

/// Turns off what needs an input the capture lacks (a real one: [`crate::data::neuman`]) and
/// says so: a prior without its scan comes from the acting video, the keypoint fit needs
/// keypoints, the normal term normal maps; a capture without truth scores all its held-out
/// frames.
fn resolve_missing_inputs(config: &mut Prior4dConfig, capture: &Prior4dCapture) -> Vec<String> {
    let mut decisions = Vec::new();
    if capture.scene_scan.is_empty() && config.scene.source == PriorSource::Scan {
        config.scene.source = PriorSource::Acting;
        decisions.push(
            "the capture has no scene scan: the scene prior comes from the acting video \
             (scene.source = \"acting\"; a scene.initial_ply, such as a scan trained by \
             train-3dgs in the acting video's COLMAP world, starts it)"
                .to_owned(),
        );
    }
    if capture.human_scan.is_empty() && config.avatar.source == PriorSource::Scan {
        config.avatar.source = PriorSource::Acting;
        decisions.push(
            "the capture has no human scan: the avatar prior comes from the acting video \
             (avatar.source = \"acting\"; an avatar.initial_ply starts it)"
                .to_owned(),
        );
    }
    if capture.acting_keypoints.is_empty() && config.body_fit.keypoints {
        config.body_fit.keypoints = false;
        decisions.push(
            "the capture has no 2-D keypoints: stage C keeps the body fit as given \
                        (body_fit.keypoints = false)"
                .to_owned(),
        );
    }
    if capture.truth.is_none() && config.joint.eval_stride > 1 {
        config.joint.eval_stride = 1;
        decisions.push(
            "a real capture: every held-out frame is scored (joint.eval_stride = 1)".to_owned(),
        );
    }
    if capture.acting.iter().all(|f| f.normals.is_none()) && config.joint.normal > 0.0 {
        config.joint.normal = 0.0;
        decisions
            .push("the capture has no normal maps: no normal term (joint.normal = 0)".to_owned());
    }
    decisions
}

/// The built-in body's vertices (flat `[V · 3]`) at shape `betas` in `pose`.
fn true_canonical_vertices(
    betas: &[f64],
    pose: splatzoo_train::scene::skinned::CanonicalPose,
    device: &Device,
) -> Vec<f32> {
    use burn::tensor::{Tensor, TensorData};
    use splatzoo_models::body::lbs::{BodyTensors, PoseInput, pose as lbs};
    let model = &splatzoo_models::body::builtin_body().model;
    let s = betas.len().min(model.shape_count());
    let j = model.joint_count();
    let betas: Vec<f32> = betas[..s].iter().map(|&b| b as f32).collect();
    let axis_angles: Vec<f32> = pose.axis_angles(j).iter().map(|&v| v as f32).collect();
    let posed = lbs(
        &BodyTensors::new(model, device),
        &PoseInput::from_axis_angle(
            Tensor::from_data(TensorData::new(betas, [1, s]), device),
            Tensor::from_data(TensorData::new(axis_angles, [1, 3 * j]), device),
            Tensor::zeros([1, 3], device),
        ),
    );
    host_f32(&posed.vertices)
}

fn load_offsets(joint: &mut JointStage, checkpoint: &Checkpoint) -> Result<(), TrainError> {
    joint.offsets = checkpoint.module(joint.offsets.clone(), OFFSETS)?.train();
    joint.offsets_adam = ModuleAdam::load_under(
        NETWORK_ADAM,
        &joint.offsets,
        checkpoint,
        &format!("{OFFSETS}.optimizer"),
    )?;
    Ok(())
}

impl Method for Prior4d {
    const NAME: &'static str = "prior4d";
    const FORMAT: &'static str = "splatzoo-prior4d-1";
    const ABOUT: &'static str =
        "Prior-4D: a scene prior and an avatar prior refined jointly on a monocular acting video";
    type Config = Prior4dConfig;
    type Args = Prior4dArgs;

    fn overrides(args: &Prior4dArgs) -> Vec<String> {
        let mut sets = Vec::new();
        let mut off = |on: bool, set: &str| {
            if on {
                sets.push(set.to_owned());
            }
        };
        off(args.no_normal, "joint.normal=0.0");
        off(args.no_contact, "joint.contact=0.0");
        off(args.no_huber, "joint.huber=0.0");
        off(args.no_pose_offsets, "joint.pose_offsets=false");
        off(args.no_camera_refinement, "joint.camera_refinement=false");
        off(args.free_scene, "joint.free_scene=true");
        off(args.no_scene_prior, "scene.source=acting");
        off(args.no_avatar_prior, "avatar.source=acting");
        sets
    }

    fn new(config: Prior4dConfig, device: &Device) -> Result<Self, TrainError> {
        Ok(Self::assemble(config, device)?)
    }

    fn resume(
        config: Prior4dConfig,
        checkpoint: &Checkpoint,
        device: &Device,
    ) -> Result<Self, TrainError> {
        let mut method = Self::assemble(config, device)?;
        method.scene.node.load(checkpoint, SCENE, device)?;
        method.avatar.node.load(checkpoint, SCAN_AVATAR, device)?;
        method.step = checkpoint.meta_parsed("step")?;
        match method.stage(method.step) {
            Stage::Scene => {
                method.scene.order = EpochOrder::load(checkpoint, method.scene.train.len())?
            }
            Stage::Avatar => {
                method.avatar.order = EpochOrder::load(checkpoint, method.avatar.train.len())?
            }
            Stage::Joint if method.step > method.config.joint_start() => {
                let mut joint = method.start_joint()?;
                joint.scene.load(checkpoint, JOINT_SCENE, device)?;
                joint.avatar.load(checkpoint, AVATAR, device)?;
                load_offsets(&mut joint, checkpoint)?;
                joint.attach_offsets(&method.config, false);
                let frames = method.capture.acting.len();
                joint.log_sigma = checkpoint.tensor("sigma.log", [Some(1)], device)?;
                joint.sigma_adam = splatzoo_train::adam::AdamState::load(
                    checkpoint,
                    "sigma.log",
                    &joint.log_sigma,
                )?;
                joint.camera_rotation =
                    checkpoint.tensor("cameras.rotation", [Some(frames), Some(3)], device)?;
                joint.camera_translation =
                    checkpoint.tensor("cameras.translation", [Some(frames), Some(3)], device)?;
                joint.rotation_adam = splatzoo_train::adam::AdamState::load(
                    checkpoint,
                    "cameras.rotation",
                    &joint.camera_rotation,
                )?;
                joint.translation_adam = splatzoo_train::adam::AdamState::load(
                    checkpoint,
                    "cameras.translation",
                    &joint.camera_translation,
                )?;
                joint.order = EpochOrder::load(checkpoint, frames)?;
                if let Ok(json) = checkpoint.meta("priors_only") {
                    method.priors_only = serde_json::from_str(json).ok();
                }
                method.joint = Some(joint);
            }
            Stage::Joint => {}
        }
        Ok(method)
    }

    fn steps(&self) -> usize {
        self.step
    }

    fn describe(&self) -> String {
        format!(
            "scene scan {} views, human scan {} views, acting {} frames; scene prior {} Gaussians, \
             avatar {} Gaussians",
            self.capture.scene_scan.len(),
            self.capture.human_scan.len(),
            self.capture.acting.len(),
            self.scene.node.gaussians(),
            self.avatar.node.gaussians()
        )
    }

    fn decisions(&self) -> Vec<String> {
        self.decisions.clone()
    }

    fn step(&mut self) -> Result<StepReport, TrainError> {
        Ok(self.train_step()?)
    }

    fn evaluate(&self, lpips: Option<&Lpips>) -> Result<Evaluation, TrainError> {
        let degree =
            SceneStage::sh_degree(&self.config.scene, self.step.min(self.config.scene.steps));
        let (scene_psnr, scene_ssim) = self.scene.evaluate(&self.capture, degree)?;
        let mut evaluation = match &self.joint {
            Some(joint) => {
                let scores = self.joint_scores(joint, lpips)?;
                Evaluation::new(
                    self.step,
                    Scores {
                        psnr: scores.psnr,
                        ssim: scores.ssim,
                        lpips: scores.lpips,
                    },
                )
                .with(
                    "scores",
                    if self.capture.truth.is_some() {
                        "evaluation camera, full image"
                    } else {
                        "held-out acting frames, full image"
                    },
                )
                .with("joint", serde_json::to_value(&scores).expect("plain data"))
            }
            None => Evaluation::new(
                self.step,
                Scores {
                    psnr: scene_psnr,
                    ssim: scene_ssim,
                    lpips: None,
                },
            )
            .with(
                "scores",
                "scene scan, held-out views (stage D has not started)",
            ),
        };
        evaluation = evaluation.with("scene_prior_psnr", scene_psnr).with(
            "avatar_prior_masked_psnr",
            self.avatar.evaluate(&self.capture)?,
        );
        if let Some(p) = &self.priors_only {
            evaluation =
                evaluation.with("priors_only", serde_json::to_value(p).expect("plain data"));
        }
        Ok(evaluation)
    }

    /// Camera refinement as the capture calls for it ([`crate::camera::refinement_choice`]);
    /// stage D's other optional parts by their switches (the ablations).
    fn modules(&self) -> Vec<ModuleChoice> {
        let j = &self.config.joint;
        vec![
            ModuleChoice::configured(
                "keypoint refinement of the body prior (stage C)",
                "body_fit.keypoints",
                self.config.body_fit.keypoints,
            ),
            ModuleChoice::configured(
                "pose-dependent offsets",
                "joint.pose_offsets",
                j.pose_offsets,
            ),
            self.camera_choice.clone(),
            ModuleChoice::configured("normal term (Eq. 6)", "joint.normal > 0", j.normal > 0.0),
            ModuleChoice::configured("contact term (Eq. 7)", "joint.contact > 0", j.contact > 0.0),
        ]
    }

    /// Stage D's evaluation frames, or before it the scene scan's held-out views.
    fn render_held_out(&self) -> Result<usize, TrainError> {
        Ok(match &self.joint {
            Some(joint) => joint.render_held_out(
                &self.capture,
                self.config.joint.refines_cameras(),
                self.config.joint.eval_stride,
            )?,
            None => {
                let degree = SceneStage::sh_degree(
                    &self.config.scene,
                    self.step.min(self.config.scene.steps),
                );
                self.scene.render_held_out(&self.capture, degree)?
            }
        })
    }

    fn gaussians(&self) -> usize {
        match &self.joint {
            Some(joint) => joint.scene.gaussians() + joint.avatar.gaussians(),
            None => self.scene.node.gaussians() + self.avatar.node.gaussians(),
        }
    }

    fn checkpoint(&self) -> Checkpoint {
        let mut c = Checkpoint::default();
        self.scene.node.save(&mut c, SCENE);
        self.avatar.node.save(&mut c, SCAN_AVATAR);
        if let Some(joint) = &self.joint {
            joint.scene.save(&mut c, JOINT_SCENE);
            joint.avatar.save(&mut c, AVATAR);
            c.put_module(OFFSETS, &joint.offsets);
            joint
                .offsets_adam
                .save_under(&joint.offsets, &mut c, &format!("{OFFSETS}.optimizer"));
            c.put("sigma.log", &joint.log_sigma);
            joint.sigma_adam.save(&mut c, "sigma.log");
            c.put("cameras.rotation", &joint.camera_rotation);
            c.put("cameras.translation", &joint.camera_translation);
            joint.rotation_adam.save(&mut c, "cameras.rotation");
            joint.translation_adam.save(&mut c, "cameras.translation");
            if let Some(p) = &self.priors_only {
                c.put_meta("priors_only", serde_json::to_string(p).expect("plain data"));
            }
        }
        self.order().save(&mut c);
        c
    }

    fn finish(
        &self,
        run: &Path,
        say: &mut dyn Say,
    ) -> Result<serde_json::Map<String, serde_json::Value>, TrainError> {
        crate::export::write_outputs(self, run, say)
    }
}
