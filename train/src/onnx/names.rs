//! Naming an exported graph's inputs and outputs for what they are. burn-onnx 0.22.0 names
//! every runtime value `tensor_<id>` and hands back only the serialised bytes, so the bytes are
//! decoded with the protobuf bindings burn-onnx encoded them with (`onnx_ir::ModelProto`),
//! every reference to the old names is rewritten, and the model is encoded again. Graph inputs
//! are in the order the forward closure takes them, outputs in the order it returns them.
//! [`run_graph_named`] runs a graph in tract feeding inputs by name.

use onnx_ir::{GraphProto, Message, ModelProto};
use std::collections::{HashMap, HashSet};
use std::path::Path;
use tract_onnx::prelude::{
    Datum, Framework, InferenceFact, InferenceModelExt, IntoRunnable, IntoTValue, TValue, TVec,
    Tensor as TractTensor,
};

/// Renames the graph inputs of the serialized ONNX model `bytes` to `inputs` and its graph
/// outputs to `outputs` (positionally, in graph order: burn-onnx writes the inputs in the order
/// the forward closure takes them and the outputs in the order it returns them), rewriting
/// every node input/output, `value_info` entry and subgraph reference to them. Returns the
/// re-serialized model.
///
/// Fails when the counts differ, a new name is empty or given twice, a new name is already
/// used by another value of the graph (an initializer named after a module parameter, say),
/// or one value is several of the graph's inputs/outputs (which a rename cannot split).
pub fn rename_graph_io(bytes: &[u8], inputs: &[&str], outputs: &[&str]) -> Result<Vec<u8>, String> {
    let mut model =
        ModelProto::parse_from_bytes(bytes).map_err(|e| format!("decoding the ONNX model: {e}"))?;
    let graph = model
        .graph
        .as_mut()
        .ok_or_else(|| "the ONNX model has no graph".to_string())?;
    if graph.input.len() != inputs.len() || graph.output.len() != outputs.len() {
        return Err(format!(
            "the graph has {} inputs and {} outputs; {} and {} names were given",
            graph.input.len(),
            graph.output.len(),
            inputs.len(),
            outputs.len()
        ));
    }

    let mut fresh = HashSet::new();
    for &name in inputs.iter().chain(outputs) {
        if name.is_empty() || !fresh.insert(name) {
            return Err(format!(
                "graph input/output name `{name}` is empty or repeated"
            ));
        }
    }
    let mut renames = HashMap::<String, String>::new();
    for (info, &new) in graph
        .input
        .iter()
        .zip(inputs)
        .chain(graph.output.iter().zip(outputs))
    {
        if renames.insert(info.name.clone(), new.to_string()).is_some() {
            return Err(format!(
                "value `{}` is more than one graph input/output; it cannot take two names",
                info.name
            ));
        }
    }
    let mut existing = HashSet::new();
    collect_names(graph, &mut existing);
    for &name in &fresh {
        // Free, or itself one of the names being renamed away (the renaming is simultaneous).
        if existing.contains(name) && !renames.contains_key(name) {
            return Err(format!("`{name}` already names another value of the graph"));
        }
    }

    rename_in_graph(graph, &renames);
    model
        .write_to_bytes()
        .map_err(|e| format!("encoding the ONNX model: {e}"))
}

/// The graph's input and output names, in graph order.
pub fn graph_io_names(bytes: &[u8]) -> Result<(Vec<String>, Vec<String>), String> {
    let model =
        ModelProto::parse_from_bytes(bytes).map_err(|e| format!("decoding the ONNX model: {e}"))?;
    let graph = model
        .graph
        .as_ref()
        .ok_or_else(|| "the ONNX model has no graph".to_string())?;
    Ok((
        graph.input.iter().map(|info| info.name.clone()).collect(),
        graph.output.iter().map(|info| info.name.clone()).collect(),
    ))
}

/// Every value name `graph` and its subgraphs mention.
fn collect_names(graph: &GraphProto, names: &mut HashSet<String>) {
    for info in graph
        .input
        .iter()
        .chain(&graph.output)
        .chain(&graph.value_info)
    {
        names.insert(info.name.clone());
    }
    for tensor in &graph.initializer {
        names.insert(tensor.name.clone());
    }
    for node in &graph.node {
        for name in node.input.iter().chain(&node.output) {
            if !name.is_empty() {
                names.insert(name.clone());
            }
        }
        for attribute in &node.attribute {
            if let Some(subgraph) = attribute.g.as_ref() {
                collect_names(subgraph, names);
            }
            for subgraph in &attribute.graphs {
                collect_names(subgraph, names);
            }
        }
    }
}

