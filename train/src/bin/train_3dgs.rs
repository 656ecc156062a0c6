//! `train-3dgs`: static-scene 3D Gaussian splatting, on the synthetic static preset (a yard
//! seen by 48 cameras; every 8th held out) or on a nerfstudio `transforms.json` folder. It is the
//! scene-prior stage other methods reuse.
//!
//! ```sh
//! cargo run --release --bin train-3dgs                      # embedded default
//! cargo run --release --bin train-3dgs -- --data path/to/nerfstudio/folder --backend wgpu
//! cargo run --release --bin train-3dgs -- --config my.toml --set densify.strategy=mcmc
//! cargo run --release --bin train-3dgs -- --resume runs/3dgs/default/checkpoint.safetensors
//! ```
//!
//! Every knob is in the TOML configuration ([`StaticConfig`]); `--print-config` shows the
//! defaults. Each run writes `runs/3dgs/<name>/`: `config.toml`, `log.txt`, `metrics.json`
//! (every evaluation), `checkpoint.safetensors`, `point_cloud.ply` (INRIA layout) and
//! `renders/` (held-out render | ground truth). Ctrl-C writes a checkpoint before exiting.

use clap::Parser;
use indicatif::{ProgressBar, ProgressStyle};
use splatzoo_train::backend::Backend;
use splatzoo_train::checkpoint::Checkpoint;
use splatzoo_train::config;
use splatzoo_train::densify::Strategy;
use splatzoo_train::images::{side_by_side, srgb_image, write_png};
use splatzoo_train::lpips::Lpips;
use splatzoo_train::ply::write_ply;
use splatzoo_train::run_dir::RunDir;
use splatzoo_train::static_scene::{Evaluation, StaticConfig, StaticTrainer};
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

#[derive(Parser, Debug)]
#[command(about = "Static-scene 3D Gaussian splatting (synthetic default or a nerfstudio folder)")]
struct Args {
    /// TOML configuration (any subset of the keys `--print-config` shows).
    #[arg(long)]
    config: Option<PathBuf>,
    /// Override one key, e.g. `--set densify.grad_threshold=0.0004` (repeatable; applied last).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    overrides: Vec<String>,
    /// Shorthand for `--set iterations=N`.
    #[arg(long)]
    iterations: Option<usize>,
    /// Shorthand for `--set backend=…`.
    #[arg(long, value_enum)]
    backend: Option<Backend>,
    /// A nerfstudio folder (or its transforms.json) instead of the synthetic scene.
    #[arg(long)]
    data: Option<PathBuf>,
    /// Shorthand for `--set data.size=N` (synthetic image side).
    #[arg(long)]
    size: Option<u32>,
    /// Shorthand for `--set densify.strategy=…`.
    #[arg(long, value_enum)]
    densify: Option<Strategy>,
    /// Continue from a checkpoint (its configuration, then `--config`/`--set` on top).
    #[arg(long)]
    resume: Option<PathBuf>,
    /// Run name: writes to `<runs>/3dgs/<name>/`.
    #[arg(long, default_value = "default")]
    name: String,
    #[arg(long, default_value = "runs")]
    runs: PathBuf,
    /// Print the effective configuration as TOML and exit.
    #[arg(long)]
    print_config: bool,
    /// Stop (with a checkpoint, as Ctrl-C does) after this many steps of this invocation.
    #[arg(long, hide = true)]
    stop_after: Option<usize>,
}

fn main() -> ExitCode {
    match run(Args::parse()) {
        Ok(code) => code,
        Err(message) => {
            eprintln!("error: {message}");
            ExitCode::FAILURE
        }
    }
}

