//! ONNX graphs of the methods' networks, for inference elsewhere: naming an exported graph's
//! inputs and outputs for what they are ([`rename_graph_io`]; burn-onnx 0.22 names them
//! `tensor_<id>`), writing it atomically, test vectors beside it (inputs and Burn's outputs
//! keyed `<name>.k`), and running it in tract, a pure-Rust ONNX runtime, to check every export
//! against Burn before it is reported ([`verify`]). The export itself (burn-onnx's
//! `OnnxExporter` over a module's forward) stays with each method, which knows its graphs.

mod names;

pub use names::{graph_io_names, rename_graph_io, run_graph_named};

use crate::checkpoint::Checkpoint;
use burn::tensor::Tensor;
use std::path::Path;

/// An ONNX graph or its test vectors could not be written, read or run: the file and what went
/// wrong.
#[derive(Debug, thiserror::Error)]
#[error("{file}: {problem}")]
pub struct OnnxError {
    pub file: String,
    pub problem: String,
}

impl OnnxError {
    pub fn new(file: &Path, problem: impl std::fmt::Display) -> Self {
        Self {
            file: file.display().to_string(),
            problem: problem.to_string(),
        }
    }
}

/// Names the graph's inputs and outputs (positionally) and writes it to `path` atomically.
pub fn write_graph(
    bytes: &[u8],
    inputs: &[&str],
    outputs: &[&str],
    path: &Path,
) -> Result<(), OnnxError> {
    let named = rename_graph_io(bytes, inputs, outputs).map_err(|e| OnnxError::new(path, e))?;
    splatzoo_models::files::write_bytes(path, &named)
        .map_err(|e| OnnxError::new(path, format!("cannot write ({e})")))
}

/// Writes test vectors: for each `k`, `<input>.k` and `<output>.k`.
pub fn write_vectors(
    path: &Path,
    input: &str,
    output: &str,
    pairs: &[(Tensor<2>, Tensor<2>)],
) -> Result<(), OnnxError> {
    let mut vectors = Checkpoint::default();
    for (k, (x, y)) in pairs.iter().enumerate() {
        vectors.put(&format!("{input}.{k}"), x);
        vectors.put(&format!("{output}.{k}"), y);
    }
    vectors.write(path).map_err(|e| OnnxError::new(path, e))
}

/// Runs the one-input ONNX graph at `path` in tract on an f32 input of `shape` (which resolves
/// any symbolic axis), fed by the graph's input name; returns the first output's shape and
/// values.
pub fn run_graph(
    path: &Path,
    shape: &[usize],
    values: &[f32],
) -> Result<(Vec<usize>, Vec<f32>), OnnxError> {
    let (inputs, _) = io_names(path)?;
    let [input] = inputs.as_slice() else {
        return Err(OnnxError::new(
            path,
            format!("{} graph inputs, expected one", inputs.len()),
        ));
    };
    let mut outputs = run_graph_named(path, &[(input.as_str(), shape, values)])
        .map_err(|e| OnnxError::new(path, e))?;
    let (_, shape, values) = outputs.swap_remove(0);
    Ok((shape, values))
}

/// The graph's input and output names, in graph order.
pub fn io_names(path: &Path) -> Result<(Vec<String>, Vec<String>), OnnxError> {
    let bytes =
        std::fs::read(path).map_err(|e| OnnxError::new(path, format!("cannot read ({e})")))?;
    graph_io_names(&bytes).map_err(|e| OnnxError::new(path, e))
}

/// Largest `|a − b| / (1 + |b|)`.
pub fn max_relative_difference(a: &[f32], b: &[f32]) -> f32 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs() / (1.0 + y.abs()))
        .fold(0.0, f32::max)
}

/// Runs `graph` on every vector in `vectors` (`<input name>.k` → `<output name>.k`, the
/// names read from the graph); returns the largest relative difference from the stored
/// outputs, or what went wrong (a missing vector, a shape that differs, a graph tract cannot
/// run).
pub fn verify(graph: &Path, vectors: &Path) -> Result<f32, OnnxError> {
    let stored = Checkpoint::read(vectors).map_err(|e| OnnxError::new(vectors, e))?;
    let (inputs, outputs) = io_names(graph)?;
    let (Some(input), Some(output)) = (inputs.first(), outputs.first()) else {
        return Err(OnnxError::new(graph, "the graph has no input or no output"));
    };
    let mut worst = 0.0f32;
    for k in 0.. {
        let Some((in_shape, values)) = stored.tensors.get(&format!("{input}.{k}")) else {
            if k == 0 {
                return Err(OnnxError::new(vectors, format!("no `{input}.0`")));
            }
            break;
        };
        let (out_shape, expected) = stored
            .tensors
            .get(&format!("{output}.{k}"))
            .ok_or_else(|| OnnxError::new(vectors, format!("no `{output}.{k}`")))?;
        let (shape, got) = run_graph(graph, in_shape, values)?;
        if &shape != out_shape {
            return Err(OnnxError::new(
                graph,
                format!("on vector {k}: output shape {shape:?}, expected {out_shape:?}"),
            ));
        }
        worst = worst.max(max_relative_difference(&got, expected));
    }
    Ok(worst)
}
