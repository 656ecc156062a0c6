//! ONNX graphs of Illum's networks for inference, each with test vectors and checked in tract
//! (the engine's [`splatzoo_train::onnx::export_rows`]):
//!
//! - `visibility.onnx` (F_vis, Eq. 3): `visibility_inputs` `[R, input_width]` =
//!   `[γ(v) ‖ γ(φ) ‖ θ]` (see [`VisibilityNet::logits`] for the layout) → `visibility`
//!   `[R, 1]` in (0, 1);
//! - `shadow.onnx` (F_ao, Eq. 8): `shadow_inputs` `[R, 40 + d_z]` = `[γ(r) ‖ γ(δ) ‖ z]`
//!   ([`crate::shadow::decoder_inputs`]) → `ao` `[R, 1]`;
//! - `materials_code.onnx` (F_m's hash encoding, Eq. 2): `canonical_positions` `[R, 3]` (the
//!   template's canonical space, in metres; any `R`) → `hash_code` `[R, L·F]`, the body's unit
//!   cube and the trained table inside, written node by node by the engine
//!   ([`splatzoo_train::onnx::export_hash_grid`]: burn-onnx cannot trace a hash encoding);
//! - `materials.onnx` (F_m's network, Eq. 2): `hash_code` `[R, L·F]` → `metallic_roughness`
//!   `[R, 2]` in (0, 1). Chained after `materials_code.onnx` it is F_m from positions; for a
//!   fixed body the codes are constants, computed once.
//!
//! Row counts of the burn-onnx graphs are fixed at export (burn-onnx 0.22 does not slice
//! dynamic axes); run more rows in chunks of that many.

use crate::IllumError;
use crate::shadow::ShadowDecoder;
use crate::visibility::VisibilityNet;
use burn::tensor::activation::sigmoid;
use burn::tensor::{Device, Distribution, Tensor, TensorData};
use splatzoo_models::networks::hash_mlp::{HashMlp, UnitCube};
use splatzoo_train::TrainError;
use splatzoo_train::onnx::{ExportedGraph, OnnxError, export_hash_grid, export_rows};
use std::path::Path;

/// Each graph's file stem, input and output names.
pub const GRAPHS: [(&str, &str, &str); 4] = [
    ("visibility", "visibility_inputs", "visibility"),
    ("shadow", "shadow_inputs", "ao"),
    ("materials_code", "canonical_positions", "hash_code"),
    ("materials", "hash_code", "metallic_roughness"),
];

/// `(m, r)` in (0, 1) of F_m's network from hash codes.
pub fn material_output(field: &HashMlp, code: Tensor<2>) -> Tensor<2> {
    sigmoid(field.forward_code(code))
}

/// The networks to export (each without autodiff).
pub struct IllumNetworks<'a> {
    pub visibility: &'a VisibilityNet,
    pub shadow: &'a ShadowDecoder,
    pub materials: &'a HashMlp,
    /// The cube that maps canonical positions into F_m's grid ([`crate::human::BodyMesh`]'s).
    pub cube: &'a UnitCube,
}

/// Writes the four graphs with two test vectors each (`rows` rows of normal samples; positions
/// uniform in the cube and a little beyond it) into `dir` and checks each in tract.
pub fn export(
    nets: &IllumNetworks,
    rows: usize,
    dir: &Path,
    device: &Device,
) -> Result<Vec<ExportedGraph>, IllumError> {
    let samples = |width: usize| -> Vec<Tensor<2>> {
        (0..2)
            .map(|_| Tensor::random([rows.max(1), width], Distribution::Normal(0.0, 1.0), device))
            .collect()
    };
    let cube = nets.cube;
    let positions: Vec<Tensor<2>> = (0..2)
        .map(|_| {
            let unit =
                Tensor::<2>::random([rows.max(1), 3], Distribution::Uniform(-0.05, 1.05), device);
            let min = Tensor::<2>::from_data(
                TensorData::new(cube.min.map(|v| v as f32).to_vec(), [1, 3]),
                device,
            );
            unit * cube.size + min
        })
        .collect();
    let graphs = || -> Result<Vec<ExportedGraph>, OnnxError> {
        Ok(vec![
            export_rows(
                nets.visibility,
                VisibilityNet::probability_rows,
                &samples(nets.visibility.input_width()),
                GRAPHS[0],
                dir,
            )?,
            export_rows(
                nets.shadow,
                ShadowDecoder::forward_rows,
                &samples(ShadowDecoder::input_width(nets.shadow.latent_dim())),
                GRAPHS[1],
                dir,
            )?,
            export_hash_grid(
                &nets.materials.grid,
                Some(nets.cube),
                &positions,
                GRAPHS[2],
                dir,
            )?,
            export_rows(
                nets.materials,
                material_output,
                &samples(nets.materials.grid.output_width()),
                GRAPHS[3],
                dir,
            )?,
        ])
    };
    graphs().map_err(|e| IllumError::Train(TrainError::from(e)))
}
