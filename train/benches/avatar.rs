//! `train-avatar` speed and memory per backend: training steps/s on the default capture size
//! (320×240, 28k Gaussians, no density control so every backend does the same work), and the
//! trained-size avatar's render rate at 512² and 1920×1080 (posing, skinning, rasterizing and
//! reading the image back), with peak resident memory. GauHuman's published figures (1–2 min
//! of training, 189 FPS, on a GPU) are printed beside them for scale.
//!
//! ```sh
//! cargo bench --workspace --bench avatar                 # flex, ndarray, wgpu
//! cargo bench --workspace --bench avatar -- flex 100     # one backend, 100 steps
//! ```
//!
//! Each backend runs in its own child process so that its peak memory (`VmHWM`) is its own.

use splatzoo_rasterizer::{Camera, ColorMode, RasterSettings, rasterize};
use splatzoo_train::avatar::{AvatarConfig, AvatarTrainer};
use splatzoo_train::backend::Backend;
use splatzoo_train::densify::Strategy;
use splatzoo_train::harness::Method;
use splatzoo_train::host_f32;
use splatzoo_train::scene::SceneNode;
use std::process::Command;
use std::time::Instant;

const WARM_UP: usize = 5;
const FRAMES: usize = 10;

fn peak_rss_mib() -> f64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<f64>().ok())
        .map_or(f64::NAN, |kb| kb / 1024.0)
}

/// Frames per second of the avatar at `width`×`height`, posed anew every frame.
fn render_rate(trainer: &AvatarTrainer, width: u32, height: u32) -> f64 {
    let canonical = trainer.node.canonical_set().splats();
    let background = burn::tensor::Tensor::<1>::zeros([3], &canonical.means.device());
    let frames = trainer.capture.train.len();
    let start = Instant::now();
    for k in 0..FRAMES {
        let frame = trainer.capture.train[k % frames].frame;
        let posed = trainer.node.posed(canonical.clone(), frame).splats;
        let centre = host_f32(&trainer.node.joint_positions(frame))[..3].to_vec();
        let camera = Camera::look_at(
            [centre[0], centre[1], centre[2] + 2.5],
            [centre[0], centre[1], centre[2]],
            [0.0, 1.0, 0.0],
            50.0,
            width,
            height,
        );
        let settings = RasterSettings::new(camera, ColorMode::Sh { degree: 0 });
        let render = rasterize(&posed, background.clone(), &settings).expect("render");
        let _ = host_f32(&render.color);
    }
    FRAMES as f64 / start.elapsed().as_secs_f64()
}

/// In the child: trains, renders and prints `steps/s fps512 fps1080 peak_MiB gaussians`.
fn child(backend: Backend, steps: usize) {
    let mut config = AvatarConfig {
        backend,
        iterations: WARM_UP + steps,
        ..Default::default()
    };
    config.data.frames = 15;
    config.densify.strategy = Strategy::None;
    let device = backend.device();
    let mut trainer = AvatarTrainer::new(config, &device).expect("default capture");
    for _ in 0..WARM_UP {
        trainer.step().expect("step");
    }
    let start = Instant::now();
    for _ in 0..steps {
        trainer.step().expect("step");
    }
    let rate = steps as f64 / start.elapsed().as_secs_f64();
    let small = render_rate(&trainer, 512, 512);
    let large = render_rate(&trainer, 1920, 1080);
    println!(
        "{rate} {small} {large} {} {}",
        peak_rss_mib(),
        trainer.node.gaussians()
    );
}

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .collect();
    if args.first().map(String::as_str) == Some("--child") {
        let backend = Backend::ALL
            .into_iter()
            .find(|b| b.name() == args[1])
            .expect("known backend");
        child(backend, args[2].parse().expect("steps"));
        return;
    }
    let steps: usize = args.iter().find_map(|a| a.parse().ok()).unwrap_or(40);
    let chosen: Vec<Backend> = Backend::ALL
        .into_iter()
        .filter(|b| {
            args.iter().all(|a| a.parse::<usize>().is_ok()) || args.iter().any(|a| a == b.name())
        })
        .collect();
    println!("train-avatar default capture size, {steps} timed steps after {WARM_UP} warm-up");
    println!("| backend | steps/s | FPS 512² | FPS 1080p | peak memory (RSS) | Gaussians |");
    println!("|---|---|---|---|---|---|");
    let exe = std::env::current_exe().expect("own path");
    for backend in chosen {
        let out = Command::new(&exe)
            .args(["--child", backend.name(), &steps.to_string()])
            .output()
            .expect("child runs");
        let text = String::from_utf8_lossy(&out.stdout);
        let fields: Vec<f64> = text
            .split_whitespace()
            .filter_map(|f| f.parse().ok())
            .collect();
        if !out.status.success() || fields.len() != 5 {
            let stderr = String::from_utf8_lossy(&out.stderr);
            println!(
                "| {} | failed: {} | | | | |",
                backend.name(),
                stderr.lines().last().unwrap_or("")
            );
            continue;
        }
        println!(
            "| {} | {:.1} | {:.1} | {:.1} | {:.0} MiB | {} |",
            backend.name(),
            fields[0],
            fields[1],
            fields[2],
            fields[3],
            fields[4]
        );
    }
    println!("| GauHuman (paper, one GPU) | 1–2 min to train | 189 | | | |");
}
