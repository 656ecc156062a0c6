//! `train-nlf`: NLF-GS trained across synthetic identities (the multi-view studio preset on a
//! six-camera ring; inputs at 0°, 120°, 240°), evaluated zero-shot on held-out identities at 60°,
//! 180°, 300° against two baselines: the untrained network and each Gaussian taking the mean
//! colour of its projections. Writes `runs/nlf/<name>/` with `config.toml`, `metrics.json`,
//! `log.txt`, held-out renders (render | truth), `checkpoint.safetensors` (the network by
//! parameter path, the Adam moments, the configuration; `drive-nlf` reads it, `--resume`
//! continues from it) and `onnx/`: the encoder and decoder as ONNX graphs with test vectors
//! ([`splatzoo_train::nlf_onnx`]).
//!
//! ```sh
//! cargo run --release --bin train-nlf
//! cargo run --release --bin train-nlf -- --set iterations=50 --set network.depth=\"50\"
//! cargo run --release --bin train-nlf -- --resume runs/nlf/default/checkpoint.safetensors
//! ```

use burn::tensor::Tensor;
use clap::Parser;
use indicatif::{ProgressBar, ProgressStyle};
use splatzoo_models::networks::nlf::{NlfGs, PosedGaussians};
use splatzoo_rasterizer::{ColorMode, RasterSettings, Render, rasterize};
use splatzoo_train::checkpoint::Checkpoint;
use splatzoo_train::config;
use splatzoo_train::images::{side_by_side, srgb_image, write_png};
use splatzoo_train::loss::{psnr, scalar, ssim};
use splatzoo_train::lpips::Lpips;
use splatzoo_train::nlf_baseline::mean_colour_avatar;
use splatzoo_train::nlf_data::{NlfSubject, posed_splats};
use splatzoo_train::nlf_onnx::{self, OnnxSamples};
use splatzoo_train::nlf_trainer::{NlfTrainConfig, NlfTrainer};
use splatzoo_train::run_dir::RunDir;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

#[derive(Parser, Debug)]
#[command(about = "Train NLF-GS on synthetic identities and evaluate zero-shot")]
struct Args {
    #[arg(long)]
    config: Option<PathBuf>,
    #[arg(long = "set", value_name = "KEY=VALUE")]
    overrides: Vec<String>,
    /// Continue from a checkpoint (its configuration, then `--config`/`--set` on top).
    #[arg(long)]
    resume: Option<PathBuf>,
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

struct Scores {
    psnr: f64,
    ssim: f64,
    lpips: Option<f64>,
}

impl Scores {
    fn json(&self) -> serde_json::Value {
        serde_json::json!({"psnr": self.psnr, "ssim": self.ssim, "lpips": self.lpips})
    }

