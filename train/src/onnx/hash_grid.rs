//! The ONNX graph of a multi-resolution hash encoding ([`HashGrid::encode`]), written node by
//! node: burn-onnx 0.22 cannot trace it (the corner rows are computed on the host, and its
//! graphs have fixed row counts), so the graph is built here with the protobuf bindings
//! burn-onnx encodes with, at opset 18, and checked in tract like every other export.
//!
//! `positions` `[R, 3]` (R symbolic: any row count) → `code` `[R, L·F]`. The graph first maps
//! the method's coordinates into the grid's unit cube (`(p − min) / size`, [`UnitCube`]), then,
//! per level `l` (resolution `N_l`, the table an initializer):
//!
//! ```text
//! s = clip(p, 0, 1) · N_l            c = clip(⌊s⌋, 0, N_l − 1)        f = s − c
//! corner_k = int64(c) + o_k          (o_k the 8 offsets, bit j of k along axis j)
//! dense:  row = x + (N_l+1)·y + (N_l+1)²·z
//! hashed: row = (x·π₁ ⊕ y·π₂ ⊕ z·π₃) mod T     (int64 products: x ≤ 2²¹ and π < 2³², so no
//!         overflow; T = 2^k divides 2³², so the 32-bit wrap of the Rust code changes no row)
//! code_l = Σ_k Π_j (o_kj ? f_j : 1 − f_j) · table[first_row_l + row_k]
//! ```
//!
//! and concatenates the levels. BitwiseXor is ONNX opset 18; tract and onnxruntime run it.

use super::{ExportedGraph, OnnxError, verify, write_vectors};
use burn::tensor::Tensor;
use onnx_ir::AttributeType;
use onnx_ir::{AttributeProto, GraphProto, Message, ModelProto, NodeProto, TensorProto};
use onnx_ir::{TypeProto, ValueInfoProto};
use splatzoo_models::networks::hash_grid::{HASH_PRIMES, HashGrid, LevelLayout};
use splatzoo_models::networks::hash_mlp::UnitCube;
use std::path::Path;

/// ONNX `TensorProto.DataType` codes.
const FLOAT: i32 = 1;
const INT64: i32 = 7;
const UINT64: i32 = 13;
/// The opset whose `BitwiseXor` and axis-input reductions the graph uses, and its IR version.
const OPSET: i64 = 18;
const IR_VERSION: i64 = 8;

/// Nodes and initializers, each value named `v<n>` in the order made.
struct Builder {
    graph: GraphProto,
    values: usize,
}

impl Builder {
    fn fresh(&mut self) -> String {
        self.values += 1;
        format!("v{}", self.values)
    }

    /// One node of `op` on `inputs` with `attributes`; its one output's name.
    fn node(&mut self, op: &str, inputs: &[&str], attributes: Vec<AttributeProto>) -> String {
        let output = self.fresh();
        self.node_into(op, inputs, attributes, output)
    }

    /// [`Self::node`] whose output is named `output`.
    fn node_into(
        &mut self,
        op: &str,
        inputs: &[&str],
        attributes: Vec<AttributeProto>,
        output: String,
    ) -> String {
        let mut node = NodeProto::new();
        node.op_type = op.to_owned();
        node.name = format!("{op}_{}", self.values);
        node.input = inputs.iter().map(|&s| s.to_owned()).collect();
        node.output = vec![output.clone()];
        node.attribute = attributes;
        self.graph.node.push(node);
        output
    }

    /// An initializer of `data_type` and shape `dims` from its values' little-endian bytes
    /// (`raw_data`, which every reader takes: tract 0.23.9 reads a uint64 initializer's numbers
    /// from `int64_data`, the ONNX spec from `uint64_data`).
    fn initializer<const N: usize>(
        &mut self,
        data_type: i32,
        dims: &[usize],
        values: impl ExactSizeIterator<Item = [u8; N]>,
    ) -> String {
        assert_eq!(
            dims.iter().product::<usize>(),
            values.len(),
            "initializer shape"
        );
        let name = self.fresh();
        let mut tensor = TensorProto::new();
        tensor.name = name.clone();
        tensor.data_type = data_type;
        tensor.dims = dims.iter().map(|&d| d as i64).collect();
        tensor.raw_data = values.flatten().collect::<Vec<u8>>().into();
        self.graph.initializer.push(tensor);
        name
    }

    fn floats(&mut self, dims: &[usize], values: &[f32]) -> String {
        self.initializer(FLOAT, dims, values.iter().map(|v| v.to_le_bytes()))
    }

    fn ints(&mut self, dims: &[usize], values: &[i64]) -> String {
        self.initializer(INT64, dims, values.iter().map(|v| v.to_le_bytes()))
    }

    fn unsigned(&mut self, dims: &[usize], values: &[u64]) -> String {
        self.initializer(UINT64, dims, values.iter().map(|v| v.to_le_bytes()))
    }

