//! Training speed and peak memory per backend on the default `train-3dgs` scene (96², 14 064
//! Gaussians from depth, SH degree 3, no density control so every backend does the same work).
//!
//! ```sh
//! cargo bench --workspace --bench train                 # flex, ndarray, wgpu
//! cargo bench --workspace --bench train -- flex 200     # one backend, 200 steps
//! ```
//!
//! Each backend runs in its own child process so that its peak resident memory (`VmHWM`, which
//! on lavapipe includes the "GPU" buffers) is its own. Prints a table.

use splatzoo_train::backend::Backend;
use splatzoo_train::densify::Strategy;
use splatzoo_train::harness::Method;
use splatzoo_train::static_scene::{StaticConfig, StaticTrainer};
use std::process::Command;
use std::time::Instant;

const WARM_UP: usize = 10;

fn peak_rss_mib() -> f64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<f64>().ok())
        .map_or(f64::NAN, |kb| kb / 1024.0)
}

/// In the child: trains and prints `steps/s peak_MiB gaussians`.
fn child(backend: Backend, steps: usize) {
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
    println!("{rate} {} {}", peak_rss_mib(), trainer.graph.gaussians());
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
    let steps: usize = args.iter().find_map(|a| a.parse().ok()).unwrap_or(60);
    let chosen: Vec<Backend> = Backend::ALL
        .into_iter()
        .filter(|b| {
            args.iter().all(|a| a.parse::<usize>().is_ok()) || args.iter().any(|a| a == b.name())
        })
        .collect();
    println!("train-3dgs default scene, {steps} timed steps after {WARM_UP} warm-up, SH degree 3");
    println!("| backend | steps/s | peak memory (RSS) | Gaussians |");
    println!("|---|---|---|---|");
    let exe = std::env::current_exe().expect("own path");
    for backend in chosen {
        let out = Command::new(&exe)
            .args(["--child", backend.name(), &steps.to_string()])
            .output()
            .expect("child runs");
        let text = String::from_utf8_lossy(&out.stdout);
        let fields: Vec<&str> = text.split_whitespace().collect();
        if !out.status.success() || fields.len() != 3 {
            println!(
                "| {} | failed: {} | | |",
                backend.name(),
                String::from_utf8_lossy(&out.stderr)
                    .lines()
                    .last()
                    .unwrap_or("")
            );
            continue;
        }
        let rate: f64 = fields[0].parse().unwrap_or(f64::NAN);
        let mib: f64 = fields[1].parse().unwrap_or(f64::NAN);
        println!(
            "| {} | {rate:.1} | {mib:.0} MiB | {} |",
            backend.name(),
            fields[2]
        );
    }
}