    fn line(&self) -> String {
        let lpips = self
            .lpips
            .map(|l| format!(", LPIPS {l:.4}"))
            .unwrap_or_default();
        format!("PSNR {:.2} dB, SSIM {:.4}{lpips}", self.psnr, self.ssim)
    }
}

/// PSNR/SSIM (and LPIPS) over every target view of `subjects`, the avatar of each from
/// `avatar_of`.
fn evaluate(
    subjects: &[NlfSubject],
    avatar_of: &dyn Fn(&NlfSubject) -> PosedGaussians,
    lpips: Option<&Lpips>,
    mut keep: impl FnMut(usize, usize, &Render),
) -> Result<Scores, String> {
    let (mut p, mut s, mut l, mut n) = (0.0, 0.0, 0.0, 0.0);
    for (i, subject) in subjects.iter().enumerate() {
        let splats = posed_splats(avatar_of(subject));
        let device = subject.vertices.device();
        let background = Tensor::<1>::from_floats(subject.background.as_slice(), &device);
        for (k, view) in subject.targets.iter().enumerate() {
            let settings = RasterSettings::new(view.camera, ColorMode::Sh { degree: 0 });
            let render =
                rasterize(&splats, background.clone(), &settings).map_err(|e| e.to_string())?;
            let image = render.color.clone().clamp(0.0, 1.0);
            p += psnr(image.clone(), view.image.clone());
            if let Some(lpips) = lpips {
                l += scalar(lpips.distance(image.clone(), view.image.clone()));
            }
            s += scalar(ssim(image, view.image.clone()));
            n += 1.0;
            keep(i, k, &render);
        }
    }
    Ok(Scores {
        psnr: p / n,
        ssim: s / n,
        lpips: lpips.map(|_| l / n),
    })
}

fn main() -> ExitCode {
    match run(Args::parse()) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// Writes the checkpoint with the metrics so far (a resumed run continues them).
fn write_checkpoint(
    trainer: &NlfTrainer,
    metrics: &serde_json::Value,
    path: &std::path::Path,
) -> Result<(), String> {
    let mut checkpoint = trainer.checkpoint();
    checkpoint.put_meta("metrics", metrics);
    checkpoint.write(path).map_err(|e| e.to_string())
}

fn run(args: Args) -> Result<ExitCode, String> {
    let resumed = match &args.resume {
        Some(path) => Some(Checkpoint::read(path).map_err(|e| e.to_string())?),
        None => None,
    };
    let base = match &resumed {
        Some(c) => NlfTrainer::checkpoint_config(c)?,
        None => NlfTrainConfig::default(),
    };
    let cfg: NlfTrainConfig =
        config::load(&base, args.config.as_deref(), &args.overrides).map_err(|e| e.to_string())?;
    if args.print_config {
        print!("{}", config::to_toml(&cfg));
        return Ok(ExitCode::SUCCESS);
    }
    let start = Instant::now();
    let device = cfg.backend.device();
    let mut run = RunDir::open(&args.runs, "nlf", &args.name).map_err(|e| e.to_string())?;
    run.write_text("config.toml", &config::to_toml(&cfg))
        .map_err(|e| e.to_string())?;
    let say = |run: &mut RunDir, bar: Option<&ProgressBar>, line: String| {
        match bar {
            Some(bar) if !bar.is_hidden() => bar.println(&line),
            _ => println!("{line}"),
        }
        run.log(&line);
    };
    let lpips = match &cfg.lpips_weights {
        Some(path) => Some(Lpips::load(path, &device).map_err(|e| e.to_string())?),
        None => None,
    };
    let lpips = lpips.as_ref();
    let mut trainer = match &resumed {
        Some(c) => NlfTrainer::resume(cfg.clone(), c, &device)?,
        None => NlfTrainer::new(cfg.clone(), &device)?,
    };
    say(
        &mut run,
        None,
        format!(
            "{} training and {} held-out identities at {}², {} Gaussians each; {} in {:.1} s",
            trainer.train.len(),
            trainer.test.len(),
            cfg.size,
            trainer.anchors.len(),
            match &resumed {
                Some(_) => format!("resumed at step {}", trainer.step),
                None => "ready".into(),
            },
            start.elapsed().as_secs_f64()
        ),
    );
    let mut metrics = match &resumed {
        Some(c) => serde_json::from_str(c.meta("metrics").map_err(|e| e.to_string())?)
            .map_err(|e| format!("{}: metadata `metrics`: {e}", c.origin))?,
        None => {
            let baseline = evaluate(
                &trainer.test,
                &|s| mean_colour_avatar(s, &trainer.faces, &trainer.anchors),
                lpips,
                |_, _, _| {},
            )?;
            say(
                &mut run,
                None,
                format!("baseline, mean colour of projections: {}", baseline.line()),
            );
            let model = trainer.model();
            let untrained = evaluate(
                &trainer.test,
                &|s| trainer.avatar(&model, s),
                lpips,
                |_, _, _| {},
            )?;
            say(
                &mut run,
                None,
                format!("baseline, untrained network: {}", untrained.line()),
            );
            serde_json::json!({
                "method": "nlf-gs",
                "evaluations": [],
                "baselines": {"mean_colour": baseline.json(), "untrained": untrained.json()},
                "gaussians": trainer.anchors.len(),
            })
        }
    };

    let interrupted = Arc::new(AtomicBool::new(false));
    signal_hook::flag::register(signal_hook::consts::SIGINT, interrupted.clone())
        .map_err(|e| format!("cannot install the Ctrl-C handler: {e}"))?;
    let bar = ProgressBar::new(cfg.iterations as u64).with_position(trainer.step as u64);
    bar.set_style(
        ProgressStyle::with_template("{bar:30} {pos}/{len} {per_sec} eta {eta} {msg}")
            .expect("valid template"),
    );
    let checkpoint_path = run.file("checkpoint.safetensors");
    let renders = run.file("renders");
    let loop_start = Instant::now();
    let first_step = trainer.step;
    while trainer.step < cfg.iterations {
        let loss = trainer.step()?;
        let step = trainer.step;
        bar.set_position(step as u64);
        bar.set_message(format!("loss {loss:.4}"));
        if step % 20 == 0 || step == 1 {
            run.log(&format!("step {step:>5}: loss {loss:.4}"));
        }
        let last = step == cfg.iterations;
        if step % cfg.eval_every.max(1) == 0 || last {
            let model = trainer.model();
            std::fs::create_dir_all(&renders).map_err(|e| e.to_string())?;
            let test = &trainer.test;
            let scores = evaluate(
                test,
                &|s| trainer.avatar(&model, s),
                lpips,
                |i, k, render| {
                    if last {
                        let pair = side_by_side(&[
                            srgb_image(&render.color),
                            srgb_image(&test[i].targets[k].image),
                        ]);
                        let _ =
                            write_png(&renders.join(format!("subject_{i}_target_{k}.png")), &pair);
                    }
                },
            )?;
            say(
                &mut run,
                Some(&bar),
                format!("step {step:>5}: held-out {}", scores.line()),
            );
            let mut entry = scores.json();
            entry["step"] = step.into();
            if let Some(list) = metrics["evaluations"].as_array_mut() {
                list.push(entry);
            }
        }
        let stop = interrupted.load(Ordering::SeqCst)
            || args.stop_after.is_some_and(|n| step - first_step >= n);
        if stop && !last {
            write_checkpoint(&trainer, &metrics, &checkpoint_path)?;
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
        if cfg.checkpoint_every > 0 && step % cfg.checkpoint_every == 0 && !last {
            write_checkpoint(&trainer, &metrics, &checkpoint_path)?;
        }
    }
    bar.finish_and_clear();
    let steps_run = trainer.step - first_step;
    metrics["final"] = metrics["evaluations"]
        .as_array()
        .and_then(|list| list.last().cloned())
        .unwrap_or_default();
    metrics["steps_per_second"] =
        (steps_run as f64 / loop_start.elapsed().as_secs_f64().max(1e-9)).into();
    metrics["seconds"] = start.elapsed().as_secs_f64().into();
    run.write_json("metrics.json", &metrics)
        .map_err(|e| e.to_string())?;
    write_checkpoint(&trainer, &metrics, &checkpoint_path)?;
    if cfg.onnx {
        let started = Instant::now();
        let files = export_onnx(&trainer, &run.file("onnx"))?;
        let encoder = nlf_onnx::verify(&files.encoder, &files.encoder_vectors)?;
        let decoder = nlf_onnx::verify(&files.decoder, &files.decoder_vectors)?;
        say(
            &mut run,
            None,
            format!(
                "exported {} and {} with test vectors; tract reproduces Burn to {encoder:.1e} \
                 and {decoder:.1e} (relative) ({:.1} s)",
                files.encoder.display(),
                files.decoder.display(),
                started.elapsed().as_secs_f64()
            ),
        );
        if encoder.max(decoder) > 1e-3 {
            return Err("the exported ONNX graphs disagree with Burn (see above)".into());
        }
    }
    let path = run.path.display().to_string();
    say(
        &mut run,
        None,
        format!(
            "wrote {} ({:.0} s in all)",
            path,
            start.elapsed().as_secs_f64()
        ),
    );
    Ok(ExitCode::SUCCESS)
}

/// The ONNX graphs, with the first held-out identity's views (all three, and two of them) and
/// its fused features as test vectors.
fn export_onnx(trainer: &NlfTrainer, dir: &std::path::Path) -> Result<nlf_onnx::OnnxFiles, String> {
    let model: NlfGs = trainer.model();
    let subject = &trainer.test[0];
    let inputs = subject.nlf_inputs(&trainer.faces, &trainer.anchors);
    let images = inputs.images.clone();
    let [v, _, h, w] = images.dims();
    let network = &trainer.config.network;
    let fused = model.query(
        model.encoder.forward_inference(images.clone()),
        &inputs,
        network.fusion,
        network.occlusion_tolerance,
    );
    let samples = OnnxSamples {
        images: vec![images.clone(), images.slice([0..v - 1, 0..3, 0..h, 0..w])],
        fused: vec![fused],
    };
    nlf_onnx::export(&model, network, &trainer.anchors, &samples, dir)
}
