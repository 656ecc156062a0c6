//! ONNX graphs of Illum's networks for inference, each with test vectors and checked in tract
//! (the engine's [`splatzoo_train::onnx::export_rows`]):
//!
//! - `visibility.onnx` (F_vis, Eq. 3): `visibility_inputs` `[R, input_width]` =
//!   `[γ(v) ‖ γ(φ) ‖ θ]` (see [`VisibilityNet::logits`] for the layout) → `visibility`
//!   `[R, 1]` in (0, 1);
//! - `shadow.onnx` (F_ao, Eq. 8): `shadow_inputs` `[R, 40 + d_z]` = `[γ(r) ‖ γ(δ) ‖ z]`
//!   ([`crate::shadow::decoder_inputs`]) → `ao` `[R, 1]`;
//! - `materials.onnx` (F_m's network, Eq. 2): `hash_code` `[R, L·F]` → `metallic_roughness`
//!   `[R, 2]` in (0, 1). The hash encoding itself (a gather of `L·8` table rows and a weighted
//!   sum, [`splatzoo_models::networks::hash_grid::HashGrid`]) runs outside the graph: for a
//!   fixed body its codes are constants, computed once.
//!
//! Row counts are fixed at export (burn-onnx 0.22 does not slice dynamic axes); run more rows
//! in chunks of that many.

use crate::IllumError;
use crate::shadow::ShadowDecoder;
use crate::visibility::VisibilityNet;
use burn::tensor::activation::sigmoid;
use burn::tensor::{Device, Distribution, Tensor};
use splatzoo_models::networks::hash_mlp::HashMlp;
use splatzoo_train::TrainError;
use splatzoo_train::onnx::{ExportedGraph, OnnxError, export_rows};
use std::path::Path;

/// Each graph's file stem, input and output names.
pub const GRAPHS: [(&str, &str, &str); 3] = [
    ("visibility", "visibility_inputs", "visibility"),
    ("shadow", "shadow_inputs", "ao"),
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
}

/// Writes the three graphs with two test vectors each (`rows` rows of normal samples) into
/// `dir` and checks each in tract.
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
            export_rows(
                nets.materials,
                material_output,
                &samples(nets.materials.grid.output_width()),
                GRAPHS[2],
                dir,
            )?,
        ])
    };
    graphs().map_err(|e| IllumError::Train(TrainError::from(e)))
}
