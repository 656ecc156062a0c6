//! `bench-illum`: what Illum's speed knobs cost, as a table. One capture is built; for each
//! variant (one `--set` line from the default) a fresh run takes a few stage-1 steps, hands
//! over, takes a few stage-2 steps, and renders a held-out frame (scene + human, the
//! evaluation's N_l), each timed after a warm-up step. The `shading error` column is the
//! Monte-Carlo estimate's RMS sRGB difference per human Gaussian against N_l = 256 on the
//! same state (the accuracy the sample count buys).
//!
//! ```sh
//! cargo run --release --bin bench-illum
//! cargo run --release --bin bench-illum -- --steps 5 --set data.width=320 --set data.height=240
//! ```

use burn::tensor::Tensor;
use clap::Parser;
use splatzoo_illum::config::IllumConfig;
use splatzoo_illum::method::Illum;
use splatzoo_illum::steps::Nets;
use splatzoo_train::TrainError;
use splatzoo_train::harness::{Method, MethodConfig};
use splatzoo_train::host_f32;
use splatzoo_train::scene::{FrameContext, FrameQuery, SceneNode};
use std::process::ExitCode;
use std::time::Instant;

/// Each variant: its name and its overrides.
const VARIANTS: [(&str, &[&str]); 11] = [
    ("default", &[]),
    ("N_l = 8", &["stage2.samples=8", "stage2.eval_samples=8"]),
    ("N_l = 32", &["stage2.samples=32", "stage2.eval_samples=32"]),
    ("visibility open", &["visibility.source=\"open\""]),
    ("visibility ray cast", &["visibility.source=\"raycast\""]),
    ("probes 0.3 H apart", &["light.spacing=0.3"]),
    (
        "probes 0.08 H apart",
        &["light.spacing=0.08", "light.max_per_axis=40"],
    ),
    ("probe SH degree 1", &["light.degree=1"]),
    ("probe SH degree 3", &["light.degree=3"]),
    ("no light volume", &["ablation.light_volume=false"]),
    ("no shadow decoder", &["ablation.shadow=false"]),
];

#[derive(Debug, Parser)]
#[command(about = "Illum's speed knobs: ms per step of each stage and render FPS")]
struct Args {
    /// Timed steps per stage (after one warm-up step).
    #[arg(long, default_value_t = 3)]
    steps: usize,
    /// `key=value` overrides of the base configuration (as `train-illum --set`).
    #[arg(long = "set")]
    overrides: Vec<String>,
}

fn milliseconds(start: Instant, count: usize) -> f64 {
    1e3 * start.elapsed().as_secs_f64() / count.max(1) as f64
}

/// RMS sRGB difference of the human's shaded colours at `count` samples against 256.
fn shading_error(method: &Illum, count: usize) -> Option<f64> {
    let t = &method.trainer;
    let stage2 = t.stage2.as_ref()?;
    if !t.config.ablation.light_volume {
        return None;
    }
    let frame = t.capture.test_frames().next()?;
    let pose = t.frame_pose(frame.frame, true);
    let query = FrameQuery {
        camera: &frame.camera,
        frame: frame.frame,
        time: 0.0,
    };
    let canonical = stage2
        .human
        .render(&query, &FrameContext { outputs: &[] })
        .splats;
    let canonical = splatzoo_illum::eval::untracked(canonical);
    let (volume, decoder, materials) = t.frozen();
    let nets = Nets {
        volume: &volume,
        decoder: &decoder,
        materials: &materials,
    };
    let colours = |samples: usize| -> Tensor<2> {
        let sampling = splatzoo_illum::lighting::SamplingConfig {
            count: samples,
            rule: t.config.stage2.rule,
        };
        let (_, [colour, ..]) =
            t.stage2_human(nets, &canonical, &pose, &frame.camera, sampling, None);
        colour
    };
    let (estimate, reference) = (host_f32(&colours(count)), host_f32(&colours(256)));
    let mse = estimate
        .iter()
        .zip(&reference)
        .map(|(a, b)| f64::from(a - b).powi(2))
        .sum::<f64>()
        / estimate.len().max(1) as f64;
    Some(mse.sqrt())
}

fn run(args: &Args) -> Result<(), TrainError> {
    let base: IllumConfig =
        splatzoo_train::config::load(&IllumConfig::default(), None, &args.overrides)?;
    let device = base.backend.device();
    device.seed(base.seed);
    let build = Instant::now();
    let capture = base.data.build(&device).map_err(TrainError::from)?;
    println!(
        "capture {}×{}, {} frames, built in {:.1} s; {} timed steps per stage\n",
        base.data.width,
        base.data.height,
        capture.frames.len(),
        build.elapsed().as_secs_f64(),
        args.steps
    );
    println!(
        "| variant | probes | human Gaussians | stage 1 ms/step | stage 2 ms/step | render ms (FPS) | shading error (sRGB RMS) |"
    );
    println!("|---|---|---|---|---|---|---|");
    for (name, sets) in VARIANTS {
        let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
        let mut config: IllumConfig = splatzoo_train::config::load(&base, None, &sets)?;
        config.stage1.steps = 1 + args.steps;
        config.iterations = config.stage1.steps + 1 + args.steps;
        // F_vis's warm-up runs once at the hand-over, outside the timed steps; its cost is
        // measured by the sweep (`configs/sweep-visibility-warmup.toml`), not here.
        config.visibility.warmup = 0;
        config.validate()?;
        let mut method = Illum::from_capture(config.clone(), capture.clone(), &device)?;
        method.step()?;
        let start = Instant::now();
        for _ in 0..args.steps {
            method.step()?;
        }
        let stage1 = milliseconds(start, args.steps);
        method.step()?; // the hand-over and stage 2's warm-up
        let start = Instant::now();
        for _ in 0..args.steps {
            method.step()?;
        }
        let stage2 = milliseconds(start, args.steps);
        let t = &method.trainer;
        let frame = t.capture.test_frames().next().expect("a held-out frame");
        let pose = t.frame_pose(frame.frame, true);
        let (volume, decoder, materials) = t.frozen();
        let nets = Nets {
            volume: &volume,
            decoder: &decoder,
            materials: &materials,
        };
        t.render_view(nets, &frame.camera, &pose, true)?;
        let start = Instant::now();
        t.render_view(nets, &frame.camera, &pose, true)?;
        let render = milliseconds(start, 1);
        let error = shading_error(&method, config.stage2.eval_samples)
            .map_or_else(|| "—".to_owned(), |e| format!("{e:.4}"));
        println!(
            "| {name} | {} | {} | {stage1:.0} | {stage2:.0} | {render:.0} ({:.1}) | {error} |",
            t.volume.grid().count(),
            t.stage2.as_ref().map_or(0, |s| s.human.gaussians()),
            1e3 / render
        );
    }
    Ok(())
}

fn main() -> ExitCode {
    splatzoo_train::harness::cli::exit(run(&Args::parse()))
}
