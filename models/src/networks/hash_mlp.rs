//! A hash-encoded field: a [`HashGrid`] code followed by a small ReLU MLP and a linear head
//! (instant-NGP's "fully fused" network, here plain Burn layers), and [`UnitCube`], the affine
//! map that brings a bounding box into the grid's unit cube. The head's output is raw; each
//! caller applies its own activation (Illum's F_Δ is linear and starts at zero, F_c and F_m
//! are sigmoids).

use super::hash_grid::{HashGrid, HashGridConfig, HashQueries};
use super::mlp::head;
use burn::module::Module;
use burn::nn::{Linear, LinearConfig};
use burn::tensor::activation::relu;
use burn::tensor::{Device, Tensor, TensorData};

/// The shape of a [`HashMlp`]: its encoder and `hidden` ReLU layers of `width`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct HashMlpConfig {
    pub grid: HashGridConfig,
    pub hidden: usize,
    pub width: usize,
}

impl Default for HashMlpConfig {
    /// The CPU-sized encoder and two hidden layers of 64 (iHuman's heads).
    fn default() -> Self {
        Self {
            grid: HashGridConfig::default(),
            hidden: 2,
            width: 64,
        }
    }
}

#[derive(Module, Debug)]
pub struct HashMlp {
    pub grid: HashGrid,
    pub hidden: Vec<Linear>,
    pub head: Linear,
}

impl HashMlp {
    /// `outputs` raw values per point; `zero_head` starts them at exactly zero.
    pub fn new(
        config: HashMlpConfig,
        outputs: usize,
        zero_head: bool,
        seed: u64,
        device: &Device,
    ) -> Self {
        let grid = HashGrid::new(config.grid, seed, device);
        let mut fan_in = grid.output_width();
        let hidden = (0..config.hidden)
            .map(|_| {
                let layer = LinearConfig::new(fan_in, config.width).init(device);
                fan_in = config.width;
                layer
            })
            .collect();
        Self {
            grid,
            hidden,
            head: head(fan_in, outputs, zero_head, device),
        }
    }

    /// `[N, outputs]` at precomputed fixed queries.
    pub fn forward_queries(&self, queries: &HashQueries) -> Tensor<2> {
        self.forward_code(self.grid.encode_queries(queries))
    }

    /// `[N, outputs]` at `[N, 3]` points in the unit cube.
    pub fn forward(&self, points: Tensor<2>) -> Tensor<2> {
        self.forward_code(self.grid.encode(points))
    }

    /// `[N, outputs]` from hash codes `[N, L·F]`: the MLP and head alone (what an ONNX graph
    /// of the field's network takes, the encoding done outside it).
    pub fn forward_code(&self, code: Tensor<2>) -> Tensor<2> {
        let x = self
            .hidden
            .iter()
            .fold(code, |x, layer| relu(layer.forward(x)));
        self.head.forward(x)
    }
}

/// The map `p ↦ (p − min) / size` of a cube holding a bounding box, so the box lands inside
/// `[0, 1]³` with room to move.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UnitCube {
    pub min: [f64; 3],
    /// The cube's side (one for all axes, so shapes are not stretched).
    pub size: f64,
}

impl UnitCube {
    /// The cube centred on the bounding box of `points`, its side the box's longest side times
    /// `margin` (≥ 1; iHuman uses 1.05). `None` for no points or non-finite ones.
    pub fn around(points: &[[f64; 3]], margin: f64) -> Option<Self> {
        if points.is_empty() || points.iter().flatten().any(|v| !v.is_finite()) {
            return None;
        }
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in points {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let longest = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
        let size = (longest * margin.max(1.0)).max(1e-9);
        let min = std::array::from_fn(|k| 0.5 * (lo[k] + hi[k]) - 0.5 * size);
        Some(Self { min, size })
    }

    /// `[N, 3]` points mapped into the cube's unit coordinates.
    pub fn apply(&self, points: Tensor<2>) -> Tensor<2> {
        let device = points.device();
        let min = Tensor::<2>::from_data(
            TensorData::new(self.min.map(|v| v as f32).to_vec(), [1, 3]),
            &device,
        );
        (points - min) / self.size
    }
}
