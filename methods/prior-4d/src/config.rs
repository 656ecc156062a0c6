//! Every knob of a `train-prior4d` run. The paper gives no schedule, rate, weight or size; the
//! defaults are the spec's (§4: INRIA, ExAvatar, MonoSDF/HSR conventions) compressed to a CPU
//! budget: stage A (scene prior) `scene.steps`, stage B (avatar prior) `avatar.steps`, stage C
//! (initialisation) between them and stage D, and stage D (joint) for the rest of
//! `iterations` — one harness step per optimiser step, so `--iterations` sets D's length.

use crate::body_fit::BodyFitConfig;
use crate::contact::ContactConfig;
use crate::data::Prior4dDataConfig;
use crate::init::GroundConfig;
use crate::loss::HuberConfig;
use crate::offsets::PoseOffsetConfig;
use crate::sources::PriorSource;
use serde::{Deserialize, Serialize};
use splatzoo_train::TrainError;
use splatzoo_train::backend::Backend;
use splatzoo_train::densify::{DensifyConfig, Strategy};
use splatzoo_train::harness::MethodConfig;
use splatzoo_train::optimizer::LearningRates;
use splatzoo_train::scene::skinned::{Placement, SkinnedConfig};
use std::path::PathBuf;

/// Stage A: 3DGS on the scene scan with the monocular-depth term.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SceneStageConfig {
    pub steps: usize,
    pub sh_degree: u32,
    /// The SH degree rises by one every this many steps (INRIA: 1000).
    pub sh_degree_every: usize,
    /// The inverse-depth L1 weight decays exponentially from `depth_start` to `depth_end`.
    pub depth_start: f64,
    pub depth_end: f64,
    /// Every this many scan views is held out of stage A (its score only).
    pub holdout_every: usize,
    pub rates: LearningRates,
    pub densify: DensifyConfig,
    /// The video stage A trains on: the scene scan (the paper) or the acting video (Fig. 5's
    /// "without the scene prior"; [`crate::sources`]).
    pub source: PriorSource,
    /// Stage A starts from this INRIA `.ply` (a `train-3dgs` point cloud, an earlier run's
    /// `scene_prior.ply`) instead of the scan's points, at full SH degree; with `steps = 0`
    /// stage D starts from it as it is.
    pub initial_ply: Option<PathBuf>,
}

impl Default for SceneStageConfig {
    fn default() -> Self {
        Self {
            steps: 1500,
            sh_degree: 3,
            sh_degree_every: 300,
            depth_start: 1.0,
            depth_end: 0.01,
            holdout_every: 8,
            rates: LearningRates::default(),
            // Capped: stage D renders the scene three times a step.
            densify: DensifyConfig {
                start: 300,
                stop: 1200,
                max_gaussians: 60_000,
                ..DensifyConfig::default()
            },
            source: PriorSource::Scan,
            initial_ply: None,
        }
    }
}

/// Stage B: the avatar prior on the human scan (and the avatar in stage D).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AvatarStageConfig {
    pub steps: usize,
    /// Midpoint subdivisions of the built-in body (one Gaussian per vertex): 0 keeps its
    /// vertices, each level about ×4.
    pub subdivisions: usize,
    /// The skinned node in stage B (fitting the scan's body prior and shape).
    pub node: SkinnedConfig,
    pub rates: LearningRates,
    /// Every this many scan views is held out of stage B (its score only).
    pub holdout_every: usize,
    /// The video stage B trains on: the human scan (the paper) or the acting video (Fig. 5's
    /// "without the avatar prior"; [`crate::sources`]).
    pub source: PriorSource,
    /// The avatar's canonical Gaussians from this `.ply` (an earlier run's
    /// `avatar_canonical.ply`: one row per vertex of the body at `subdivisions`, canonical
    /// space, metres) instead of the body's vertices; with `steps = 0` stage D starts from it.
    pub initial_ply: Option<PathBuf>,
}

impl Default for AvatarStageConfig {
    fn default() -> Self {
        Self {
            steps: 800,
            subdivisions: 1,
            node: SkinnedConfig {
                placement: Placement::Vertices,
                initial_opacity: 0.99,
                refine_sequence_offset: false,
                ..SkinnedConfig::default()
            },
            rates: LearningRates::default(),
            holdout_every: 6,
            source: PriorSource::Scan,
            initial_ply: None,
        }
    }
}

