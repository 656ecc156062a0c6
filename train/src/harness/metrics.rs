//! What `metrics.json` holds: held-out scores per evaluation, reference baselines, and after the
//! run a summary. The history travels inside every checkpoint, so a resumed run — wherever its
//! checkpoint was copied — continues the same list (evaluations past the checkpoint's step are
//! dropped).

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Image-quality scores averaged over held-out views.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Scores {
    pub psnr: f64,
    pub ssim: f64,
    /// Present when LPIPS weights were given.
    pub lpips: Option<f64>,
}

impl Scores {
    /// `PSNR 27.01 dB, SSIM 0.9420[, LPIPS 0.0712]`.
    pub fn line(&self) -> String {
        let lpips = self
            .lpips
            .map(|l| format!(", LPIPS {l:.4}"))
            .unwrap_or_default();
        format!("PSNR {:.2} dB, SSIM {:.4}{lpips}", self.psnr, self.ssim)
    }
}

/// Sums of per-view scores, averaged at the end.
#[derive(Debug, Clone, Copy, Default)]
pub struct ScoreSum {
    psnr: f64,
    ssim: f64,
    lpips: f64,
    views: usize,
    with_lpips: bool,
}

impl ScoreSum {
    pub fn add(&mut self, psnr: f64, ssim: f64, lpips: Option<f64>) {
        self.psnr += psnr;
        self.ssim += ssim;
        self.lpips += lpips.unwrap_or(0.0);
        self.with_lpips |= lpips.is_some();
        self.views += 1;
    }

    pub fn mean(&self) -> Scores {
        let n = self.views.max(1) as f64;
        Scores {
            psnr: self.psnr / n,
            ssim: self.ssim / n,
            lpips: self.with_lpips.then(|| self.lpips / n),
        }
    }
}

/// One evaluation: of held-out views, unless `training_views`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Evaluation {
    pub step: usize,
    #[serde(flatten)]
    pub scores: Scores,
    /// The scores are of views the method trains on (a capture with nothing held out: a single
    /// photo, say), so they measure the fit, not generalisation.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub training_views: bool,
    /// Further figures of the method at this step (Gaussian count, scores on other view sets).
    #[serde(flatten)]
    pub extra: BTreeMap<String, serde_json::Value>,
}

impl Evaluation {
    pub fn new(step: usize, scores: Scores) -> Self {
        Self {
            step,
            scores,
            training_views: false,
            extra: BTreeMap::new(),
        }
    }

    /// Marks the scores as of training views.
    pub fn of_training_views(mut self) -> Self {
        self.training_views = true;
        self
    }

    /// `held-out` or `training-view`, for logs.
    pub fn kind(&self) -> &'static str {
        if self.training_views {
            "training-view"
        } else {
            "held-out"
        }
    }

    pub fn with(mut self, key: &str, value: impl Into<serde_json::Value>) -> Self {
        self.extra.insert(key.to_owned(), value.into());
        self
    }
}

/// Everything `metrics.json` keeps across a run and its resumptions.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct History {
    pub method: String,
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub baselines: BTreeMap<String, Scores>,
    pub evaluations: Vec<Evaluation>,
}
