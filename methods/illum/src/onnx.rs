//! ONNX graphs of Illum's networks for inference, each with test vectors and checked in tract
//! (the engine's [`splatzoo_train::onnx::export_rows`]). Stage 1's body fields, always:
//!
//! - `offsets_code.onnx` and `colours_code.onnx` (F_Δ's and F_c's hash encodings, Eq. 1):
//!   `canonical_positions` `[R, 3]` (the template's canonical space, in metres; any `R`) →
//!   `hash_code` `[R, L·F]`, the body's unit cube and the trained table inside, written node by
//!   node by the engine ([`splatzoo_train::onnx::export_hash_grid`]: burn-onnx cannot trace a
//!   hash encoding);
//! - `offsets.onnx` (F_Δ's network): `hash_code` → `offsets` `[R, 3]` in metres, each component
//!   clamped to `±max_offset·H` as in training ([`RefinedBody::offsets_for_export`]);
//! - `colours.onnx` (F_c's network): `hash_code` → `colours` `[R, 3]` in (0, 1).
//!
//! Chained after its code graph each is the field from canonical positions; for a fixed body
//! the codes are constants, computed once. Where stage 2 ran, also:
//!
//! - `visibility.onnx` (F_vis, Eq. 3): `visibility_inputs` `[R, input_width]` =
//!   `[γ(v) ‖ γ(φ) ‖ θ]` (see [`VisibilityNet::logits`] for the layout) → `visibility`
//!   `[R, 1]` in (0, 1);
//! - `shadow.onnx` (F_ao, Eq. 8): `shadow_inputs` `[R, 40 + d_z]` = `[γ(r) ‖ γ(δ) ‖ z]`
//!   ([`crate::shadow::decoder_inputs`]) → `ao` `[R, 1]`;
//! - `materials_code.onnx` and `materials.onnx` (F_m, Eq. 2): as F_c's pair, → `metallic_roughness`
//!   `[R, 2]` in (0, 1).
//!
//! Row counts of the burn-onnx graphs are fixed at export (burn-onnx 0.22 does not slice
//! dynamic axes); run more rows in chunks of that many.

use crate::IllumError;
use crate::human::RefinedBody;
use crate::shadow::ShadowDecoder;
use crate::visibility::VisibilityNet;
use burn::tensor::activation::sigmoid;
use burn::tensor::{Device, Distribution, Tensor, TensorData};
use splatzoo_models::networks::hash_mlp::{HashMlp, UnitCube};
use splatzoo_train::TrainError;
use splatzoo_train::onnx::{ExportedGraph, OnnxError, export_hash_grid, export_rows};
use std::path::Path;

/// Stage 1's graphs: file stem, input and output names.
pub const BODY_GRAPHS: [(&str, &str, &str); 4] = [
    ("offsets_code", "canonical_positions", "hash_code"),
    ("offsets", "hash_code", "offsets"),
    ("colours_code", "canonical_positions", "hash_code"),
    ("colours", "hash_code", "colours"),
];

/// Stage 2's graphs, in the same form.
pub const STAGE2_GRAPHS: [(&str, &str, &str); 4] = [
    ("visibility", "visibility_inputs", "visibility"),
    ("shadow", "shadow_inputs", "ao"),
    ("materials_code", "canonical_positions", "hash_code"),
    ("materials", "hash_code", "metallic_roughness"),
];

/// `(m, r)` in (0, 1) of F_m's network from hash codes.
pub fn material_output(field: &HashMlp, code: Tensor<2>) -> Tensor<2> {
    sigmoid(field.forward_code(code))
}

/// Stage 2's networks (each without autodiff).
pub struct Stage2Networks<'a> {
    pub visibility: &'a VisibilityNet,
    pub shadow: &'a ShadowDecoder,
    pub materials: &'a HashMlp,
}

/// The networks to export (each without autodiff).
pub struct IllumNetworks<'a> {
    /// F_Δ and F_c.
    pub body: &'a RefinedBody,
    /// The cube that maps canonical positions into the body fields' grids
    /// ([`crate::human::BodyMesh`]'s; F_m's too).
    pub cube: &'a UnitCube,
    /// `None` where the run ended in stage 1.
    pub stage2: Option<Stage2Networks<'a>>,
}

/// Writes the graphs with two test vectors each (`rows` rows of normal samples; positions
/// uniform in the cube and a little beyond it) into `dir` and checks each in tract: stage 1's
/// four ([`BODY_GRAPHS`]), then stage 2's four ([`STAGE2_GRAPHS`]) where it ran.
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
        let body = nets.body;
        let mut graphs = vec![
            export_hash_grid(
                &body.offset.grid,
                Some(cube),
                &positions,
                BODY_GRAPHS[0],
                dir,
            )?,
            export_rows(
                body,
                RefinedBody::offsets_for_export,
                &samples(body.offset.grid.output_width()),
                BODY_GRAPHS[1],
                dir,
            )?,
            export_hash_grid(
                &body.colour.grid,
                Some(cube),
                &positions,
                BODY_GRAPHS[2],
                dir,
            )?,
            export_rows(
                body,
                RefinedBody::colours_from_code,
                &samples(body.colour.grid.output_width()),
                BODY_GRAPHS[3],
                dir,
            )?,
        ];
        if let Some(stage2) = &nets.stage2 {
            graphs.extend([
                export_rows(
                    stage2.visibility,
                    VisibilityNet::probability_rows,
                    &samples(stage2.visibility.input_width()),
                    STAGE2_GRAPHS[0],
                    dir,
                )?,
                export_rows(
                    stage2.shadow,
                    ShadowDecoder::forward_rows,
                    &samples(ShadowDecoder::input_width(stage2.shadow.latent_dim())),
                    STAGE2_GRAPHS[1],
                    dir,
                )?,
                export_hash_grid(
                    &stage2.materials.grid,
                    Some(cube),
                    &positions,
                    STAGE2_GRAPHS[2],
                    dir,
                )?,
                export_rows(
                    stage2.materials,
                    material_output,
                    &samples(stage2.materials.grid.output_width()),
                    STAGE2_GRAPHS[3],
                    dir,
                )?,
            ]);
        }
        Ok(graphs)
    };
    graphs().map_err(|e| IllumError::Train(TrainError::from(e)))
}
