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
use burn_onnx::export::OnnxExporter;
use splatzoo_train::TrainError;
use splatzoo_train::onnx::{OnnxError, verify, write_graph, write_vectors};
use std::path::{Path, PathBuf};

/// The graph's file stem, input and output names.
pub const GRAPH: (&str, &str, &str) = ("pose_offsets", "offset_inputs", "offsets");

/// Rows per run of the exported graph.
pub const ROWS: usize = 1024;

/// The written graph and tract's largest relative difference from Burn on its vectors.
#[derive(Debug, Clone)]
pub struct ExportedGraph {
    pub graph: PathBuf,
    pub vectors: PathBuf,
    pub relative_error: f32,
}

/// Writes `pose_offsets.onnx` and its vectors (`samples`: input rows `[ROWS, ·]`, at least one)
/// into `dir` and checks them in tract; `net` without autodiff.
pub fn export(
    net: &PoseOffsetNet,
    samples: &[Tensor<2>],
    dir: &Path,
) -> Result<ExportedGraph, Prior4dError> {
    let (stem, input, output) = GRAPH;
    let fail = |file: &Path, problem: String| {
        Prior4dError::Train(TrainError::from(OnnxError::new(file, problem)))
    };
    std::fs::create_dir_all(dir).map_err(|e| fail(dir, format!("cannot create ({e})")))?;
    let graph = dir.join(format!("{stem}.onnx"));
    let vectors = dir.join(format!("{stem}.vectors.safetensors"));
    let first = samples
        .first()
        .ok_or_else(|| fail(&graph, "no sample inputs to export with".into()))?;
    let model = OnnxExporter::new()
        .export(net, first.clone(), PoseOffsetNet::forward_inputs)
        .map_err(|e| fail(&graph, format!("exporting {stem}: {e}")))?;
    write_graph(model.as_bytes(), &[input], &[output], &graph).map_err(TrainError::from)?;
    let pairs: Vec<(Tensor<2>, Tensor<2>)> = samples
        .iter()
        .map(|x| (x.clone(), net.forward_inputs(x.clone())))
        .collect();
    write_vectors(&vectors, input, output, &pairs).map_err(TrainError::from)?;
    let relative_error = verify(&graph, &vectors).map_err(TrainError::from)?;
    Ok(ExportedGraph {
        graph,
        vectors,
        relative_error,
    })
}
