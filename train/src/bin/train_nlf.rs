//! `train-nlf`: NLF-GS trained across synthetic identities (the multi-view studio preset on a
//! six-camera ring; inputs at 0°, 120°, 240°), evaluated zero-shot on held-out identities at 60°,
//! 180°, 300° against two baselines: the untrained network and each Gaussian taking the mean
//! colour of its projections. Writes `runs/nlf/<name>/` with `config.toml`, `metrics.json`,
//! `log.txt`, held-out renders (render | truth) and `checkpoint.safetensors` (the network by
//! parameter path, its configuration as metadata; `drive-nlf` reads it).
//!
//! ```sh
//! cargo run --release --bin train-nlf
//! cargo run --release --bin train-nlf -- --set iterations=50 --set network.depth=\"50\"
//! ```
//!
//! Not yet: LPIPS in the metrics, resuming, ONNX export.

use burn::module::Module;
use burn::optim::{AdamConfig, GradientsParams};
use burn::tensor::Tensor;
use clap::Parser;
use serde::{Deserialize, Serialize};
use splatzoo_models::anchor::MeshAnchors;
use splatzoo_models::body::builtin_body;
use splatzoo_models::networks::nlf::{NlfConfig, NlfGs, NlfInputs, PosedGaussians};
use splatzoo_rasterizer::{ColorMode, RasterSettings, Render, rasterize};
use splatzoo_train::backend::Backend;
use splatzoo_train::config;
use splatzoo_train::images::{side_by_side, srgb_image, write_png};
use splatzoo_train::loss::{psnr, scalar, ssim};
use splatzoo_train::nlf_baseline::mean_colour_avatar;
use splatzoo_train::nlf_data::{NlfSubject, posed_splats};
use splatzoo_train::nlf_loss::{NlfLossInputs, NlfLossWeights, nlf_loss};
use splatzoo_train::run_dir::RunDir;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
struct TrainNlfConfig {
    backend: Backend,
    /// Image side in pixels.
    size: u32,
    /// Training identities are seeds `0..train_subjects`; held-out ones start at `test_seed`.
    train_subjects: usize,
    test_subjects: usize,
    test_seed: u64,
    iterations: usize,
    learning_rate: f64,
    eval_every: usize,
    network: NlfConfig,
    loss: NlfLossWeights,
}

impl Default for TrainNlfConfig {
    fn default() -> Self {
        Self {
            backend: Backend::Flex,
            size: 96,
            train_subjects: 12,
            test_subjects: 3,
            test_seed: 10_000,
            iterations: 100,
            learning_rate: 5e-4,
            eval_every: 50,
            network: NlfConfig::default(),
            loss: NlfLossWeights::default(),
        }
    }
}

#[derive(Parser, Debug)]
#[command(about = "Train NLF-GS on synthetic identities and evaluate zero-shot")]
struct Args {
    #[arg(long)]
    config: Option<PathBuf>,
    #[arg(long = "set", value_name = "KEY=VALUE")]
    overrides: Vec<String>,
    #[arg(long, default_value = "default")]
    name: String,
    #[arg(long, default_value = "runs")]
    runs: PathBuf,
}

struct Scores {
    psnr: f64,
    ssim: f64,
}

/// PSNR/SSIM over every target view of `subjects`, the avatar of each from `avatar_of`.
fn evaluate(
    subjects: &[NlfSubject],
    avatar_of: &dyn Fn(&NlfSubject) -> PosedGaussians,
    mut keep: impl FnMut(usize, usize, &Render),
) -> Result<Scores, String> {
    let (mut p, mut s, mut n) = (0.0, 0.0, 0.0);
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
            s += scalar(ssim(image, view.image.clone()));
            n += 1.0;
            keep(i, k, &render);
        }
    }
    Ok(Scores {
        psnr: p / n,
        ssim: s / n,
    })
}