    fn scalar(&mut self, value: f32) -> String {
        self.floats(&[], &[value])
    }
}

fn int_attribute(name: &str, value: i64) -> AttributeProto {
    let mut attribute = AttributeProto::new();
    attribute.name = name.to_owned();
    attribute.type_ = AttributeType::INT.into();
    attribute.i = value;
    attribute
}

/// A float tensor value `[rows, width]`, `rows` symbolic.
fn rows_value(name: &str, width: usize) -> ValueInfoProto {
    let mut kind = TypeProto::new();
    let tensor = kind.mut_tensor_type();
    tensor.elem_type = FLOAT;
    let shape = tensor.shape.mut_or_insert_default();
    shape.dim.push(Default::default());
    shape.dim[0].set_dim_param("rows".to_owned());
    shape.dim.push(Default::default());
    shape.dim[1].set_dim_value(width as i64);
    let mut value = ValueInfoProto::new();
    value.name = name.to_owned();
    value.type_ = Some(kind).into();
    value
}

/// Corner `k`'s offset along each axis (bit `j` of `k` along axis `j`), as [`HashGrid`] orders
/// them: `[8, 3]`.
fn corner_offsets() -> [[i64; 3]; 8] {
    std::array::from_fn(|k| [(k & 1) as i64, ((k >> 1) & 1) as i64, ((k >> 2) & 1) as i64])
}

/// One level's code `[R, F]` of unit-cube points `unit` `[R, 3]`.
fn level_code(b: &mut Builder, unit: &str, level: &LevelLayout, table: &str) -> String {
    let resolution = level.resolution as f32;
    let n = b.scalar(resolution);
    let scaled = b.node("Mul", &[unit, &n], vec![]);
    let floor = b.node("Floor", &[&scaled], vec![]);
    let (zero, top) = (b.scalar(0.0), b.scalar(resolution - 1.0));
    let cell = b.node("Clip", &[&floor, &zero, &top], vec![]);
    let fraction = b.node("Sub", &[&scaled, &cell], vec![]);

    // The eight corners' table rows: [R, 8].
    let cell_index = b.node("Cast", &[&cell], vec![int_attribute("to", INT64.into())]);
    let axis_one = b.ints(&[1], &[1]);
    let cell_index = b.node("Unsqueeze", &[&cell_index, &axis_one], vec![]); // [R, 1, 3]
    let offsets: Vec<i64> = corner_offsets().concat();
    let offsets_value = b.ints(&[8, 3], &offsets);
    let corners = b.node("Add", &[&cell_index, &offsets_value], vec![]); // [R, 8, 3]
    let axis_two = b.ints(&[1], &[2]);
    let local = if level.dense {
        let side = level.resolution as i64 + 1;
        let strides = b.ints(&[3], &[1, side, side * side]);
        let weighted = b.node("Mul", &[&corners, &strides], vec![]);
        b.node(
            "ReduceSum",
            &[&weighted, &axis_two],
            vec![int_attribute("keepdims", 0)],
        )
    } else {
        // In uint64: tract reads int64 arithmetic as shape arithmetic, which has no XOR.
        let to_unsigned = vec![int_attribute("to", UINT64.into())];
        let corners = b.node("Cast", &[&corners], to_unsigned);
        let primes = b.unsigned(&[3], &HASH_PRIMES.map(u64::from));
        let products = b.node("Mul", &[&corners, &primes], vec![]);
        let axis = |b: &mut Builder, k: i64| {
            let index = b.ints(&[], &[k]);
            b.node(
                "Gather",
                &[&products, &index],
                vec![int_attribute("axis", 2)],
            )
        };
        let (x, y, z) = (axis(b, 0), axis(b, 1), axis(b, 2));
        let xy = b.node("BitwiseXor", &[&x, &y], vec![]);
        let hash = b.node("BitwiseXor", &[&xy, &z], vec![]);
        let modulus = b.unsigned(&[], &[level.rows as u64]);
        let local = b.node("Mod", &[&hash, &modulus], vec![]);
        b.node("Cast", &[&local], vec![int_attribute("to", INT64.into())])
    };
    let first_row = b.ints(&[], &[level.first_row as i64]);
    let rows = b.node("Add", &[&local, &first_row], vec![]);
    let gathered = b.node("Gather", &[table, &rows], vec![int_attribute("axis", 0)]); // [R, 8, F]

    // The trilinear weights: [R, 8, 1].
    let picks: Vec<f32> = offsets.iter().map(|&o| o as f32).collect();
    let pick = b.floats(&[8, 3], &picks);
    let unpicked: Vec<f32> = picks.iter().map(|p| 1.0 - p).collect();
    let unpick = b.floats(&[8, 3], &unpicked);
    let fraction = b.node("Unsqueeze", &[&fraction, &axis_one], vec![]); // [R, 1, 3]
    let one = b.scalar(1.0);
    let rest = b.node("Sub", &[&one, &fraction], vec![]);
    let near = b.node("Mul", &[&pick, &fraction], vec![]);
    let far = b.node("Mul", &[&unpick, &rest], vec![]);
    let per_axis = b.node("Add", &[&near, &far], vec![]); // [R, 8, 3]
    let weights = b.node(
        "ReduceProd",
        &[&per_axis, &axis_two],
        vec![int_attribute("keepdims", 1)],
    );
    let weighted = b.node("Mul", &[&gathered, &weights], vec![]);
    b.node(
        "ReduceSum",
        &[&weighted, &axis_one],
        vec![int_attribute("keepdims", 0)],
    )
}