/// Applies `renames` to every value reference in `graph`, recursing into subgraphs (ONNX names
/// are unique across nested scopes, so a subgraph can only mean the outer value).
fn rename_in_graph(graph: &mut GraphProto, renames: &HashMap<String, String>) {
    let apply = |name: &mut String| {
        if let Some(new) = renames.get(name.as_str()) {
            *name = new.clone();
        }
    };
    for info in graph
        .input
        .iter_mut()
        .chain(graph.output.iter_mut())
        .chain(graph.value_info.iter_mut())
    {
        apply(&mut info.name);
    }
    // An input may also be an initializer (a default value); burn-onnx never writes one.
    for tensor in graph.initializer.iter_mut() {
        apply(&mut tensor.name);
    }
    for annotation in graph.quantization_annotation.iter_mut() {
        apply(&mut annotation.tensor_name);
    }
    for node in graph.node.iter_mut() {
        for name in node.input.iter_mut().chain(node.output.iter_mut()) {
            apply(name);
        }
        for attribute in node.attribute.iter_mut() {
            if let Some(subgraph) = attribute.g.as_mut() {
                rename_in_graph(subgraph, renames);
            }
            for subgraph in attribute.graphs.iter_mut() {
                rename_in_graph(subgraph, renames);
            }
        }
    }
}

/// A loaded tract model's input and output names, in the order `SimplePlan::run` takes and
/// gives values (see [`run_graph_named`]); read before `into_optimized`.
pub fn tract_io_names(
    model: &tract_onnx::prelude::InferenceModel,
) -> tract_onnx::prelude::TractResult<(Vec<String>, Vec<String>)> {
    let inputs = model
        .input_outlets()?
        .iter()
        .map(|outlet| model.node(outlet.node).name.clone())
        .collect();
    let outputs = model
        .output_outlets()?
        .iter()
        .map(|&outlet| {
            model
                .outlet_label(outlet)
                .map(str::to_owned)
                .unwrap_or_else(|| model.node(outlet.node).name.clone())
        })
        .collect();
    Ok((inputs, outputs))
}

/// One named f32 tensor: name, shape, values.
pub type Named = (String, Vec<usize>, Vec<f32>);

/// Runs the ONNX graph at `path` in tract, feeding each graph input by name from `inputs`
/// (name, shape, values; the shapes resolve any symbolic axis) and returning every output with
/// its graph name, in graph order.
///
/// tract's model inputs are the graph's `input` entries in order, each a source node named
/// after it (tract-onnx-0.23.9 `src/model.rs` 81–104), and its outputs the graph's `output`
/// entries in order, each outlet labelled with its name (189–192); `SimplePlan::run` takes and
/// gives values in that order. Names are read before `into_optimized`.
pub fn run_graph_named(
    path: &Path,
    inputs: &[(&str, &[usize], &[f32])],
) -> Result<Vec<Named>, String> {
    let fail = |e: tract_onnx::prelude::TractError| format!("{}: {e:#}", path.display());
    let mut model = tract_onnx::onnx().model_for_path(path).map_err(fail)?;
    let (input_names, output_names) = tract_io_names(&model).map_err(fail)?;
    if let Some((name, ..)) = inputs
        .iter()
        .find(|(name, ..)| !input_names.iter().any(|n| n == name))
    {
        return Err(format!(
            "{}: no graph input `{name}` (inputs: {input_names:?})",
            path.display()
        ));
    }
    let mut values: TVec<TValue> = TVec::new();
    for (ix, name) in input_names.iter().enumerate() {
        let &(_, shape, data) = inputs
            .iter()
            .find(|(given, ..)| given == name)
            .ok_or_else(|| format!("{}: graph input `{name}` not given", path.display()))?;
        model
            .set_input_fact(ix, InferenceFact::dt_shape(f32::datum_type(), shape))
            .map_err(fail)?;
        values.push(
            TractTensor::from_shape(shape, data)
                .map_err(fail)?
                .into_tvalue(),
        );
    }
    let plan = model
        .into_optimized()
        .map_err(fail)?
        .into_runnable()
        .map_err(fail)?;
    let outputs = plan.run(values).map_err(fail)?;
    output_names
        .into_iter()
        .zip(outputs.iter())
        .map(|(name, value)| -> Result<Named, String> {
            let view = value.to_plain_array_view::<f32>().map_err(fail)?;
            Ok((name, view.shape().to_vec(), view.iter().copied().collect()))
        })
        .collect()
}