/// Stage D's learning rates (spec §4; Adam).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct JointRates {
    /// The scene's SH (DC and the rest, INRIA's); its geometry's rates apply only with
    /// `joint.free_scene`.
    pub scene: LearningRates,
    /// The avatar's canonical Gaussians (`free` variant: RGB and log-radius as INRIA, the
    /// centres — the cloth offsets — per metre).
    pub avatar: LearningRates,
    /// Body motion (6-D rotation deltas and root translation, metres) and shape.
    pub rotation: f64,
    pub translation: f64,
    pub shape: f64,
    /// `s = ln σ`.
    pub log_scale: f64,
    /// Camera refinement: rotation (radians) and translation (per scene unit of the scan's
    /// camera extent).
    pub camera_rotation: f64,
    pub camera_translation: f64,
    /// The pose-dependent offset network.
    pub offsets: f64,
}

impl Default for JointRates {
    fn default() -> Self {
        let frozen = LearningRates {
            means_start: 0.0,
            means_end: 0.0,
            quats: 0.0,
            log_scales: 0.0,
            opacity: 0.0,
            ..LearningRates::default()
        };
        Self {
            scene: frozen,
            avatar: LearningRates {
                means_start: 1e-4,
                means_end: 1e-5,
                ..LearningRates::default()
            },
            rotation: 1e-4,
            translation: 1e-4,
            shape: 1e-5,
            log_scale: 1e-3,
            camera_rotation: 1e-4,
            camera_translation: 1e-4,
            offsets: 1e-4,
        }
    }
}

/// Stage D's terms and switches (the ablations are one line each).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct JointConfig {
    /// `L1` and D-SSIM weights of each photometric term (ExAvatar's 0.8 / 0.2).
    pub l1: f64,
    pub dssim: f64,
    /// The human-only term (over a random background) and the scene-only term (off the mask).
    pub human_term: bool,
    pub scene_term: bool,
    /// λ_n (Eq. 6), λ_c (Eq. 7), λ_r (Huber prior); 0 switches a term off.
    pub normal: f64,
    pub contact: f64,
    pub huber: f64,
    pub huber_deltas: HuberConfig,
    pub contact_rule: ContactConfig,
    /// Learn the pose-dependent offsets ΔV_pose, ΔS_pose.
    pub pose_offsets: bool,
    pub offset_network: PoseOffsetConfig,
    /// Refine the acting cameras (off for the paper's comparisons, §5.1.3). Absent, the
    /// capture decides: on where its acting cameras are estimated, off where they are
    /// calibrated ([`crate::camera::refinement_choice`]); the run keeps the decision here.
    pub camera_refinement: Option<bool>,
    /// Optimise every scene parameter (the "all scene params" ablation) instead of SH only.
    pub free_scene: bool,
    /// σ₀ from the plane (§4.2); otherwise `initial_sigma`. Either is multiplied by
    /// `sigma_scale` (the σ-recovery ablations start it off by a known factor).
    pub sigma_from_plane: bool,
    pub initial_sigma: f64,
    pub sigma_scale: f64,
    /// Stage D's own seed (frame order, random backgrounds), so arms share stages A and B.
    pub seed: u64,
    pub rates: JointRates,
    /// Evaluate every this many synchronised frames.
    pub eval_stride: usize,
}

impl JointConfig {
    /// Whether stage D refines the acting cameras: unless forced off (the run resolves `None`
    /// from the capture before anything reads this).
    pub fn refines_cameras(&self) -> bool {
        self.camera_refinement != Some(false)
    }
}

impl Default for JointConfig {
    fn default() -> Self {
        Self {
            l1: 0.8,
            dssim: 0.2,
            human_term: true,
            scene_term: true,
            normal: 0.05,
            contact: 1.0,
            huber: 1.0,
            huber_deltas: HuberConfig::default(),
            contact_rule: ContactConfig::default(),
            pose_offsets: true,
            offset_network: PoseOffsetConfig::default(),
            camera_refinement: None,
            free_scene: false,
            sigma_from_plane: true,
            initial_sigma: 1.0,
            sigma_scale: 1.0,
            seed: 0,
            rates: JointRates::default(),
            eval_stride: 5,
        }
    }
}