/// The serialized ONNX model of `grid.encode(cube.apply(p))` (the cube map left out for
/// `None`: the input is then already in the unit cube): graph input `input` `[R, 3]`, output
/// `output` `[R, L·F]`, `R` symbolic, the table an initializer.
pub fn hash_grid_model(
    grid: &HashGrid,
    cube: Option<&UnitCube>,
    input: &str,
    output: &str,
) -> Result<Vec<u8>, String> {
    let layout = grid.layout();
    let features = layout.config.features;
    let values = grid
        .table
        .val()
        .into_data()
        .convert::<f32>()
        .try_into_vec::<f32>()
        .map_err(|e| format!("reading the hash table: {e:?}"))?;
    let mut b = Builder {
        graph: GraphProto::new(),
        values: 0,
    };
    b.graph.name = "hash_grid".to_owned();
    let table = b.floats(&[layout.total_rows(), features], &values);

    let mut unit = input.to_owned();
    if let Some(cube) = cube {
        let min = b.floats(&[1, 3], &cube.min.map(|v| v as f32));
        let size = b.scalar(cube.size as f32);
        let shifted = b.node("Sub", &[&unit, &min], vec![]);
        unit = b.node("Div", &[&shifted, &size], vec![]);
    }
    let (zero, one) = (b.scalar(0.0), b.scalar(1.0));
    let clamped = b.node("Clip", &[&unit, &zero, &one], vec![]);
    let codes: Vec<String> = layout
        .levels
        .iter()
        .map(|level| level_code(&mut b, &clamped, level, &table))
        .collect();
    let codes: Vec<&str> = codes.iter().map(String::as_str).collect();
    b.node_into(
        "Concat",
        &codes,
        vec![int_attribute("axis", 1)],
        output.to_owned(),
    );

    b.graph.input = vec![rows_value(input, 3)];
    b.graph.output = vec![rows_value(output, layout.output_width())];
    let mut model = ModelProto::new();
    model.ir_version = IR_VERSION;
    model.producer_name = "splatzoo".to_owned();
    model.opset_import.push(Default::default());
    model.opset_import[0].version = OPSET;
    model.graph = Some(b.graph).into();
    model
        .write_to_bytes()
        .map_err(|e| format!("encoding the ONNX model: {e}"))
}

/// Writes `dir/<stem>.onnx`, the graph of `grid.encode(cube.apply(p))` ([`hash_grid_model`]),
/// and `dir/<stem>.vectors.safetensors` (each sample `[R, 3]`, any `R`, and Burn's code for
/// it), and checks the graph on them in tract.
pub fn export_hash_grid(
    grid: &HashGrid,
    cube: Option<&UnitCube>,
    samples: &[Tensor<2>],
    (stem, input, output): (&str, &str, &str),
    dir: &Path,
) -> Result<ExportedGraph, OnnxError> {
    std::fs::create_dir_all(dir)
        .map_err(|e| OnnxError::new(dir, format!("cannot create ({e})")))?;
    let graph = dir.join(format!("{stem}.onnx"));
    let vectors = dir.join(format!("{stem}.vectors.safetensors"));
    if samples.is_empty() {
        return Err(OnnxError::new(&graph, "no sample inputs to export with"));
    }
    let bytes =
        hash_grid_model(grid, cube, input, output).map_err(|e| OnnxError::new(&graph, e))?;
    splatzoo_models::files::write_bytes(&graph, &bytes)
        .map_err(|e| OnnxError::new(&graph, format!("cannot write ({e})")))?;
    let pairs: Vec<(Tensor<2>, Tensor<2>)> = samples
        .iter()
        .map(|p| {
            let unit = cube.map_or_else(|| p.clone(), |c| c.apply(p.clone()));
            (p.clone(), grid.encode(unit))
        })
        .collect();
    write_vectors(&vectors, input, output, &pairs)?;
    let relative_error = verify(&graph, &vectors)?;
    Ok(ExportedGraph {
        graph,
        vectors,
        relative_error,
    })
}