fn main() -> ExitCode {
    match run(Args::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(args: Args) -> Result<(), String> {
    let cfg: TrainNlfConfig = config::load(
        &TrainNlfConfig::default(),
        args.config.as_deref(),
        &args.overrides,
    )
    .map_err(|e| e.to_string())?;
    if cfg.iterations == 0 || cfg.train_subjects == 0 || cfg.test_subjects == 0 || cfg.size < 32 {
        return Err("iterations, train_subjects, test_subjects ≥ 1 and size ≥ 32".into());
    }
    let start = Instant::now();
    let device = cfg.backend.device();
    let mut run = RunDir::open(&args.runs, "nlf", &args.name).map_err(|e| e.to_string())?;
    run.write_text("config.toml", &config::to_toml(&cfg))
        .map_err(|e| e.to_string())?;
    let say = |run: &mut RunDir, line: String| {
        println!("{line}");
        run.log(&line);
    };
    let train: Vec<NlfSubject> = (0..cfg.train_subjects as u64)
        .map(|s| NlfSubject::synthetic(s, cfg.size, &device))
        .collect();
    let test: Vec<NlfSubject> = (0..cfg.test_subjects as u64)
        .map(|s| NlfSubject::synthetic(cfg.test_seed + s, cfg.size, &device))
        .collect();
    let faces = builtin_body().model.faces.clone();
    let anchors = MeshAnchors::per_face(faces.len() / 3, cfg.network.gaussians_per_face);
    say(
        &mut run,
        format!(
            "{} training and {} held-out identities at {}², {} Gaussians each; ready in {:.1} s",
            train.len(),
            test.len(),
            cfg.size,
            anchors.len(),
            start.elapsed().as_secs_f64()
        ),
    );
    let generate = |model: &NlfGs, subject: &NlfSubject| {
        let (images, views, centres) = subject.input_tensors();
        let inputs = NlfInputs {
            images,
            views,
            camera_centres: centres,
            vertices: subject.vertices.clone(),
            faces: &faces,
            anchors: &anchors,
            depth: Some(subject.input_depth.clone()),
        };
        model
            .generate(&inputs, cfg.network.fusion, cfg.network.occlusion_tolerance)
            .drive(subject.vertices.clone(), &faces, &anchors)
    };
    let baseline = evaluate(
        &test,
        &|s| mean_colour_avatar(s, &faces, &anchors),
        |_, _, _| {},
    )?;
    say(
        &mut run,
        format!(
            "baseline, mean colour of projections: PSNR {:.2} dB, SSIM {:.4}",
            baseline.psnr, baseline.ssim
        ),
    );
    let mut model = NlfGs::new(&cfg.network, &device);
    let untrained = evaluate(&test, &|s| generate(&model, s), |_, _, _| {})?;
    say(
        &mut run,
        format!(
            "baseline, untrained network: PSNR {:.2} dB, SSIM {:.4}",
            untrained.psnr, untrained.ssim
        ),
    );
    let mut optimizer = AdamConfig::new().init();
    let mut evaluations = Vec::new();
    let loop_start = Instant::now();
    let mut trainable = model.train();
    for step in 1..=cfg.iterations {
        let subject = &train[(step * 7) % train.len()];
        let (images, views, centres) = subject.input_tensors();
        let inputs = NlfInputs {
            images: images.autodiff(),
            views: splatzoo_models::networks::query::Views {
                intrinsics: views.intrinsics.autodiff(),
                world_to_camera: views.world_to_camera.autodiff(),
                size: views.size,
            },
            camera_centres: centres.autodiff(),
            vertices: subject.vertices.clone().autodiff(),
            faces: &faces,
            anchors: &anchors,
            depth: Some(subject.input_depth.clone().autodiff()),
        };
        let avatar =
            trainable.generate(&inputs, cfg.network.fusion, cfg.network.occlusion_tolerance);
        let posed = avatar.drive(subject.vertices.clone().autodiff(), &faces, &anchors);
        let splat_set = posed_splats(posed);
        let background =
            Tensor::<1>::from_floats(subject.background.as_slice(), &device).autodiff();
        let mut total: Option<Tensor<1>> = None;
        for view in &subject.targets {
            let settings = RasterSettings::new(view.camera, ColorMode::Sh { degree: 0 });
            let render =
                rasterize(&splat_set, background.clone(), &settings).map_err(|e| e.to_string())?;
            let loss = nlf_loss(
                NlfLossInputs {
                    image: render.color,
                    target: view.image.clone().autodiff(),
                    alpha: render.alpha,
                    mask: view.mask.clone().autodiff(),
                    log_scales: avatar.attributes.log_scales.clone(),
                    offsets: avatar.attributes.offset.clone(),
                    opacity_logits: avatar.attributes.opacity_logits.clone(),
                },
                &cfg.loss,
            )
            .total;
            total = Some(match total {
                Some(t) => t + loss,
                None => loss,
            });
        }
        let loss = total.expect("three targets") / subject.targets.len() as f64;
        let value = scalar(loss.clone().inner());
        let grads = GradientsParams::from_grads(loss.backward(), &trainable);
        trainable = optimizer.step(cfg.learning_rate, trainable, grads);
        if step % 20 == 0 || step == 1 {
            let rate = step as f64 / loop_start.elapsed().as_secs_f64();
            say(
                &mut run,
                format!("step {step:>5}: loss {value:.4}, {rate:.2} it/s"),
            );
        }
        if step % cfg.eval_every.max(1) == 0 || step == cfg.iterations {
            model = trainable.valid();
            let last = step == cfg.iterations;
            let renders = run.file("renders");
            std::fs::create_dir_all(&renders).map_err(|e| e.to_string())?;
            let scores = evaluate(&test, &|s| generate(&model, s), |i, k, render| {
                if last {
                    let pair = side_by_side(&[
                        srgb_image(&render.color),
                        srgb_image(&test[i].targets[k].image),
                    ]);
                    let _ = write_png(&renders.join(format!("subject_{i}_target_{k}.png")), &pair);
                }
            })?;
            say(
                &mut run,
                format!(
                    "step {step:>5}: held-out PSNR {:.2} dB, SSIM {:.4}",
                    scores.psnr, scores.ssim
                ),
            );
            evaluations
                .push(serde_json::json!({"step": step, "psnr": scores.psnr, "ssim": scores.ssim}));
        }
    }
    let last = evaluations.last().cloned().unwrap_or_default();
    let metrics = serde_json::json!({
        "method": "nlf-gs",
        "evaluations": evaluations,
        "final": last,
        "baselines": {
            "mean_colour": {"psnr": baseline.psnr, "ssim": baseline.ssim},
            "untrained": {"psnr": untrained.psnr, "ssim": untrained.ssim},
        },
        "gaussians": anchors.len(),
        "seconds": start.elapsed().as_secs_f64(),
    });
    run.write_json("metrics.json", &metrics)
        .map_err(|e| e.to_string())?;
    let mut checkpoint = splatzoo_train::checkpoint::Checkpoint {
        tensors: splatzoo_models::networks::weights::module_tensors(&trainable.valid()),
        ..Default::default()
    };
    checkpoint.put_meta("format", "splatzoo-nlf-1");
    checkpoint.put_meta("network", config::to_toml(&cfg.network));
    checkpoint.put_meta("step", cfg.iterations);
    checkpoint
        .write(&run.file("checkpoint.safetensors"))
        .map_err(|e| e.to_string())?;
    let path = run.path.display().to_string();
    say(
        &mut run,
        format!(
            "wrote {} ({:.0} s in all)",
            path,
            start.elapsed().as_secs_f64()
        ),
    );
    Ok(())
}
