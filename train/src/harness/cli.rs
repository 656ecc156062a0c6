//! The one command line of every `train-<method>` binary and the loop it runs: configuration
//! (`--config` file over the defaults or a resumed checkpoint's, then `--set` overrides and the
//! method's shorthands), `--print-config`, the run directory `runs/<method>/<name>/` with
//! `config.toml` and `log.txt`, a progress bar, evaluations on the schedule (`metrics.json`
//! rewritten atomically after each, its history kept across resumes), checkpoints on the
//! schedule and on Ctrl-C (exit code 130), and at the end the method's exports and a summary
//! (wall time, the training loop's time and its optimiser steps' alone, steps/s, render FPS of
//! the held-out frames, Gaussians, peak resident memory).

use super::{History, StepReport};
use super::{Method, MethodConfig, Say, check_format, checkpoint_config, full_checkpoint};
use crate::backend::Backend;
use crate::checkpoint::Checkpoint;
use crate::config;
use crate::error::TrainError;
use crate::lpips::Lpips;
use crate::run_dir::RunDir;
use clap::{CommandFactory, FromArgMatches, Parser};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

/// The options every `train-<method>` binary takes; `E` adds the method's shorthands.
#[derive(Parser, Debug)]
pub struct Args<E: clap::Args> {
    /// TOML configuration (any subset of the keys `--print-config` shows).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Override one key, e.g. `--set densify.grad_threshold=0.0004` (repeatable; applied last).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub overrides: Vec<String>,
    /// Shorthand for `--set iterations=N`.
    #[arg(long)]
    pub iterations: Option<usize>,
    /// Shorthand for `--set backend=…`.
    #[arg(long, value_enum)]
    pub backend: Option<Backend>,
    /// Continue from a checkpoint (its configuration, then `--config`/`--set` on top).
    #[arg(long)]
    pub resume: Option<PathBuf>,
    /// Run name: writes to `<runs>/<method>/<name>/`.
    #[arg(long, default_value = "default")]
    pub name: String,
    #[arg(long, default_value = "runs")]
    pub runs: PathBuf,
    /// Print the effective configuration as TOML and exit.
    #[arg(long)]
    pub print_config: bool,
    /// Stop (with a checkpoint, as Ctrl-C does) after this many steps of this invocation.
    #[arg(long, hide = true)]
    pub stop_after: Option<usize>,
    #[command(flatten)]
    pub method: E,
}

