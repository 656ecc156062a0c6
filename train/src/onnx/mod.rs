//! ONNX graphs of the methods' networks, for inference elsewhere: naming an exported graph's
//! inputs and outputs for what they are ([`rename_graph_io`]; burn-onnx 0.22 names them
//! `tensor_<id>`), writing it atomically, test vectors beside it (inputs and Burn's outputs
//! keyed `<name>.k`), and running it in tract, a pure-Rust ONNX runtime, to check every export
//! against Burn before it is reported ([`verify`]). [`export_rows`] does all of it for the
//! common case, a module's row-wise map `[R, I] → [R, O]`; a method with other graph shapes
//! drives burn-onnx's `OnnxExporter` itself. A hash encoding, which burn-onnx cannot trace, is
//! written node by node ([`export_hash_grid`]).

mod hash_grid;
mod names;

pub use hash_grid::{export_hash_grid, hash_grid_model};
pub use names::{graph_io_names, rename_graph_io, run_graph_named, tract_io_names};

use crate::checkpoint::Checkpoint;
use burn::module::Module;
use burn::tensor::Tensor;
use burn_onnx::export::OnnxExporter;
use std::path::{Path, PathBuf};

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

/// One exported graph: its file and its vectors, and tract's largest relative difference from
/// Burn on them.
#[derive(Debug, Clone)]
pub struct ExportedGraph {
    pub graph: PathBuf,
    pub vectors: PathBuf,
    pub relative_error: f32,
}

/// Exports `forward` of `module` (without autodiff), a row-wise map `[R, I] → [R, O]` whose row
/// count the first sample fixes (burn-onnx 0.22 does not slice dynamic axes), to
/// `dir/<stem>.onnx` with its input and output named; writes every sample and Burn's output for
/// it to `dir/<stem>.vectors.safetensors`; and checks the graph on them in tract.
pub fn export_rows<M: Module>(
    module: &M,
    forward: fn(&M, Tensor<2>) -> Tensor<2>,
    samples: &[Tensor<2>],
    (stem, input, output): (&str, &str, &str),
    dir: &Path,
) -> Result<ExportedGraph, OnnxError> {
    std::fs::create_dir_all(dir)
        .map_err(|e| OnnxError::new(dir, format!("cannot create ({e})")))?;
    let graph = dir.join(format!("{stem}.onnx"));
    let vectors = dir.join(format!("{stem}.vectors.safetensors"));
    let first = samples
        .first()
        .ok_or_else(|| OnnxError::new(&graph, "no sample inputs to export with"))?;
    let model = OnnxExporter::new()
        .export(module, first.clone(), forward)
        .map_err(|e| OnnxError::new(&graph, format!("exporting {stem}: {e}")))?;
    write_graph(model.as_bytes(), &[input], &[output], &graph)?;
    let pairs: Vec<(Tensor<2>, Tensor<2>)> = samples
        .iter()
        .map(|x| (x.clone(), forward(module, x.clone())))
        .collect();
    write_vectors(&vectors, input, output, &pairs)?;
    let relative_error = verify(&graph, &vectors)?;
    Ok(ExportedGraph {
        graph,
        vectors,
        relative_error,
    })
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
