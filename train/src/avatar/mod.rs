//! `train-avatar`: a per-subject animatable Gaussian avatar from video (the job of GauHuman,
//! 3DGS-Avatar and GART), the proof of the engine's skinned node on its own the way
//! `train-3dgs` proves the static path. One [`SkinnedGaussianNode`] on the built-in body,
//! trained against the masked frames of a monocular capture with `(1 − λ) L1 + λ D-SSIM`, a
//! silhouette term on the rendered alpha, a scale regulariser and the node's temporal
//! smoothness; poses refined per training frame, held-out frames interpolated.
//!
//! Evaluation: novel views (training frames, a camera never trained on) and novel poses
//! (held-out frames, the training camera), each full-image and over the human region; the
//! refined track's joint error against the generator's true motion beside the prior's.
//!
//! [`SkinnedGaussianNode`]: crate::scene::SkinnedGaussianNode

pub mod capture;
pub mod data;
mod eval;
pub mod refinement;
pub mod scenery;
mod trainer;

pub use data::{AvatarCapture, AvatarDataConfig, AvatarFrame, AvatarPreset, AvatarView};
pub use eval::{mpjpe_mm, project, track_joints};
pub use trainer::{AvatarArgs, AvatarTrainer, HUMAN};

use crate::backend::Backend;
use crate::densify::DensifyConfig;
use crate::error::TrainError;
use crate::harness::MethodConfig;
use crate::optimizer::LearningRates;
use crate::scene::skinned::SkinnedConfig;
use serde::{Deserialize, Serialize};
use splatzoo_models::body::{BodyModel, builtin_body, load_body_model};
use std::path::PathBuf;

/// Every knob of a `train-avatar` run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AvatarConfig {
    pub backend: Backend,
    pub iterations: usize,
    pub eval_every: usize,
    pub checkpoint_every: usize,
    pub seed: u64,
    pub lpips_weights: Option<PathBuf>,
    /// An SMPL, SMPL-H or SMPL-X file (`.npz`/`.pkl`); the built-in body when absent.
    pub body_model: Option<PathBuf>,
    /// Weight of D-SSIM in the photometric loss.
    pub lambda_dssim: f64,
    /// Weight of `|alpha − mask|`.
    pub mask_weight: f64,
    /// Weight of the penalty on standard deviations above `max_scale` metres.
    pub scale_weight: f64,
    pub max_scale: f64,
    /// Highest SH degree, raised one degree per `sh_degree_every` steps.
    pub sh_degree: u32,
    pub sh_degree_every: usize,
    /// sRGB background the avatar is rendered over (and the masked targets use).
    pub background: [f32; 3],
    /// A static background node beside the avatar: absent, where the capture has sparse
    /// points of its surroundings; `true`/`false` force it.
    pub scenery: Option<bool>,
    /// Per-frame pose refinement: absent, wherever the body track is an estimate (not where
    /// it is the true motion, [`refinement`]); `true`/`false` force it. The run keeps the
    /// decision here.
    pub pose_refinement: Option<bool>,
    /// Weight of the composite (human + background, whole image) loss when there is one.
    pub scenery_weight: f64,
    /// The background node's density control.
    pub scenery_densify: DensifyConfig,
    pub data: AvatarDataConfig,
    pub node: SkinnedConfig,
    pub rates: LearningRates,
    pub densify: DensifyConfig,
}

impl Default for AvatarConfig {
    fn default() -> Self {
        Self {
            backend: Backend::Flex,
            iterations: 2000,
            eval_every: 1000,
            checkpoint_every: 1000,
            seed: 0,
            lpips_weights: None,
            body_model: None,
            lambda_dssim: 0.2,
            mask_weight: 0.1,
            scale_weight: 1.0,
            max_scale: 0.03,
            sh_degree: 1,
            sh_degree_every: 500,
            background: [0.0; 3],
            scenery: None,
            pose_refinement: None,
            scenery_weight: 1.0,
            scenery_densify: DensifyConfig::default(),
            data: AvatarDataConfig::default(),
            node: SkinnedConfig::default(),
            rates: LearningRates::default(),
            densify: DensifyConfig {
                max_gaussians: 60_000,
                ..DensifyConfig::default()
            },
        }
    }
}

impl AvatarConfig {
    /// The body the avatar is skinned on: `body_model`'s file, else the built-in body.
    pub fn body(&self) -> Result<BodyModel, TrainError> {
        match &self.body_model {
            Some(path) => Ok(load_body_model(path)?),
            None => Ok(builtin_body().model.clone()),
        }
    }
}

impl MethodConfig for AvatarConfig {
    crate::schedule_fields!();

    fn validate(&self) -> Result<(), TrainError> {
        let bad = |m: String| Err(TrainError::Config(m));
        if self.iterations == 0 {
            return bad("iterations ≥ 1".into());
        }
        if self.sh_degree > 3 {
            return bad("sh_degree ≤ 3".into());
        }
        if !(0.0..=1.0).contains(&self.lambda_dssim) {
            return bad("lambda_dssim in [0, 1]".into());
        }
        if self.data.holdout_every < 2 || self.data.novel_view_every == 0 {
            return bad("data.holdout_every ≥ 2 and data.novel_view_every ≥ 1".into());
        }
        if self.data.downscale == 0 {
            return bad("data.downscale ≥ 1".into());
        }
        if self.data.frames < self.data.holdout_every {
            return bad(format!(
                "data.frames ({}) must be at least data.holdout_every ({})",
                self.data.frames, self.data.holdout_every
            ));
        }
        if self.data.width < 16 || self.data.height < 16 {
            return bad("data.width and data.height ≥ 16".into());
        }
        for (name, v) in [
            ("mask_weight", self.mask_weight),
            ("scale_weight", self.scale_weight),
            ("max_scale", self.max_scale),
            ("scenery_weight", self.scenery_weight),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return bad(format!("{name} must be finite and ≥ 0, got {v}"));
            }
        }
        self.node.validate()
    }
}
