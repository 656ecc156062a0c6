//! The seam between score distillation and a denoising model: [`ScoreModel`] is what any
//! ε- or v-predictor plugs into (the in-project oracles of [`crate::oracle`] today; an ONNX UNet
//! run in tract is the real-model adapter of the spec's §3), and the SDS driver
//! ([`crate::sds::SdsConfig::guidance`]) is written against it alone.
//!
//! Models see host arrays ([`LatentBatch`]): a denoiser is called without gradient (SDS stops
//! the gradient at the model, Eq. 3), and tract and the oracles work on host memory anyway.

use crate::error::AagError;
use crate::schedule::NoiseSchedule;
use serde::{Deserialize, Serialize};
use splatzoo_rasterizer::Camera;

/// What a model's output means (U2 of the spec).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum Prediction {
    /// The noise ε.
    Epsilon,
    /// v = α_t ε − σ_t x_0 (Salimans & Ho).
    V,
}

/// A batch of images or latents, `[B, C, H, W]` row-major, on the host.
#[derive(Debug, Clone, PartialEq)]
pub struct LatentBatch {
    pub shape: [usize; 4],
    pub data: Vec<f32>,
}

impl LatentBatch {
    pub fn zeros(shape: [usize; 4]) -> Self {
        Self {
            shape,
            data: vec![0.0; shape.iter().product()],
        }
    }

    /// Elements per batch item (`C · H · W`).
    pub fn item_len(&self) -> usize {
        self.shape[1] * self.shape[2] * self.shape[3]
    }

    pub fn item(&self, b: usize) -> &[f32] {
        let n = self.item_len();
        &self.data[b * n..(b + 1) * n]
    }

    pub fn item_mut(&mut self, b: usize) -> &mut [f32] {
        let n = self.item_len();
        &mut self.data[b * n..(b + 1) * n]
    }

    /// `times` copies of the batch one after another (`[times · B, C, H, W]`).
    pub fn repeat(&self, times: usize) -> Self {
        let [b, c, h, w] = self.shape;
        Self {
            shape: [times * b, c, h, w],
            data: self.data.repeat(times),
        }
    }

    /// Items `range` of the batch.
    pub fn items(&self, range: std::ops::Range<usize>) -> Self {
        let n = self.item_len();
        let [_, c, h, w] = self.shape;
        Self {
            shape: [range.len(), c, h, w],
            data: self.data[range.start * n..range.end * n].to_vec(),
        }
    }
}

/// Which text rows a batch item is conditioned on (the stacked CFG call, U1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PromptKind {
    /// The user's prompt (with its view suffix).
    Cond,
    /// The negative prompt.
    Negative,
    /// The empty prompt.
    Null,
}

/// The view-dependent prompt suffix (HumanGaussian's ", front view" …), from the camera's
/// azimuth relative to the body's facing direction and its elevation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ViewClass {
    Front,
    Side,
    Back,
    Overhead,
}

impl ViewClass {
    /// Front |az| < 45°, back |az| > 135°, overhead elevation > 60°, side otherwise.
    pub fn of(azimuth_degrees: f64, elevation_degrees: f64) -> Self {
        let az = (azimuth_degrees + 180.0).rem_euclid(360.0) - 180.0;
        if elevation_degrees > 60.0 {
            ViewClass::Overhead
        } else if az.abs() < 45.0 {
            ViewClass::Front
        } else if az.abs() > 135.0 {
            ViewClass::Back
        } else {
            ViewClass::Side
        }
    }

    pub fn suffix(self) -> &'static str {
        match self {
            ViewClass::Front => ", front view",
            ViewClass::Side => ", side view",
            ViewClass::Back => ", back view",
            ViewClass::Overhead => ", overhead view",
        }
    }
}

/// Everything a model call is conditioned on, one entry per batch item: the prompt row, the
/// view class selecting its suffix, and the camera the pose condition is drawn from (a real
/// model's skeleton map; the oracle renders its identities there).
#[derive(Debug, Clone)]
pub struct Conditioning {
    pub prompts: Vec<PromptKind>,
    pub views: Vec<ViewClass>,
    pub cameras: Vec<Camera>,
}

impl Conditioning {
    pub fn len(&self) -> usize {
        self.prompts.len()
    }

    pub fn is_empty(&self) -> bool {
        self.prompts.is_empty()
    }
}

/// A denoiser: given noisy inputs of every branch at timesteps `t`, its prediction of each
/// branch, in its [`Prediction`] type. Called without gradient.
pub trait ScoreModel {
    fn schedule(&self) -> &NoiseSchedule;
    fn prediction(&self) -> Prediction;
    /// 1: RGB only; 2: RGB + depth (Eq. 5).
    fn branches(&self) -> usize;
    /// The factor the branches are multiplied by before noising (SD's 0.18215 on VAE latents;
    /// 1 in pixel space).
    fn latent_scale(&self) -> f64 {
        1.0
    }
    /// `noisy[k]` is branch k's `[N, C, H, W]`; `t` and `cond` have N entries.
    fn predict(
        &self,
        noisy: &[LatentBatch],
        t: &[usize],
        cond: &Conditioning,
    ) -> Result<Vec<LatentBatch>, AagError>;
}

/// ε from a prediction of type `prediction` at `x_t` (U2): `ε = α_t v + σ_t x_t` for v, which
/// stays defined at zero terminal SNR (α = 0, σ = 1) where `x_0` is not.
pub fn epsilon_from(prediction: Prediction, output: f64, x_t: f64, alpha: f64, sigma: f64) -> f64 {
    match prediction {
        Prediction::Epsilon => output,
        Prediction::V => alpha * output + sigma * x_t,
    }
}

/// v from ε and `x_0` (`v = α_t ε − σ_t x_0`).
pub fn v_from(epsilon: f64, x0: f64, alpha: f64, sigma: f64) -> f64 {
    alpha * epsilon - sigma * x0
}