/// A whole run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Prior4dConfig {
    pub backend: Backend,
    /// All steps: `scene.steps + avatar.steps` then stage D to here.
    pub iterations: usize,
    pub eval_every: usize,
    pub checkpoint_every: usize,
    pub lpips_weights: Option<PathBuf>,
    pub seed: u64,
    pub data: Prior4dDataConfig,
    pub scene: SceneStageConfig,
    pub avatar: AvatarStageConfig,
    pub plane: GroundConfig,
    /// Stage C's keypoint refinement of the acting body prior.
    pub body_fit: BodyFitConfig,
    pub joint: JointConfig,
}

impl Default for Prior4dConfig {
    fn default() -> Self {
        Self {
            backend: Backend::Flex,
            iterations: 3100,
            eval_every: 0,
            checkpoint_every: 500,
            lpips_weights: None,
            seed: 0,
            data: Prior4dDataConfig::default(),
            scene: SceneStageConfig::default(),
            avatar: AvatarStageConfig::default(),
            plane: GroundConfig::default(),
            body_fit: BodyFitConfig::default(),
            joint: JointConfig::default(),
        }
    }
}

impl Prior4dConfig {
    /// The first step of stage B and of stage D.
    pub fn avatar_start(&self) -> usize {
        self.scene.steps
    }

    pub fn joint_start(&self) -> usize {
        self.scene.steps + self.avatar.steps
    }
}

impl MethodConfig for Prior4dConfig {
    splatzoo_train::schedule_fields!();

    fn validate(&self) -> Result<(), TrainError> {
        let bad = |m: String| Err(TrainError::Config(m));
        if self.iterations <= self.joint_start() {
            return bad(format!(
                "iterations ({}) must exceed scene.steps + avatar.steps ({}): stage D needs steps",
                self.iterations,
                self.joint_start()
            ));
        }
        if self.scene.sh_degree > 3 {
            return bad("scene.sh_degree ≤ 3".into());
        }
        if self.scene.holdout_every < 2 || self.avatar.holdout_every < 2 {
            return bad("scene.holdout_every and avatar.holdout_every ≥ 2".into());
        }
        if !(self.plane.min_opacity > 0.0 && self.plane.min_opacity < 1.0) {
            return bad(format!(
                "plane.min_opacity in (0, 1), got {}",
                self.plane.min_opacity
            ));
        }
        if self.avatar.subdivisions > 2 {
            return bad("avatar.subdivisions ≤ 2".into());
        }
        if self.avatar.node.placement != Placement::Vertices {
            return bad(
                "avatar.node.placement must be \"vertices\" (one Gaussian per mesh vertex)".into(),
            );
        }
        let j = &self.joint;
        for (name, v) in [
            ("joint.l1", j.l1),
            ("joint.dssim", j.dssim),
            ("joint.normal", j.normal),
            ("joint.contact", j.contact),
            ("joint.huber", j.huber),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return bad(format!("{name} must be finite and ≥ 0, got {v}"));
            }
        }
        for (name, v) in [
            ("joint.initial_sigma", j.initial_sigma),
            ("joint.sigma_scale", j.sigma_scale),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return bad(format!("{name} must be finite and > 0, got {v}"));
            }
        }
        if j.eval_stride == 0 {
            return bad("joint.eval_stride ≥ 1".into());
        }
        let b = &self.body_fit;
        if b.iterations == 0 || !(b.robust_sigma_px.is_finite() && b.robust_sigma_px > 0.0) {
            return bad(format!(
                "body_fit.iterations ≥ 1 and body_fit.robust_sigma_px > 0, got {} and {}",
                b.iterations, b.robust_sigma_px
            ));
        }
        if self.scene.densify.strategy != Strategy::None
            && self.scene.steps > 0
            && self.scene.densify.stop > self.scene.steps
        {
            return bad(format!(
                "scene.densify.stop ({}) must not pass scene.steps ({})",
                self.scene.densify.stop, self.scene.steps
            ));
        }
        self.data.validate().map_err(TrainError::Config)?;
        self.avatar.node.validate()
    }
}
