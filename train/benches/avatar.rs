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
//! Each backend runs in its own child process ([`common::run`]).

mod common;

use common::peak_rss_mib;
use splatzoo_rasterizer::{Camera, ColorMode, RasterSettings, rasterize};
use splatzoo_train::avatar::{AvatarConfig, AvatarTrainer};
use splatzoo_train::backend::Backend;
use splatzoo_train::densify::Strategy;
use splatzoo_train::harness::Method;
use splatzoo_train::host_f32;
use splatzoo_train::scene::SceneNode;
use std::time::Instant;

const WARM_UP: usize = 5;
const FRAMES: usize = 10;

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

/// In the child: trains and renders; returns steps/s, FPS at 512² and 1080p, peak MiB and
/// the Gaussian count.
fn child(backend: Backend, steps: usize) -> Vec<f64> {
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
    vec![
        rate,
        small,
        large,
        peak_rss_mib(),
        trainer.node.gaussians() as f64,
    ]
}

fn main() {
    common::run(
        40,
        child,
        |steps| {
            println!(
                "train-avatar default capture size, {steps} timed steps after {WARM_UP} warm-up"
            );
            println!("(GauHuman, on one GPU: 1–2 min of training, 189 FPS)");
            println!(
                "| backend | steps/s | FPS 512² | FPS 1080p | peak memory (RSS) | Gaussians |"
            );
            println!("|---|---|---|---|---|---|");
        },
        |backend, figures| match figures {
            Ok(f) if f.len() == 5 => println!(
                "| {} | {:.1} | {:.1} | {:.1} | {:.0} MiB | {} |",
                backend.name(),
                f[0],
                f[1],
                f[2],
                f[3],
                f[4]
            ),
            Ok(f) => println!("| {} | unexpected output {f:?} | | | | |", backend.name()),
            Err(e) => println!("| {} | failed: {e} | | | | |", backend.name()),
        },
    );
}
