//! `train-apf` speed and memory per backend: training steps/s at the preset size (384×216, all
//! networks on: S2 from the first timed step), and the whole scene's render rate (every node
//! composed, residuals and accessories included, rasterized and read back) at the preset size
//! and at 1920×1080 from the front camera, with peak resident memory. The paper's figures
//! (60 FPS, ≈ 1.2 h of training on an RTX 4090) are printed beside them for scale.
//!
//! ```sh
//! cargo bench --workspace --bench apf                 # flex, ndarray, wgpu
//! cargo bench --workspace --bench apf -- flex 20      # one backend, 20 steps
//! ```
//!
//! Each backend runs in its own child process (the engine's bench harness).

#[path = "../../../train/benches/common/mod.rs"]
mod common;

use common::peak_rss_mib;
use splatzoo_apf_gs::config::ApfConfig;
use splatzoo_apf_gs::trainer::ApfTrainer;
use splatzoo_train::backend::Backend;
use splatzoo_train::harness::Method;
use splatzoo_train::host_f32;
use std::time::Instant;

const WARM_UP: usize = 3;
const FRAMES: usize = 5;

/// Frames per second of the whole scene at the first held-out view, at the preset size
/// (`None`) or at `size` with the same horizontal field of view.
fn render_rate(trainer: &ApfTrainer, size: Option<[u32; 2]>) -> f64 {
    let view = &trainer.capture.views[trainer.capture.test[0]];
    let mut camera = view.camera;
    if let Some([w, h]) = size {
        let s = w as f32 / camera.width as f32;
        camera.fx *= s;
        camera.fy *= s;
        camera.cx = w as f32 / 2.0;
        camera.cy = h as f32 / 2.0;
        camera.width = w;
        camera.height = h;
    }
    let nets = burn::module::Module::valid(&trainer.nets);
    let start = Instant::now();
    for _ in 0..FRAMES {
        let composed = trainer.compose_at(&nets, view.frame, &camera);
        let render = trainer
            .render_splats(&composed.splats, camera)
            .expect("render");
        let _ = host_f32(&render.color);
    }
    FRAMES as f64 / start.elapsed().as_secs_f64()
}

/// In the child: trains and renders; returns steps/s, FPS at the preset size and 1080p, peak
/// MiB and the Gaussian count.
fn child(backend: Backend, steps: usize) -> Vec<f64> {
    let mut config = ApfConfig {
        backend,
        iterations: WARM_UP + steps,
        warmup: 0,
        onnx: false,
        repose_frames: 0,
        ..ApfConfig::default()
    };
    config.data.frames = 15;
    let device = backend.device();
    let mut trainer = ApfTrainer::new(config, &device).expect("the driving scene");
    for _ in 0..WARM_UP {
        trainer.step().expect("step");
    }
    let start = Instant::now();
    for _ in 0..steps {
        trainer.step().expect("step");
    }
    let rate = steps as f64 / start.elapsed().as_secs_f64();
    let preset = render_rate(&trainer, None);
    let large = render_rate(&trainer, Some([1920, 1080]));
    vec![
        rate,
        preset,
        large,
        peak_rss_mib(),
        trainer.scene.gaussians() as f64,
    ]
}

fn main() {
    common::run(
        20,
        child,
        |steps| {
            println!(
                "train-apf at the preset size (384×216, 15 frames), {steps} timed S2 steps after \
                 {WARM_UP} warm-up"
            );
            println!("(APF-GS on an RTX 4090: 60 FPS inference, ≈ 1.2 h of training)");
            println!(
                "| backend | steps/s | FPS 384×216 | FPS 1080p | peak memory (RSS) | Gaussians |"
            );
            println!("|---|---|---|---|---|---|");
        },
        |backend, figures| match figures {
            Ok(f) if f.len() == 5 => println!(
                "| {} | {:.2} | {:.1} | {:.1} | {:.0} MiB | {} |",
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
