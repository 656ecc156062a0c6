//! Training speed and peak memory per backend on the default `train-3dgs` scene (96², 14 064
//! Gaussians from depth, SH degree 3, no density control so every backend does the same work).
//!
//! ```sh
//! cargo bench --workspace --bench train                 # flex, ndarray, wgpu
//! cargo bench --workspace --bench train -- flex 200     # one backend, 200 steps
//! ```
//!
//! Each backend runs in its own child process ([`common::run`]). Prints a table.

mod common;

use common::peak_rss_mib;
use splatzoo_train::backend::Backend;
use splatzoo_train::densify::Strategy;
use splatzoo_train::harness::Method;
use splatzoo_train::static_scene::{StaticConfig, StaticTrainer};
use std::time::Instant;

const WARM_UP: usize = 10;

/// In the child: trains; returns steps/s, peak MiB and the Gaussian count.
fn child(backend: Backend, steps: usize) -> Vec<f64> {
    let mut config = StaticConfig {
        backend,
        iterations: WARM_UP + steps,
        sh_degree_every: 1,
        ..Default::default()
    };
    config.densify.strategy = Strategy::None;
    let device = backend.device();
    let mut trainer = StaticTrainer::new(config, &device).expect("default scene");
    for _ in 0..WARM_UP {
        trainer.step().expect("step");
    }
    let start = Instant::now();
    for _ in 0..steps {
        trainer.step().expect("step");
    }
    let rate = steps as f64 / start.elapsed().as_secs_f64();
    vec![rate, peak_rss_mib(), trainer.graph.gaussians() as f64]
}

fn main() {
    common::run(
        60,
        child,
        |steps| {
            println!(
                "train-3dgs default scene, {steps} timed steps after {WARM_UP} warm-up, SH degree 3"
            );
            println!("| backend | steps/s | peak memory (RSS) | Gaussians |");
            println!("|---|---|---|---|");
        },
        |backend, figures| match figures {
            Ok(f) if f.len() == 3 => println!(
                "| {} | {:.1} | {:.0} MiB | {} |",
                backend.name(),
                f[0],
                f[1],
                f[2]
            ),
            Ok(f) => println!("| {} | unexpected output {f:?} | | |", backend.name()),
            Err(e) => println!("| {} | failed: {e} | | |", backend.name()),
        },
    );
}