fn overrides(args: &Args) -> Vec<String> {
    let mut sets = Vec::new();
    if let Some(n) = args.iterations {
        sets.push(format!("iterations={n}"));
    }
    if let Some(b) = args.backend {
        sets.push(format!("backend=\"{}\"", b.name()));
    }
    if let Some(path) = &args.data {
        sets.push("data.source=\"nerfstudio\"".into());
        sets.push(format!(
            "data.path={}",
            toml::Value::from(path.display().to_string())
        ));
    }
    if let Some(size) = args.size {
        sets.push(format!("data.size={size}"));
    }
    if let Some(strategy) = args.densify {
        let name = format!("{strategy:?}").to_lowercase();
        sets.push(format!("densify.strategy=\"{name}\""));
    }
    sets.extend(args.overrides.iter().cloned());
    sets
}

fn run(args: Args) -> Result<ExitCode, String> {
    let resumed = match &args.resume {
        Some(path) => Some(Checkpoint::read(path).map_err(|e| e.to_string())?),
        None => None,
    };
    let base = match &resumed {
        Some(c) => StaticTrainer::checkpoint_config(c).map_err(|e| e.to_string())?,
        None => StaticConfig::default(),
    };
    let config: StaticConfig = config::load(&base, args.config.as_deref(), &overrides(&args))
        .map_err(|e| e.to_string())?;
    if args.print_config {
        print!("{}", config::to_toml(&config));
        return Ok(ExitCode::SUCCESS);
    }
    let device = config.backend.device();
    let start = Instant::now();
    let lpips = match &config.lpips_weights {
        Some(path) => Some(Lpips::load(path, &device).map_err(|e| e.to_string())?),
        None => None,
    };
    let mut trainer = match &resumed {
        Some(c) => StaticTrainer::resume(config.clone(), c, &device),
        None => StaticTrainer::new(config.clone(), &device),
    }
    .map_err(|e| e.to_string())?;
    let mut run = RunDir::open(&args.runs, "3dgs", &args.name).map_err(|e| e.to_string())?;
    run.write_text("config.toml", &config::to_toml(&config))
        .map_err(|e| e.to_string())?;
    let mut evaluations: Vec<Evaluation> = std::fs::read_to_string(run.file("metrics.json"))
        .ok()
        .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
        .and_then(|v| serde_json::from_value(v["evaluations"].clone()).ok())
        .unwrap_or_default();
    evaluations.retain(|e| e.step <= trainer.step);
    let views = &trainer.views;
    let say = |run: &mut RunDir, bar: Option<&ProgressBar>, line: String| {
        run.log(&line);
        match bar {
            Some(bar) if !bar.is_hidden() => bar.println(&line),
            _ => println!("{line}"),
        }
    };
    say(
        &mut run,
        None,
        format!(
            "{}: {} train / {} held-out views, {} Gaussians, extent {:.2} m, backend {}, {}; ready in {:.1} s",
            if resumed.is_some() {
                "resumed"
            } else {
                "started"
            },
            views.train.len(),
            views.test.len(),
            trainer.set.len(),
            views.extent,
            config.backend.name(),
            match &resumed {
                Some(_) => format!("from step {}", trainer.step),
                None => "from scratch".into(),
            },
            start.elapsed().as_secs_f64()
        ),
    );
    let interrupted = Arc::new(AtomicBool::new(false));
    signal_hook::flag::register(signal_hook::consts::SIGINT, interrupted.clone())
        .map_err(|e| format!("cannot install the Ctrl-C handler: {e}"))?;
    let bar = ProgressBar::new(config.iterations as u64).with_position(trainer.step as u64);
    bar.set_style(
        ProgressStyle::with_template("{bar:30} {pos}/{len} {per_sec} eta {eta} {msg}")
            .expect("valid template"),
    );
    let checkpoint_path = run.file("checkpoint.safetensors");
    let write_checkpoint = |trainer: &StaticTrainer| {
        trainer
            .checkpoint()
            .write(&checkpoint_path)
            .map_err(|e| e.to_string())
    };
    let loop_start = Instant::now();
    let first_step = trainer.step;
    let mut last_psnr = evaluations.last().map(|e| e.psnr);
    while trainer.step < config.iterations {
        let report = trainer.step().map_err(|e| e.to_string())?;
        let step = trainer.step;
        bar.set_position(step as u64);
        if step % 10 == 0 {
            bar.set_message(format!(
                "loss {:.4} psnr {} n {}",
                report.loss,
                last_psnr.map_or("-".into(), |p| format!("{p:.2}")),
                trainer.set.len()
            ));
        }
        if let Some(d) = report.density {
            run.log(&format!(
                "step {step}: density {d:?} → {} Gaussians",
                trainer.set.len()
            ));
        }
        if step % 200 == 0 {
            let rate = (step - first_step) as f64 / loop_start.elapsed().as_secs_f64();
            let line = format!(
                "step {step:>6}: loss {:.4}, {} Gaussians, {rate:.1} it/s",
                report.loss,
                trainer.set.len()
            );
            say(&mut run, Some(&bar), line);
        }
        let last = step == config.iterations;
        if config.eval_every > 0 && step % config.eval_every == 0 || last {
            let e = trainer
                .evaluate(lpips.as_ref())
                .map_err(|e| e.to_string())?;
            last_psnr = Some(e.psnr);
            let lpips_text = e.lpips.map_or(String::new(), |l| format!(", LPIPS {l:.4}"));
            say(
                &mut run,
                Some(&bar),
                format!(
                    "step {step:>6}: held-out PSNR {:.2} dB, SSIM {:.4}{lpips_text}",
                    e.psnr, e.ssim
                ),
            );
            evaluations.push(e);
            let metrics = serde_json::json!({ "method": "3dgs", "evaluations": evaluations });
            run.write_json("metrics.json", &metrics)
                .map_err(|e| e.to_string())?;
        }
        let stop = interrupted.load(Ordering::SeqCst)
            || args.stop_after.is_some_and(|n| step - first_step >= n);
        if stop && !last {
            write_checkpoint(&trainer)?;
            bar.abandon();
            say(
                &mut run,
                None,
                format!(
                    "interrupted at step {step}: wrote {}; continue with --resume {}",
                    checkpoint_path.display(),
                    checkpoint_path.display()
                ),
            );
            return Ok(ExitCode::from(130));
        }
        if config.checkpoint_every > 0 && step % config.checkpoint_every == 0 && !last {
            write_checkpoint(&trainer)?;
        }
    }
    bar.finish_and_clear();
    write_checkpoint(&trainer)?;
    write_ply(&run.file("point_cloud.ply"), &trainer.set).map_err(|e| e.to_string())?;
    let renders = run.file("renders");
    std::fs::create_dir_all(&renders).map_err(|e| format!("{}: {e}", renders.display()))?;
    for (k, view) in trainer.views.test.iter().enumerate() {
        let render = trainer.render_test(k).map_err(|e| e.to_string())?;
        let pair = side_by_side(&[srgb_image(&render.color), srgb_image(&view.image)]);
        write_png(&renders.join(format!("{}.png", view.name)), &pair).map_err(|e| e.to_string())?;
    }
    let seconds = start.elapsed().as_secs_f64();
    let rate = (trainer.step - first_step) as f64 / loop_start.elapsed().as_secs_f64();
    let last = evaluations.last().cloned();
    let metrics = serde_json::json!({
        "method": "3dgs", "evaluations": evaluations, "final": last,
        "gaussians": trainer.set.len(), "seconds": seconds, "steps_per_second": rate,
        "backend": config.backend.name(),
    });
    run.write_json("metrics.json", &metrics)
        .map_err(|e| e.to_string())?;
    if let Some(e) = last {
        let path = run.path.display().to_string();
        say(
            &mut run,
            None,
            format!(
                "held-out PSNR {:.2} dB, SSIM {:.4}; {} Gaussians; {rate:.1} it/s, {seconds:.0} s in all; wrote {}",
                e.psnr,
                e.ssim,
                trainer.set.len(),
                path
            ),
        );
    }
    Ok(ExitCode::SUCCESS)
}
