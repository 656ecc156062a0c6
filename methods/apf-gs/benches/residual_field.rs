//! The residual field `F_φ` alone, forward and backward, per backend: what its speed knobs
//! cost per pedestrian per step. `γ(μ̄)` as NeRF frequencies (the paper's) or as the engine's
//! hash encoding (the spec's speed knob; its corner rows are computed on the host), the MLP at
//! 4 × 128 (the default) or 4 × 64, and the per-Gaussian gate's eleventh column. Every column
//! encodes the same `G` random canonical means and conditions, sums the outputs and
//! backpropagates to every parameter, as a training step does; milliseconds per pass, and the
//! child's peak resident memory over all of them.
//!
//! ```sh
//! cargo bench --workspace --bench residual_field                # flex, ndarray, wgpu
//! cargo bench --workspace --bench residual_field -- flex 20     # one backend, 20 passes
//! ```
//!
//! Each backend runs in its own child process (the engine's bench harness).

#[path = "../../../train/benches/common/mod.rs"]
mod common;

use burn::module::Module;
use burn::tensor::{Device, Distribution, Tensor};
use splatzoo_apf_gs::networks::{NetworkConfig, PositionEncoding, ResidualField};
use splatzoo_train::backend::Backend;
use splatzoo_train::host_f32;
use std::time::Instant;

/// Gaussians of one pedestrian: the default driving scene's people carry about 7.9k each.
const GAUSSIANS: usize = 8192;
const WARM_UP: usize = 2;

/// The columns: name, `γ`, MLP width, output columns.
const VARIANTS: [(&str, PositionEncoding, usize, usize); 5] = [
    ("frequency, 4 × 128", PositionEncoding::Frequency, 128, 10),
    ("hash, 4 × 128", PositionEncoding::Hash, 128, 10),
    ("hash, 4 × 64", PositionEncoding::Hash, 64, 10),
    ("frequency, 4 × 64", PositionEncoding::Frequency, 64, 10),
    (
        "frequency, 4 × 128, per-Gaussian gate",
        PositionEncoding::Frequency,
        128,
        11,
    ),
];

/// Milliseconds per forward + backward pass of one variant.
fn pass_ms(config: &NetworkConfig, columns: usize, passes: usize, device: &Device) -> f64 {
    let field = ResidualField::new(config, columns, device).train();
    let normalised = Tensor::<2>::random([GAUSSIANS, 3], Distribution::Uniform(-1.0, 1.0), device);
    let condition = Tensor::<2>::random(
        [GAUSSIANS, config.condition],
        Distribution::Normal(0.0, 1.0),
        device,
    );
    let pass = || {
        let encoded = field.encode_positions(normalised.clone().autodiff(), config.position_levels);
        let inputs = Tensor::cat(vec![encoded, condition.clone().autodiff()], 1);
        let grads = field.forward(inputs).sum().backward();
        let weight = field.head.weight.grad(&grads).expect("the head's gradient");
        host_f32(&weight.sum())[0]
    };
    for _ in 0..WARM_UP {
        pass();
    }
    let start = Instant::now();
    for _ in 0..passes {
        pass();
    }
    1e3 * start.elapsed().as_secs_f64() / passes as f64
}

fn child(backend: Backend, passes: usize) -> Vec<f64> {
    let device = backend.device();
    let mut figures: Vec<f64> = VARIANTS
        .iter()
        .map(|&(_, encoding, width, columns)| {
            let config = NetworkConfig {
                position_encoding: encoding,
                residual_width: width,
                ..NetworkConfig::default()
            };
            pass_ms(&config, columns, passes, &device)
        })
        .collect();
    // After every pass has run.
    figures.push(common::peak_rss_mib());
    figures
}

fn main() {
    common::run(
        10,
        child,
        |passes| {
            println!(
                "F_φ forward + backward at {GAUSSIANS} Gaussians (one pedestrian), ms per pass, \
                 {passes} timed passes after {WARM_UP} warm-up"
            );
            let names: Vec<&str> = VARIANTS.iter().map(|v| v.0).collect();
            println!("| backend | {} | peak memory (RSS) |", names.join(" | "));
            println!("|---|{}---|", "---|".repeat(VARIANTS.len()));
        },
        |backend, figures| match figures {
            Ok(f) if f.len() == VARIANTS.len() + 1 => {
                let cells: Vec<String> = f[..VARIANTS.len()]
                    .iter()
                    .map(|ms| format!("{ms:.0}"))
                    .collect();
                let peak = f[VARIANTS.len()];
                println!(
                    "| {} | {} | {peak:.0} MiB |",
                    backend.name(),
                    cells.join(" | ")
                );
            }
            Ok(f) => println!("| {} | unexpected output {f:?} |", backend.name()),
            Err(e) => println!("| {} | failed: {e} |", backend.name()),
        },
    );
}
