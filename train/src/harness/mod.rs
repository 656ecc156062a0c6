//! The contract every `train-<method>` binary is built on, and the one CLI that runs it.
//!
//! A method implements [`Method`]: it is created from its configuration ([`Method::new`]) or
//! from a checkpoint ([`Method::resume`]), takes optimiser steps ([`Method::step`]), evaluates
//! on held-out data ([`Method::evaluate`]), writes its whole state into a [`Checkpoint`]
//! ([`Method::checkpoint`]) and, at the end, its exports ([`Method::finish`]). Everything
//! around that — `--config`/`--set`/`--print-config`/`--resume`/`--name`/`--backend`, the run
//! directory, the log, the progress bar, Ctrl-C, the evaluation and checkpoint schedule, the
//! `metrics.json` policy and the checkpoint's format tag — lives once in [`cli`], so a
//! `train-<method>` binary is `fn main() -> ExitCode { cli::main::<MyMethod>() }`.

pub mod arms;
pub mod cli;
mod epoch;
pub mod extremes;
mod metrics;
mod modules;

pub use epoch::EpochOrder;
pub use metrics::{Evaluation, History, ScoreSum, Scores};
pub use modules::ModuleChoice;

use crate::backend::Backend;
use crate::checkpoint::{Checkpoint, CheckpointError};
use crate::error::TrainError;
use crate::lpips::Lpips;
use burn::tensor::Device;
use serde::Serialize;
use serde::de::DeserializeOwned;
use std::path::Path;

/// The knobs the harness reads from every method's configuration (the rest is the method's).
/// `backend` and `iterations` must be top-level keys (`--backend` and `--iterations` set them).
pub trait MethodConfig:
    Serialize + DeserializeOwned + Default + Clone + PartialEq + std::fmt::Debug
{
    fn backend(&self) -> Backend;
    fn iterations(&self) -> usize;
    /// Held-out evaluation every this many steps (and always at the end; 0: only then).
    fn eval_every(&self) -> usize;
    /// Checkpoint every this many steps (0: only at the end and on Ctrl-C).
    fn checkpoint_every(&self) -> usize;
    /// LPIPS backbone weights, when the user gave them.
    fn lpips_weights(&self) -> Option<&Path>;
    /// Every range a knob must respect, checked before anything is loaded.
    fn validate(&self) -> Result<(), TrainError>;
}

/// Implements [`MethodConfig`]'s schedule accessors inside an `impl MethodConfig for …` block
/// for a configuration with the fields `backend`, `iterations`, `eval_every`,
/// `checkpoint_every` and `lpips_weights: Option<PathBuf>`; the block adds `validate`.
#[macro_export]
macro_rules! schedule_fields {
    () => {
        fn backend(&self) -> $crate::backend::Backend {
            self.backend
        }

        fn iterations(&self) -> usize {
            self.iterations
        }

        fn eval_every(&self) -> usize {
            self.eval_every
        }

        fn checkpoint_every(&self) -> usize {
            self.checkpoint_every
        }

        fn lpips_weights(&self) -> Option<&std::path::Path> {
            self.lpips_weights.as_deref()
        }
    };
}

/// One step's outcome, for the progress bar and the log.
#[derive(Debug, Clone, Default)]
pub struct StepReport {
    pub loss: f64,
    /// Anything worth a log line (density control, a schedule change).
    pub note: Option<String>,
}

/// Where a method's messages go (the terminal, above the progress bar, and `log.txt`).
pub trait Say {
    fn say(&mut self, line: &str);
}

pub trait Method: Sized {
    /// The run directory's parent (`runs/<NAME>/<name>/`) and `metrics.json`'s `method`.
    const NAME: &'static str;
    /// The format tag written into every checkpoint and checked on every read.
    const FORMAT: &'static str;
    /// One line for `--help`.
    const ABOUT: &'static str;
    type Config: MethodConfig;
    /// Method-specific command-line shorthands (each becomes `--set` overrides).
    type Args: clap::Args + std::fmt::Debug;

