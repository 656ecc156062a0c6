//! The ONNX graph of the pose-dependent offset network for inference, with test vectors, checked
//! in tract (the engine's [`splatzoo_train::onnx`]):
//!
//! `pose_offsets.onnx`: `offset_inputs` `[R, 3 (1 + 2 L) + 6 (J − 1)]` = `[γ(x̄) ‖ pose]` (see
//! [`PoseOffsetNet::inputs`]) → `offsets` `[R, 4]` = `(ΔV_pose, ΔS_pose)`: add the first three
//! to the canonical centres and the fourth to the log-radii before skinning (Eq. 2).
//!
//! burn-onnx 0.22 fixes the row count at export ([`ROWS`]); run an avatar's Gaussians through it
//! in chunks of that many rows. The test vectors are the trained avatar's first rows at the
//! acting video's first two frames.

use crate::error::Prior4dError;
use crate::offsets::PoseOffsetNet;
use burn::tensor::Tensor;
use splatzoo_train::TrainError;
use splatzoo_train::onnx::{ExportedGraph, export_rows};
use std::path::Path;

/// The graph's file stem, input and output names.
pub const GRAPH: (&str, &str, &str) = ("pose_offsets", "offset_inputs", "offsets");

/// Rows per run of the exported graph.
pub const ROWS: usize = 1024;

/// Writes `pose_offsets.onnx` and its vectors (`samples`: input rows `[ROWS, ·]`, at least one)
/// into `dir` and checks them in tract; `net` without autodiff.
pub fn export(
    net: &PoseOffsetNet,
    samples: &[Tensor<2>],
    dir: &Path,
) -> Result<ExportedGraph, Prior4dError> {
    export_rows(net, PoseOffsetNet::forward_inputs, samples, GRAPH, dir)
        .map_err(|e| Prior4dError::Train(TrainError::from(e)))
}
