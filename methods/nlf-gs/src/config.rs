//! `train-nlf`'s configuration: every knob of the data, the network, the schedule and the loss,
//! read as TOML over these defaults (`--print-config` shows them).

use crate::loss::NlfLossWeights;
use crate::network::NlfConfig;
use serde::{Deserialize, Serialize};
use splatzoo_train::TrainError;
use splatzoo_train::backend::Backend;
use splatzoo_train::harness::MethodConfig;
use std::path::PathBuf;

/// The views the loss sees.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Supervision {
    /// The input views 0°/120°/240°, the paper's "training views" (§4.2).
    Inputs,
    /// The novel views 60°/180°/300° (what this trainer did before; the scores at novel views
    /// then measure identity generalisation only).
    Targets,
}

/// Where the subjects come from: the synthetic generator (the default), or a real capture's
/// split folders ([`crate::capture`]: THuman2.0 in GHG's layout, `THuman/train` and
/// `THuman/val`) with the body model its fits are for.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NlfData {
    /// Training subjects (the first `train_subjects` with a body fit).
    pub train: Option<PathBuf>,
    /// Held-out subjects (the first `test_subjects`).
    pub test: Option<PathBuf>,
    /// SMPL / SMPL-H / SMPL-X `.npz` or `.pkl` the capture's fits are for (THuman2.0: SMPL-X);
    /// without it the built-in body takes the fits' body joints.
    pub body_model: Option<PathBuf>,
}

/// Everything `train-nlf` reads from its TOML configuration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NlfTrainConfig {
    pub backend: Backend,
    /// Image side in pixels.
    pub size: u32,
    /// Training identities are seeds `0..train_subjects`; held-out ones start at `test_seed`.
    pub train_subjects: usize,
    pub test_subjects: usize,
    pub test_seed: u64,
    pub iterations: usize,
    pub learning_rate: f64,
    /// Seeds the network's random initialisation.
    pub seed: u64,
    /// Pretrained ResNet weights in torchvision naming (safetensors; `conv1.weight`,
    /// `layer1.0.bn1.running_mean`, …) to start the encoder from; the FPN and decoder start
    /// random. Without it the encoder starts random too.
    pub encoder_weights: Option<PathBuf>,
    pub eval_every: usize,
    /// Steps between checkpoints (0: only at the end and on Ctrl-C).
    pub checkpoint_every: usize,
    /// AlexNet or VGG-16 weights in torchvision naming (safetensors): adds LPIPS to the metrics.
    pub lpips_weights: Option<PathBuf>,
    /// Export the encoder and decoder to ONNX (`onnx/`) at the end.
    pub onnx: bool,
    /// Which views the loss is computed at.
    pub supervision: Supervision,
    pub network: NlfConfig,
    pub loss: NlfLossWeights,
    pub data: NlfData,
}

impl Default for NlfTrainConfig {
    fn default() -> Self {
        Self {
            backend: Backend::Flex,
            size: 96,
            train_subjects: 12,
            test_subjects: 3,
            test_seed: 10_000,
            iterations: 500,
            learning_rate: 5e-4,
            seed: 0,
            encoder_weights: None,
            eval_every: 100,
            checkpoint_every: 100,
            lpips_weights: None,
            onnx: true,
            supervision: Supervision::Inputs,
            network: NlfConfig::default(),
            loss: NlfLossWeights::default(),
            data: NlfData::default(),
        }
    }
}

impl MethodConfig for NlfTrainConfig {
    splatzoo_train::schedule_fields!();

    fn validate(&self) -> Result<(), TrainError> {
        let bad = |m: String| Err(TrainError::Config(m));
        if self.iterations == 0 || self.train_subjects == 0 || self.test_subjects == 0 {
            return bad("iterations, train_subjects and test_subjects must be ≥ 1".into());
        }
        if self.size < 32 {
            return bad(format!("size {} is below the minimum of 32", self.size));
        }
        if !(self.learning_rate > 0.0 && self.learning_rate.is_finite()) {
            return bad(format!(
                "learning_rate {} must be positive",
                self.learning_rate
            ));
        }
        if self.network.gaussians_per_face == 0 {
            return bad("network.gaussians_per_face must be ≥ 1".into());
        }
        let d = &self.data;
        if d.train.is_some() != d.test.is_some() {
            return bad("data.train and data.test name a capture's two splits: give both".into());
        }
        if d.body_model.is_some() && d.train.is_none() {
            return bad(
                "data.body_model poses a capture's fits: set data.train and data.test".into(),
            );
        }
        Ok(())
    }
}
