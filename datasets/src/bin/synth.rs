//! `synth`: generate a synthetic capture from a seed and write it to disk, in the project's own
//! layout (images, masks, depth, normals, cameras, true and perturbed poses) and as a nerfstudio
//! `transforms.json`, so nerfstudio, gsplat and Brush can train on the same scene.
//!
//! ```sh
//! cargo run --release --bin synth -- --preset driving --out runs/synth/driving
//! cargo run --release --bin synth -- --preset multiview --subjects 4 --out runs/synth/nlf
//! ```

use burn::tensor::Device;
use clap::Parser;
use splatzoo_datasets::synth::export::write_scene;
use splatzoo_datasets::synth::prior::PriorNoise;
use splatzoo_datasets::synth::{Preset, SceneConfig};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

#[derive(Parser, Debug)]
#[command(
    about = "Generate a synthetic scene with ground truth; write it in the project's layout and as nerfstudio transforms.json"
)]
struct Args {
    /// Which method's protocol: multiview (NLF-GS), monocular (Prior-4D, Illum), driving
    /// (APF-GS), static (3DGS).
    #[arg(long, value_enum, default_value_t = Preset::Monocular)]
    preset: Preset,
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Output folder.
    #[arg(long, default_value = "runs/synth")]
    out: PathBuf,
    /// Frames (default: the preset's).
    #[arg(long)]
    frames: Option<usize>,
    /// Image width and height (default: the preset's).
    #[arg(long, requires = "height")]
    width: Option<u32>,
    #[arg(long, requires = "width")]
    height: Option<u32>,
    /// Subjects, each its own scene in `subject_NNN/` with seeds seed, seed + 1, ...
    #[arg(long, default_value_t = 1)]
    subjects: usize,
    /// Anti-aliasing samples per pixel along each axis.
    #[arg(long, default_value_t = 2)]
    supersample: usize,
    /// Shadow-map resolution; 0 turns shadows off.
    #[arg(long, default_value_t = 1024)]
    shadow_resolution: usize,
    /// Per-frame noise on the perturbed prior's joint angles (radians).
    #[arg(long)]
    pose_noise: Option<f64>,
    /// Per-sequence bias on the prior's joint angles (radians).
    #[arg(long)]
    pose_bias: Option<f64>,
    /// Per-frame noise on the prior's root translation (metres).
    #[arg(long)]
    translation_noise: Option<f64>,
    /// Per-sequence bias on the prior's root translation (metres).
    #[arg(long)]
    translation_bias: Option<f64>,
    /// Noise on the prior's shape coefficients.
    #[arg(long)]
    shape_noise: Option<f64>,
}

fn config(args: &Args, seed: u64) -> Result<SceneConfig, String> {
    let mut config = SceneConfig::new(args.preset, seed);
    if let (Some(w), Some(h)) = (args.width, args.height) {
        if w == 0 || h == 0 || w > 8192 || h > 8192 {
            return Err(format!("--width/--height: {w}×{h} is outside 1..=8192"));
        }
        (config.width, config.height) = (w, h);
    }
    if args.frames == Some(0) {
        return Err("--frames: at least 1".into());
    }
    config.frames = args.frames;
    if !(1..=8).contains(&args.supersample) {
        return Err(format!(
            "--supersample: {} is outside 1..=8",
            args.supersample
        ));
    }
    config.supersample = args.supersample;
    config.shadow_resolution = (args.shadow_resolution > 0).then_some(args.shadow_resolution);
    let defaults = PriorNoise::default();
    config.noise = PriorNoise {
        pose_noise: args.pose_noise.unwrap_or(defaults.pose_noise),
        pose_bias: args.pose_bias.unwrap_or(defaults.pose_bias),
        translation_noise: args.translation_noise.unwrap_or(defaults.translation_noise),
        translation_bias: args.translation_bias.unwrap_or(defaults.translation_bias),
        shape_noise: args.shape_noise.unwrap_or(defaults.shape_noise),
    };
    for (name, v) in [
        ("--pose-noise", config.noise.pose_noise),
        ("--pose-bias", config.noise.pose_bias),
        ("--translation-noise", config.noise.translation_noise),
        ("--translation-bias", config.noise.translation_bias),
        ("--shape-noise", config.noise.shape_noise),
    ] {
        if !(v.is_finite() && v >= 0.0) {
            return Err(format!("{name}: {v} must be a finite level ≥ 0"));
        }
    }
    Ok(config)
}

fn main() -> ExitCode {
    let args = Args::parse();
    if args.subjects == 0 {
        eprintln!("error: --subjects: at least 1");
        return ExitCode::FAILURE;
    }
    let device = Device::flex();
    for s in 0..args.subjects {
        let seed = args.seed.wrapping_add(s as u64);
        let config = match config(&args, seed) {
            Ok(c) => c,
            Err(e) => {
                eprintln!("error: {e}");
                return ExitCode::FAILURE;
            }
        };
        let dir = if args.subjects > 1 {
            args.out.join(format!("subject_{s:03}"))
        } else {
            args.out.clone()
        };
        let start = Instant::now();
        let scene = config.build(&device);
        let frames: Vec<usize> = (0..scene.frame_count).collect();
        println!(
            "{:?} seed {seed}: {} people, {} cameras × {} frames at {}×{}; built in {:.1} s",
            scene.preset,
            scene.people.len(),
            scene.tracks.len(),
            frames.len(),
            config.width,
            config.height,
            start.elapsed().as_secs_f64()
        );
        let total = frames.len();
        let bar = indicatif::ProgressBar::new(total as u64);
        let result = write_scene(&scene, &dir, &frames, |done| {
            bar.set_position(done as u64);
            if bar.is_hidden() && (done == total || done % 10 == 0) {
                println!("  rendered {done}/{total} frames");
            }
        });
        bar.finish_and_clear();
        if let Err(e) = result {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
        println!(
            "wrote {} ({:.1} s); nerfstudio: {}",
            dir.display(),
            start.elapsed().as_secs_f64(),
            dir.join("transforms.json").display()
        );
    }
    ExitCode::SUCCESS
}
