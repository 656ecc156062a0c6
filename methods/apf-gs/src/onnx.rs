//! ONNX graphs of APF-GS's networks for inference, each with test vectors and checked in tract
//! (the engine's [`splatzoo_train::onnx`]):
//!
//! - `guidance.onnx` (`C`): `guidance_inputs` `[1, F + E + T]` = `[f_img ‖ e_h ‖ γ(t)]` →
//!   `condition_and_sigma` `[1, C + 1]` = `[c_t ‖ σ_t]` (the sigmoid applied);
//! - `residual.onnx` (`F_φ`): `residual_inputs` `[G, 63 + C]` = `[γ(μ̄) ‖ c_t]` →
//!   `residual` `[G, 10]`, raw `(δμ, δq, δs)` before the gate (multiply by `a(σ)`, then bound
//!   `δμ` by `r_max tanh(·/r_max)`; see [`crate::residual`]). With a hash `γ` the input is the
//!   hash code, `[G, L·F + C]`, and a fourth graph computes it:
//! - `residual_code.onnx` (the hash `γ` of `F_φ`, only with `position_encoding = "hash"`):
//!   `normalised_positions` `[R, 3]` = `μ̄` in `[−1, 1]³` (any `R`) → `position_code`
//!   `[R, L·F]`, the trained table inside, written node by node by the engine
//!   ([`splatzoo_train::onnx::export_hash_grid`]: burn-onnx cannot trace a hash encoding);
//! - `accessory.onnx` (`D_ψ`): `accessory_inputs` `[N, 63 + T + E]` = `[γ(x̄) ‖ γ(t) ‖ e_a]`
//!   → `deformation` `[N, 7]` = `(δx, δq)`.
//!
//! Row counts are fixed at export (burn-onnx 0.22 does not slice dynamic axes): one person-frame
//! for `C`, one human's Gaussians for `F_φ`, `N` accessory Gaussians for `D_ψ`.

use crate::error::ApfError;
use crate::networks::{AccessoryField, ApfNetworks, Guidance, NetworkConfig, ResidualField};
use burn::tensor::activation::sigmoid;
use burn::tensor::{Device, Distribution, Tensor};
use splatzoo_models::networks::hash_mlp::UnitCube;
use splatzoo_train::onnx::{ExportedGraph, OnnxError, export_hash_grid, export_rows};
use std::path::Path;

/// Each graph's file stem, input and output names.
pub const GRAPHS: [(&str, &str, &str); 3] = [
    ("guidance", "guidance_inputs", "condition_and_sigma"),
    ("residual", "residual_inputs", "residual"),
    ("accessory", "accessory_inputs", "deformation"),
];

/// The hash `γ`'s graph, written after [`GRAPHS`] where `F_φ` has one.
pub const POSITION_CODE_GRAPH: (&str, &str, &str) =
    ("residual_code", "normalised_positions", "position_code");

/// `[c_t ‖ σ_t]` of `C`.
pub fn guidance_output(net: &Guidance, inputs: Tensor<2>) -> Tensor<2> {
    let (condition, logit) = net.forward(inputs);
    Tensor::cat(vec![condition, sigmoid(logit)], 1)
}

/// Writes the three graphs (four with a hash `γ`) with two test vectors each into `dir` (`nets`
/// without autodiff), for `gaussians` human Gaussians and `accessory_rows` accessory Gaussians,
/// and checks each in tract.
pub fn export(
    nets: &ApfNetworks,
    config: &NetworkConfig,
    gaussians: usize,
    accessory_rows: usize,
    dir: &Path,
    device: &Device,
) -> Result<Vec<ExportedGraph>, ApfError> {
    let samples = |rows: usize, width: usize| -> Vec<Tensor<2>> {
        (0..2)
            .map(|_| Tensor::random([rows, width], Distribution::Normal(0.0, 1.0), device))
            .collect()
    };
    let graphs = || -> Result<Vec<ExportedGraph>, OnnxError> {
        let mut graphs = vec![
            export_rows(
                &nets.guidance,
                guidance_output,
                &samples(1, config.guidance_inputs()),
                GRAPHS[0],
                dir,
            )?,
            export_rows(
                &nets.residual,
                |m: &ResidualField, x| m.forward(x),
                &samples(gaussians.max(1), config.residual_inputs()),
                GRAPHS[1],
                dir,
            )?,
            export_rows(
                &nets.accessory,
                |m: &AccessoryField, x| m.forward(x),
                &samples(accessory_rows.max(1), config.accessory_inputs()),
                GRAPHS[2],
                dir,
            )?,
        ];
        if let Some(grid) = &nets.residual.encoding {
            // μ̄ ∈ [−1, 1]³ enters the grid as (μ̄ + 1) / 2: the cube of side 2 at −1.
            let cube = UnitCube {
                min: [-1.0; 3],
                size: 2.0,
            };
            let positions: Vec<Tensor<2>> = (0..2)
                .map(|_| {
                    Tensor::random(
                        [gaussians.max(1), 3],
                        Distribution::Uniform(-1.1, 1.1),
                        device,
                    )
                })
                .collect();
            graphs.push(export_hash_grid(
                grid,
                Some(&cube),
                &positions,
                POSITION_CODE_GRAPH,
                dir,
            )?);
        }
        Ok(graphs)
    };
    graphs().map_err(|e| ApfError::from(splatzoo_train::TrainError::from(e)))
}
