//! What a sweep keeps per run ([`PointRecord`]: the row of `sweep.csv`) and per point over its
//! seeds ([`PointSummary`]: mean and range, the rows the fronts are computed on).

use super::runner::RunSpec;
use serde::{Deserialize, Serialize};
use std::path::Path;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    Ok,
    Failed,
}

/// One run: a point at one seed, and what it measured.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PointRecord {
    pub point: String,
    pub seed: u64,
    pub status: Status,
    /// A failed run's exit and last error line.
    pub error: Option<String>,
    /// Every `--set` the run had.
    pub set: Vec<String>,
    /// FNV-1a of the effective configuration: a finished run is reused only while it matches.
    pub config_hash: String,
    /// The trainer binary's modification time (seconds since the epoch) when it ran.
    pub binary_modified: Option<u64>,
    pub psnr: Option<f64>,
    pub ssim: Option<f64>,
    pub lpips: Option<f64>,
    /// The sweep file's headline metric.
    pub headline: Option<f64>,
    /// Wall time of the optimiser steps alone (held-out evaluations, checkpoints and exports
    /// left out, so their schedule does not move a point).
    pub train_seconds: Option<f64>,
    /// The child's whole wall time (data, training, exports, the render timing).
    pub wall_seconds: Option<f64>,
    pub steps_per_second: Option<f64>,
    pub render_fps: Option<f64>,
    /// Peak resident host memory of the run (Linux's `VmHWM`; device memory on a real GPU is
    /// not in it).
    pub peak_rss_mib: Option<f64>,
    pub gaussians: Option<u64>,
    /// The final checkpoint (everything needed to resume).
    pub checkpoint_bytes: Option<u64>,
    /// Everything the run wrote (exports and renders too).
    pub run_bytes: Option<u64>,
}

/// The columns of `sweep.csv`, in order.
pub const CSV_HEADER: &str = "point,seed,status,psnr,ssim,lpips,headline,train_seconds,\
wall_seconds,steps_per_second,render_fps,peak_rss_mib,gaussians,checkpoint_bytes,run_bytes,\
set,error";

impl PointRecord {
    /// A record of `run` with nothing measured yet (status ok until a failure is found).
    pub fn new(run: &RunSpec) -> Self {
        Self {
            point: run.point.clone(),
            seed: run.seed,
            status: Status::Ok,
            error: None,
            set: run.set.clone(),
            config_hash: String::new(),
            binary_modified: None,
            psnr: None,
            ssim: None,
            lpips: None,
            headline: None,
            train_seconds: None,
            wall_seconds: None,
            steps_per_second: None,
            render_fps: None,
            peak_rss_mib: None,
            gaussians: None,
            checkpoint_bytes: None,
            run_bytes: None,
        }
    }

    /// Fills the figures from a finished run directory; a missing summary marks it failed.
    /// `headline` is a JSON pointer into `metrics.json`.
    pub fn read_run(&mut self, dir: &Path, headline: Option<&str>) {
        let metrics = dir.join("metrics.json");
        let value: Option<serde_json::Value> = std::fs::read_to_string(&metrics)
            .ok()
            .and_then(|t| serde_json::from_str(&t).ok());
        let Some(value) = value.filter(|v| v.get("seconds").is_some()) else {
            self.status = Status::Failed;
            self.error = Some(format!("{} has no run summary", metrics.display()));
            return;
        };
        let number = |pointer: &str| value.pointer(pointer).and_then(serde_json::Value::as_f64);
        self.psnr = number("/final/psnr");
        self.ssim = number("/final/ssim");
        self.lpips = number("/final/lpips");
        self.headline = headline.and_then(number);
        self.train_seconds = number("/step_seconds").or_else(|| number("/loop_seconds"));
        self.steps_per_second = number("/steps_per_second");
        self.render_fps = number("/render_fps");
        self.peak_rss_mib = number("/peak_rss_bytes").map(|b| b / (1024.0 * 1024.0));
        self.gaussians = value
            .pointer("/gaussians")
            .and_then(serde_json::Value::as_u64);
        self.checkpoint_bytes = std::fs::metadata(dir.join("checkpoint.safetensors"))
            .ok()
            .map(|m| m.len());
        self.run_bytes = Some(folder_bytes(dir));
        if self.psnr.is_none_or(|p| !p.is_finite()) {
            self.status = Status::Failed;
            self.error = Some(format!("{}: no finite final PSNR", metrics.display()));
        }
    }

    /// The record as a `sweep.csv` row.
    pub fn csv_row(&self) -> String {
        let f = |v: Option<f64>| v.map_or(String::new(), |v| format!("{v}"));
        let u = |v: Option<u64>| v.map_or(String::new(), |v| v.to_string());
        let status = match self.status {
            Status::Ok => "ok",
            Status::Failed => "failed",
        };
        [
            csv_field(&self.point),
            self.seed.to_string(),
            status.into(),
            f(self.psnr),
            f(self.ssim),
            f(self.lpips),
            f(self.headline),
            f(self.train_seconds),
            f(self.wall_seconds),
            f(self.steps_per_second),
            f(self.render_fps),
            f(self.peak_rss_mib),
            u(self.gaussians),
            u(self.checkpoint_bytes),
            u(self.run_bytes),
            csv_field(&self.set.join(" ")),
            csv_field(self.error.as_deref().unwrap_or("")),
        ]
        .join(",")
    }
}

/// A value quoted for CSV where it needs to be.
fn csv_field(text: &str) -> String {
    if text.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", text.replace('"', "\"\""))
    } else {
        text.to_owned()
    }
}

/// Bytes of every file under `dir`.
fn folder_bytes(dir: &Path) -> u64 {
    std::fs::read_dir(dir).map_or(0, |entries| {
        entries
            .filter_map(Result::ok)
            .map(|e| match e.metadata() {
                Ok(m) if m.is_dir() => folder_bytes(&e.path()),
                Ok(m) => m.len(),
                Err(_) => 0,
            })
            .sum()
    })
}

/// Mean and range of one figure over a point's seeds.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Spread {
    pub mean: f64,
    pub min: f64,
    pub max: f64,
}

impl Spread {
    /// Over the finite values; `None` when there are none.
    pub fn of(values: impl IntoIterator<Item = f64>) -> Option<Self> {
        let values: Vec<f64> = values.into_iter().filter(|v| v.is_finite()).collect();
        if values.is_empty() {
            return None;
        }
        Some(Self {
            mean: values.iter().sum::<f64>() / values.len() as f64,
            min: values.iter().copied().fold(f64::INFINITY, f64::min),
            max: values.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        })
    }
}

/// One point over its successful seeds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PointSummary {
    pub point: String,
    /// The point's own overrides (after the sweep's base).
    pub set: Vec<String>,
    pub default: bool,
    pub seeds: usize,
    pub failed: usize,
    /// The score the fronts use (see the sweep file's `quality`).
    pub quality: Option<Spread>,
    pub psnr: Option<Spread>,
    pub headline: Option<Spread>,
    pub train_seconds: Option<Spread>,
    pub render_fps: Option<Spread>,
    pub peak_rss_mib: Option<Spread>,
    pub gaussians: Option<Spread>,
    /// On the front of quality against training time.
    pub time_front: bool,
    /// On the front of quality against render FPS.
    pub fps_front: bool,
}
