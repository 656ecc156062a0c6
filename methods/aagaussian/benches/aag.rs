//! `train-aag` speed per backend: SDS steps/s of the default configuration (64², B = 4, 20k
//! Gaussians) guided by the mixture oracle and by a small ONNX denoiser run in tract (the
//! random-weight `TinyDenoiser`, 16 hidden channels), the minutes the 1200-step default would
//! take at that rate, the animation's frames/s (posing + rasterizing at 128²), and peak resident
//! memory. The paper's figures (≈ 2 h per avatar on a V100, ≈ 3 h per 8 s clip on a GTX 1070)
//! are printed beside them for scale.
//!
//! ```sh
//! cargo bench --workspace --bench aag                 # flex, ndarray, wgpu
//! cargo bench --workspace --bench aag -- flex 20      # one backend, 20 steps
//! ```

#[path = "../../../train/benches/common/mod.rs"]
mod common;

use common::peak_rss_mib;
use splatzoo_aagaussian::Aag;
use splatzoo_aagaussian::animate::{animate, builtin_motion};
use splatzoo_aagaussian::config::AagConfig;
use splatzoo_aagaussian::prompts::PromptEmbeddings;
use splatzoo_aagaussian::tiny_unet::{TinyDenoiser, write_guidance};
use splatzoo_datasets::synth::rng::Rng;
use splatzoo_train::backend::Backend;
use splatzoo_train::harness::Method;
use std::time::Instant;

const WARM_UP: usize = 3;

fn config(backend: Backend) -> AagConfig {
    let mut config = AagConfig {
        backend,
        ..AagConfig::default()
    };
    config.data.body_fit = false;
    config
}

fn steps_per_second(config: AagConfig, steps: usize) -> (f64, Aag) {
    let device = config.backend.device();
    let mut method = Aag::new(config, &device).expect("the portrait");
    for _ in 0..WARM_UP {
        method.step().expect("step");
    }
    let start = Instant::now();
    for _ in 0..steps {
        method.step().expect("step");
    }
    (steps as f64 / start.elapsed().as_secs_f64(), method)
}

/// In the child: oracle steps/s, ONNX steps/s, animation FPS, peak MiB, Gaussians.
fn child(backend: Backend, steps: usize) -> Vec<f64> {
    let (oracle, method) = steps_per_second(config(backend), steps);
    let trainer = &method.trainer;
    let animation = trainer.config.animation.clone();
    let scores = animate(
        &trainer.node.set,
        &trainer.capture,
        &builtin_motion(12, animation.fps),
        &animation,
        None,
    )
    .expect("animates");

    let dir = tempfile::tempdir().expect("temp dir");
    let mut rng = Rng(7);
    let mut rows = |n: usize| -> Vec<Vec<f32>> {
        (0..n)
            .map(|_| (0..77 * 64).map(|_| rng.normal() as f32).collect())
            .collect()
    };
    let (cond, negative, null) = (rows(4), rows(4), rows(1).remove(0));
    let prompts = PromptEmbeddings::from_rows(77, 64, cond, negative, null);
    let device = Backend::Flex.device();
    let net = TinyDenoiser::new(16, 64, &device);
    let toml = write_guidance(
        &net,
        &prompts,
        trainer.config.render_size as usize,
        1.0,
        dir.path(),
    )
    .expect("exported");
    let onnx_config = AagConfig {
        guidance_model: Some(toml),
        ..config(backend)
    };
    let (onnx, _) = steps_per_second(onnx_config, steps.div_ceil(4).max(2));
    vec![
        oracle,
        onnx,
        scores.fps,
        peak_rss_mib(),
        trainer.node.set.len() as f64,
    ]
}

fn main() {
    common::run(
        10,
        child,
        |steps| {
            println!(
                "train-aag at the default size (64², B = 4, 20k Gaussians), {steps} timed steps \
                 after {WARM_UP} warm-up (a quarter as many with the ONNX model)"
            );
            println!(
                "(AAGaussian: ≈ 2 h per avatar on a V100, 3600 steps at 1024² with the UNet; \
                 ≈ 3 h to animate an 8 s clip on a GTX 1070)"
            );
            println!(
                "| backend | steps/s (oracle) | min per 1200 steps | steps/s (ONNX, tract) | \
                 animation FPS 128² | peak memory (RSS) | Gaussians |"
            );
            println!("|---|---|---|---|---|---|---|");
        },
        |backend, figures| match figures {
            Ok(f) if f.len() == 5 => println!(
                "| {} | {:.2} | {:.1} | {:.2} | {:.1} | {:.0} MiB | {} |",
                backend.name(),
                f[0],
                1200.0 / f[0] / 60.0,
                f[1],
                f[2],
                f[3],
                f[4]
            ),
            Ok(f) => println!("| {} | unexpected output {f:?} | | | | | |", backend.name()),
            Err(e) => println!("| {} | failed: {e} | | | | | |", backend.name()),
        },
    );
}