/// Parses the command line for `M`, runs it, and turns an error into a message and exit code 1.
pub fn main<M: Method>() -> ExitCode {
    let matches = Args::<M::Args>::command().about(M::ABOUT).get_matches();
    let args = match Args::<M::Args>::from_arg_matches(&matches) {
        Ok(args) => args,
        Err(e) => e.exit(),
    };
    match run::<M>(&args) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// A command's exit: success, or its error on stderr and exit code 1 (for binaries beside the
/// trainers: `render`, `drive-*`).
pub fn exit<E: std::fmt::Display>(result: Result<(), E>) -> ExitCode {
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// The terminal (above the progress bar while there is one) and `log.txt`.
struct Reporter {
    run: RunDir,
    bar: Option<ProgressBar>,
}

impl Say for Reporter {
    fn say(&mut self, line: &str) {
        self.run.log(line);
        match &self.bar {
            Some(bar) if !bar.is_hidden() => bar.println(line),
            _ => println!("{line}"),
        }
    }
}

impl Reporter {
    fn write_metrics(&self, metrics: &serde_json::Value) -> Result<(), TrainError> {
        Ok(self.run.write_json("metrics.json", metrics)?)
    }
}

/// The `--set` list: the generic shorthands, the method's, then the user's (applied last).
fn overrides<M: Method>(args: &Args<M::Args>) -> Vec<String> {
    let mut sets = Vec::new();
    if let Some(n) = args.iterations {
        sets.push(format!("iterations={n}"));
    }
    if let Some(b) = args.backend {
        sets.push(format!("backend=\"{}\"", b.name()));
    }
    sets.extend(M::overrides(&args.method));
    sets.extend(args.overrides.iter().cloned());
    sets
}

/// Runs `M` as the command line says; `Ok` carries the exit code (130 when interrupted).
pub fn run<M: Method>(args: &Args<M::Args>) -> Result<ExitCode, TrainError> {
    let resumed = args.resume.as_deref().map(Checkpoint::read).transpose()?;
    let base = match &resumed {
        Some(c) => checkpoint_config::<M>(c)?,
        None => M::Config::default(),
    };
    let config: M::Config = config::load(&base, args.config.as_deref(), &overrides::<M>(args))?;
    // Validated before printing too, so a sweep learns of a bad value before it runs anything.
    config.validate()?;
    if args.print_config {
        print!("{}", config::to_toml(&config));
        return Ok(ExitCode::SUCCESS);
    }
    let start = Instant::now();
    let device = config.backend().device();
    let lpips = config
        .lpips_weights()
        .map(|path| Lpips::load(path, &device))
        .transpose()?;
    let lpips = lpips.as_ref();
    let mut method = match &resumed {
        Some(c) => {
            check_format(c, M::FORMAT)?;
            M::resume(config.clone(), c, &device)?
        }
        None => M::new(config.clone(), &device)?,
    };
    let run = RunDir::open(&args.runs, M::NAME, &args.name)?;
    run.write_text("config.toml", &config::to_toml(&config))?;
    let mut out = Reporter { run, bar: None };
    out.say(&format!(
        "{}; backend {}, {} in {:.1} s",
        method.describe(),
        config.backend().name(),
        match &resumed {
            Some(_) => format!("resumed at step {}", method.steps()),
            None => "ready".into(),
        },
        start.elapsed().as_secs_f64()
    ));
    for decision in method.decisions() {
        out.say(&format!("  {decision}"));
    }
    for module in method.modules() {
        out.say(&format!("  {}", module.line()));
    }
    let mut history = match &resumed {
        Some(c) => resumed_history(c, method.steps())?,
        None => {
            let mut history = History {
                method: M::NAME.to_owned(),
                ..Default::default()
            };
            for (name, scores) in method.baselines(lpips)? {
                out.say(&format!("baseline, {name}: {}", scores.line()));
                history.baselines.insert(name, scores);
            }
            history
        }
    };

    let interrupted = Arc::new(AtomicBool::new(false));
    signal_hook::flag::register(signal_hook::consts::SIGINT, interrupted.clone()).map_err(
        |source| TrainError::System {
            what: "cannot install the Ctrl-C handler".into(),
            source,
        },
    )?;
    let iterations = config.iterations();
    let bar = ProgressBar::new(iterations as u64).with_position(method.steps() as u64);
    bar.set_style(
        ProgressStyle::with_template("{bar:30} {pos}/{len} {per_sec} eta {eta} {msg}")
            .expect("valid template"),
    );
    out.bar = Some(bar.clone());
    let checkpoint_path = out.run.file("checkpoint.safetensors");
    let write_checkpoint = |method: &M, history: &History| {
        full_checkpoint(method, &config, history).write(&checkpoint_path)
    };
    let loop_start = Instant::now();
    let mut step_seconds = 0.0;
    let first_step = method.steps();
    let mut last_psnr = history.evaluations.last().map(|e| e.scores.psnr);
    while method.steps() < iterations {
        let step_start = Instant::now();
        let StepReport { loss, note } = method.step()?;
        step_seconds += step_start.elapsed().as_secs_f64();
        if !loss.is_finite() {
            return Err(TrainError::NonFinite {
                step: method.steps(),
                value: loss,
            });
        }
        let step = method.steps();
        bar.set_position(step as u64);
        bar.set_message(format!(
            "loss {loss:.4} psnr {}",
            last_psnr.map_or("-".into(), |p| format!("{p:.2}"))
        ));
        if let Some(note) = note {
            out.run.log(&format!("step {step}: {note}"));
        }
        let log_every = (iterations / 10).clamp(1, 200);
        if step % log_every == 0 || step == 1 {
            let rate = (step - first_step) as f64 / loop_start.elapsed().as_secs_f64();
            out.say(&format!("step {step:>6}: loss {loss:.4}, {rate:.2} it/s"));
        }
        let last = step == iterations;
        let every = config.eval_every();
        if every > 0 && step.is_multiple_of(every) || last {
            let evaluation = method.evaluate(lpips)?;
            last_psnr = Some(evaluation.scores.psnr);
            out.say(&format!(
                "step {step:>6}: {} {}",
                evaluation.kind(),
                evaluation.scores.line()
            ));
            history.evaluations.push(evaluation);
            out.write_metrics(&serde_json::to_value(&history).expect("plain data"))?;
        }
        let stop = interrupted.load(Ordering::SeqCst)
            || args.stop_after.is_some_and(|n| step - first_step >= n);
        if stop && !last {
            write_checkpoint(&method, &history)?;
            bar.abandon();
            out.bar = None;
            out.say(&format!(
                "interrupted at step {step}: wrote {}; continue with --resume {}",
                checkpoint_path.display(),
                checkpoint_path.display()
            ));
            return Ok(ExitCode::from(130));
        }
        let every = config.checkpoint_every();
        if every > 0 && step.is_multiple_of(every) && !last {
            write_checkpoint(&method, &history)?;
        }
    }
    bar.finish_and_clear();
    out.bar = None;
    write_checkpoint(&method, &history)?;
    let steps_run = method.steps() - first_step;
    let rate = steps_run as f64 / loop_start.elapsed().as_secs_f64().max(1e-9);
    let run_path = out.run.path.clone();
    let loop_seconds = loop_start.elapsed().as_secs_f64();
    let extra = method.finish(&run_path, &mut out)?;
    let (frames, render_fps) = render_speed(&method)?;
    if let Some(fps) = render_fps {
        out.say(&format!(
            "rendering: {fps:.2} FPS over {frames} held-out frames (median of timed passes)"
        ));
    }
    let seconds = start.elapsed().as_secs_f64();
    let mut metrics = serde_json::to_value(&history).expect("plain data");
    let summary = metrics.as_object_mut().expect("a JSON object");
    summary.insert(
        "final".into(),
        serde_json::to_value(history.evaluations.last()).expect("plain data"),
    );
    summary.insert("seconds".into(), seconds.into());
    summary.insert("steps_per_second".into(), rate.into());
    summary.insert("loop_seconds".into(), loop_seconds.into());
    summary.insert("step_seconds".into(), step_seconds.into());
    summary.insert("render_fps".into(), render_fps.into());
    summary.insert("render_frames".into(), frames.into());
    summary.insert("gaussians".into(), method.gaussians().into());
    summary.insert("peak_rss_bytes".into(), super::peak_rss_bytes().into());
    summary.insert("backend".into(), config.backend().name().into());
    summary.insert("decisions".into(), method.decisions().into());
    summary.insert(
        "modules".into(),
        serde_json::to_value(method.modules()).expect("plain data"),
    );
    summary.extend(extra);
    out.write_metrics(&metrics)?;
    let headline = history.evaluations.last().map_or(String::new(), |e| {
        format!("{} {}; ", e.kind(), e.scores.line())
    });
    out.say(&format!(
        "{headline}{rate:.2} it/s, {seconds:.0} s in all; wrote {}",
        out.run.path.display()
    ));
    Ok(ExitCode::SUCCESS)
}

/// Frames per pass and render FPS of the held-out frames: a warm-up pass, then timed passes
/// until a second has gone by (at least three, at most twenty); the median pass's FPS. `None`
/// when the method has no held-out frame.
fn render_speed<M: Method>(method: &M) -> Result<(usize, Option<f64>), TrainError> {
    let frames = method.render_held_out()?;
    if frames == 0 {
        return Ok((0, None));
    }
    let start = Instant::now();
    let mut rates = Vec::new();
    while rates.len() < 3 || (rates.len() < 20 && start.elapsed().as_secs_f64() < 1.0) {
        let pass = Instant::now();
        let n = method.render_held_out()?;
        rates.push(n as f64 / pass.elapsed().as_secs_f64().max(1e-9));
    }
    rates.sort_by(f64::total_cmp);
    Ok((frames, Some(rates[rates.len() / 2])))
}

/// The metrics history a checkpoint carries, cut at its step.
fn resumed_history(checkpoint: &Checkpoint, step: usize) -> Result<History, TrainError> {
    let text = checkpoint.meta("metrics")?;
    let mut history: History =
        serde_json::from_str(text).map_err(|e| crate::checkpoint::CheckpointError::Entry {
            file: checkpoint.origin.clone(),
            name: "metrics".into(),
            problem: format!("not a metrics history: {e}"),
        })?;
    history.evaluations.retain(|e| e.step <= step);
    Ok(history)
}