    /// The `--set` overrides the method's shorthands stand for.
    fn overrides(args: &Self::Args) -> Vec<String>;
    /// A fresh run.
    fn new(config: Self::Config, device: &Device) -> Result<Self, TrainError>;
    /// Continues from `checkpoint` (its format already checked) with `config`, which is the
    /// checkpoint's configuration with the user's overrides on top.
    fn resume(
        config: Self::Config,
        checkpoint: &Checkpoint,
        device: &Device,
    ) -> Result<Self, TrainError>;
    /// Optimiser steps taken.
    fn steps(&self) -> usize;
    /// The line printed once the method is ready (data, sizes).
    fn describe(&self) -> String;
    /// What the method decided from its data and why (which nodes and modules the scene got,
    /// how the capture was split), printed one per line after [`Self::describe`].
    fn decisions(&self) -> Vec<String> {
        Vec::new()
    }
    /// Each optional module of the scene, whether this run built it and why (printed after the
    /// decisions, kept in `metrics.json`'s `modules`).
    fn modules(&self) -> Vec<ModuleChoice>;
    /// Reference scores computed once at the start of a fresh run (`metrics.json`'s
    /// `baselines`), by name.
    fn baselines(&self, _lpips: Option<&Lpips>) -> Result<Vec<(String, Scores)>, TrainError> {
        Ok(Vec::new())
    }
    fn step(&mut self) -> Result<StepReport, TrainError>;
    /// Held-out scores now.
    fn evaluate(&self, lpips: Option<&Lpips>) -> Result<Evaluation, TrainError>;
    /// Renders what [`Self::evaluate`] renders, once, without scoring it, each frame read back
    /// to the host (see [`read_back`]); returns how many frames. The harness times repeated
    /// passes after training for `metrics.json`'s `render_fps` (inference: for a feed-forward
    /// method that includes decoding the avatar).
    fn render_held_out(&self) -> Result<usize, TrainError>;
    /// Gaussians in the whole scene now (`metrics.json`'s `gaussians`).
    fn gaussians(&self) -> usize;
    /// The method's whole state (the harness adds the format tag, the configuration, the step
    /// and the metrics history).
    fn checkpoint(&self) -> Checkpoint;
    /// Exports at the end of training (renders, `.ply`, ONNX, …) into the run directory `run`;
    /// returns extra summary fields for `metrics.json`.
    fn finish(
        &self,
        run: &Path,
        say: &mut dyn Say,
    ) -> Result<serde_json::Map<String, serde_json::Value>, TrainError>;
}

/// Waits for `image` and copies it to the host, so a timed render includes all of its work on
/// lazy or asynchronous backends (wgpu, fusion).
pub fn read_back<const D: usize>(image: &burn::tensor::Tensor<D>) {
    drop(crate::host_f32(image));
}

/// This process's peak resident memory in bytes (Linux's `VmHWM`: host memory, with image
/// caches, LPIPS and exports; on lavapipe it includes the "GPU" buffers, on a real GPU it does
/// not see device memory); `None` where the system does not say.
pub fn peak_rss_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let kib = status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))?
        .trim()
        .strip_suffix("kB")?
        .trim()
        .parse::<u64>()
        .ok()?;
    Some(kib * 1024)
}

/// Refuses a checkpoint whose format tag is not `format` (every reader calls this first).
pub fn check_format(checkpoint: &Checkpoint, format: &str) -> Result<(), CheckpointError> {
    let found = checkpoint.meta("format")?;
    if found == format {
        Ok(())
    } else {
        Err(CheckpointError::Entry {
            file: checkpoint.origin.clone(),
            name: "format".into(),
            problem: format!("`{found}`, expected `{format}`"),
        })
    }
}

/// The configuration a checkpoint of method `M` was written with (format checked).
pub fn checkpoint_config<M: Method>(checkpoint: &Checkpoint) -> Result<M::Config, TrainError> {
    check_format(checkpoint, M::FORMAT)?;
    let text = checkpoint.meta("config")?;
    toml::from_str(text).map_err(|e| {
        CheckpointError::Entry {
            file: checkpoint.origin.clone(),
            name: "config".into(),
            problem: format!("not a {} configuration: {e}", M::NAME),
        }
        .into()
    })
}

/// The checkpoint a run writes: the method's state plus the format tag, the configuration, the
/// step and the metrics history.
pub fn full_checkpoint<M: Method>(method: &M, config: &M::Config, history: &History) -> Checkpoint {
    let mut checkpoint = method.checkpoint();
    checkpoint.put_meta("format", M::FORMAT);
    checkpoint.put_meta("config", crate::config::to_toml(config));
    checkpoint.put_meta("step", method.steps());
    checkpoint.put_meta(
        "metrics",
        serde_json::to_string(history).expect("plain data serialises"),
    );
    checkpoint
}
