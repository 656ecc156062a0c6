//! A multi-resolution hash encoding (instant-NGP, Müller et al. 2022) as a Burn module: `L`
//! levels of a 3-D grid, level `l` at resolution `N_l = ⌊N_min · b^l⌋` cells per axis, each
//! grid corner owning `F` learned features in a table of at most `T` rows. Coarse levels whose
//! `(N_l + 1)³` corners fit in `T` are indexed densely; finer ones hash a corner `(x, y, z)` to
//! `(x·π₁ ⊕ y·π₂ ⊕ z·π₃) mod T` with `π = (1, 2654435761, 805459861)` (32-bit wrapping), so
//! colliding corners share a row. A point's code is the trilinear blend of its cell's eight
//! corners at every level, concatenated: `[N, L·F]`.
//!
//! Why two paths: methods whose queries never move (Illum's canonical template vertices, the
//! spec's "key fact") precompute the corner rows and trilinear weights once
//! ([`HashGrid::queries`] → [`HashQueries`]) so each step is one gather and a weighted sum,
//! whose backward is a scatter-add into the table. [`HashGrid::encode`] is the general path: the
//! same rows, with the trilinear weights computed as Burn ops of the points, so a loss also
//! reaches the query positions (within a cell; the cell choice itself is piecewise constant).
//! On the CPU both give bit-identical codes. [`hash_grid_reference`] evaluates one point in
//! scalar f64 from the table's values, independently of both, for tests.
//!
//! Points are expected in the unit cube `[0, 1]³`; coordinates outside are clamped to it.

use burn::module::{Module, Param};
use burn::tensor::{Device, Int, Tensor, TensorData};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

/// The spatial-hash primes of instant-NGP, one per axis.
pub const HASH_PRIMES: [u32; 3] = [1, 2_654_435_761, 805_459_861];

/// The shape of a hash encoding; every field trades speed and memory for detail.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct HashGridConfig {
    /// `L`: number of resolution levels.
    pub levels: usize,
    /// `F`: features per level (the code is `L·F` wide).
    pub features: usize,
    /// `log₂ T`: rows of each level's table at most.
    pub log2_table_size: u32,
    /// `N_min`: cells per axis at the coarsest level.
    pub base_resolution: usize,
    /// `b`: the resolution ratio between consecutive levels.
    pub growth: f64,
}

impl Default for HashGridConfig {
    /// A CPU-sized encoder: 16 levels of 2 features, `T = 2¹⁴`, `N_min = 4`, `b = 1.5`
    /// (finest level 1751 cells per axis).
    fn default() -> Self {
        Self {
            levels: 16,
            features: 2,
            log2_table_size: 14,
            base_resolution: 4,
            growth: 1.5,
        }
    }
}

/// One level's place in the concatenated table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LevelLayout {
    /// `N_l`: cells per axis (corners per axis `N_l + 1`).
    pub resolution: usize,
    /// Rows this level owns: `min(T, (N_l + 1)³)`.
    pub rows: usize,
    /// The level's first row in the concatenated table.
    pub first_row: usize,
    /// Whether corners are indexed densely (`(N_l + 1)³ ≤ T`) instead of hashed.
    pub dense: bool,
}

/// Every level's resolution, row count and offset, derived from a [`HashGridConfig`].
#[derive(Debug, Clone, PartialEq)]
pub struct HashGridLayout {
    pub config: HashGridConfig,
    pub levels: Vec<LevelLayout>,
}

impl HashGridLayout {
    pub fn new(config: HashGridConfig) -> Self {
        assert!(config.levels >= 1, "a hash grid needs at least one level");
        assert!(
            config.features >= 1,
            "a hash grid needs at least one feature"
        );
        assert!(
            (1..=24).contains(&config.log2_table_size),
            "log2_table_size {} outside 1..=24",
            config.log2_table_size
        );
        assert!(config.base_resolution >= 1, "base_resolution must be ≥ 1");
        assert!(
            config.growth.is_finite() && config.growth >= 1.0,
            "growth {} must be ≥ 1",
            config.growth
        );
        let table = 1usize << config.log2_table_size;
        let mut first_row = 0;
        let levels = (0..config.levels)
            .map(|l| {
                let resolution =
                    ((config.base_resolution as f64) * config.growth.powi(l as i32)).floor();
                // Beyond ~2²¹ cells per axis the 32-bit hash of a coordinate wraps meaninglessly.
                let resolution = resolution.min((1u64 << 21) as f64) as usize;
                let corners = (resolution as u128 + 1).pow(3);
                let dense = corners <= table as u128;
                let rows = if dense { corners as usize } else { table };
                let level = LevelLayout {
                    resolution,
                    rows,
                    first_row,
                    dense,
                };
                first_row += rows;
                level
            })
            .collect();
        Self { config, levels }
    }

    /// Rows of the concatenated table: `Σ_l min(T, (N_l + 1)³)`.
    pub fn total_rows(&self) -> usize {
        self.levels.iter().map(|l| l.rows).sum()
    }

    /// Learned values: `Σ_l min(T, (N_l + 1)³) · F`.
    pub fn parameter_count(&self) -> usize {
        self.total_rows() * self.config.features
    }

    /// Width of a code: `L · F`.
    pub fn output_width(&self) -> usize {
        self.config.levels * self.config.features
    }
}

impl LevelLayout {
    /// The table row (within the whole table) of corner `(x, y, z)`, each in `0..=N_l`.
    pub fn row(&self, corner: [u32; 3]) -> usize {
        let local = if self.dense {
            let side = self.resolution + 1;
            corner[0] as usize + side * (corner[1] as usize + side * corner[2] as usize)
        } else {
            let hash = (corner[0].wrapping_mul(HASH_PRIMES[0]))
                ^ (corner[1].wrapping_mul(HASH_PRIMES[1]))
                ^ (corner[2].wrapping_mul(HASH_PRIMES[2]));
            hash as usize % self.rows
        };
        self.first_row + local
    }

    /// The cell of a coordinate in `[0, 1]` (clamped) and its fraction within that cell.
    fn cell(&self, coordinate: f32) -> (u32, f32) {
        let scaled = coordinate.clamp(0.0, 1.0) * self.resolution as f32;
        let cell = scaled.floor().min(self.resolution as f32 - 1.0).max(0.0);
        (cell as u32, scaled - cell)
    }
}

/// Corner `c` (bit `k` = offset along axis `k`) of a cell, in the order the weights use.
fn corner_offset(c: usize) -> [u32; 3] {
    [(c & 1) as u32, ((c >> 1) & 1) as u32, ((c >> 2) & 1) as u32]
}

/// Precomputed table rows and trilinear weights of fixed query points: `[N, L·8]` each,
/// level-major, corner-minor.
#[derive(Debug, Clone)]
pub struct HashQueries {
    pub rows: Tensor<2, Int>,
    pub weights: Tensor<2>,
}

impl HashQueries {
    pub fn len(&self) -> usize {
        self.rows.dims()[0]
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// The hash encoding's table, `[Σ_l rows_l, F]`, and its layout.
#[derive(Module, Debug)]
pub struct HashGrid {
    pub table: Param<Tensor<2>>,
    #[module(skip)]
    layout: HashGridLayout,
}

impl HashGrid {
    /// A table initialised uniformly in `±1e-4` (instant-NGP), from `seed`.
    pub fn new(config: HashGridConfig, seed: u64, device: &Device) -> Self {
        let layout = HashGridLayout::new(config);
        let rows = layout.total_rows();
        let mut rng = StdRng::seed_from_u64(seed);
        let values: Vec<f32> = (0..rows * config.features)
            .map(|_| rng.random_range(-1e-4f32..1e-4))
            .collect();
        let table =
            Tensor::<2>::from_data(TensorData::new(values, [rows, config.features]), device);
        Self {
            table: Param::from_tensor(table),
            layout,
        }
    }

    pub fn layout(&self) -> &HashGridLayout {
        &self.layout
    }

    /// Width of a code: `L · F`.
    pub fn output_width(&self) -> usize {
        self.layout.output_width()
    }

    /// Host-side rows and fractions of `[N, 3]` points: per point and level, the eight corner
    /// rows and the cell fractions `(fx, fy, fz)`.
    fn corner_rows(&self, points: &[f32]) -> (Vec<i64>, Vec<f32>) {
        let n = points.len() / 3;
        let levels = &self.layout.levels;
        let mut rows = Vec::with_capacity(n * levels.len() * 8);
        let mut fractions = Vec::with_capacity(n * levels.len() * 3);
        for p in points.chunks_exact(3) {
            for level in levels {
                let cells = [level.cell(p[0]), level.cell(p[1]), level.cell(p[2])];
                for c in 0..8 {
                    let o = corner_offset(c);
                    let corner = [cells[0].0 + o[0], cells[1].0 + o[1], cells[2].0 + o[2]];
                    rows.push(level.row(corner) as i64);
                }
                fractions.extend(cells.iter().map(|&(_, f)| f));
            }
        }
        (rows, fractions)
    }

    /// Precomputes the rows and trilinear weights of fixed `[N, 3]` points in the unit cube.
    pub fn queries(&self, points: Tensor<2>) -> HashQueries {
        let [n, d] = points.dims();
        assert_eq!(d, 3, "hash grid queries must be [N, 3], got [{n}, {d}]");
        let device = points.device();
        let data = host_f32(points);
        let (rows, fractions) = self.corner_rows(&data);
        let levels = self.layout.levels.len();
        let weights: Vec<f32> = fractions
            .chunks_exact(3)
            .flat_map(|f| (0..8).map(move |c| trilinear_weight(c, [f[0], f[1], f[2]])))
            .collect();
        HashQueries {
            rows: Tensor::<2, Int>::from_data(TensorData::new(rows, [n, levels * 8]), &device),
            weights: Tensor::<2>::from_data(TensorData::new(weights, [n, levels * 8]), &device),
        }
    }

    /// Codes `[N, L·F]` of precomputed queries: a gather of `N·L·8` rows and a weighted sum.
    pub fn encode_queries(&self, queries: &HashQueries) -> Tensor<2> {
        let n = queries.len();
        let levels = self.layout.levels.len();
        assert_eq!(
            queries.rows.dims(),
            [n, levels * 8],
            "hash queries were built for another layout"
        );
        self.blend(queries.rows.clone(), queries.weights.clone(), n)
    }

    /// Codes `[N, L·F]` of `[N, 3]` points in the unit cube, differentiable in the table and,
    /// through the trilinear weights, in the points.
    pub fn encode(&self, points: Tensor<2>) -> Tensor<2> {
        let [n, d] = points.dims();
        assert_eq!(d, 3, "hash grid points must be [N, 3], got [{n}, {d}]");
        let device = points.device();
        let (rows, _) = self.corner_rows(&host_f32(points.clone()));
        let levels = self.layout.levels.len();
        let rows = Tensor::<2, Int>::from_data(TensorData::new(rows, [n, levels * 8]), &device);
        // The fraction within each level's cell, as ops: scaled − cell, the cell a constant.
        let clamped = points.clamp(0.0, 1.0);
        let mut per_level = Vec::with_capacity(levels);
        for level in &self.layout.levels {
            let scaled = clamped.clone() * level.resolution as f64;
            let cell = scaled
                .clone()
                .detach()
                .floor()
                .clamp(0.0, level.resolution as f64 - 1.0);
            let fraction = scaled - cell; // [N, 3]
            let axis = |k: usize| fraction.clone().slice([0..n, k..k + 1]);
            let (fx, fy, fz) = (axis(0), axis(1), axis(2));
            let corners: Vec<Tensor<2>> = (0..8)
                .map(|c| {
                    let o = corner_offset(c);
                    let pick = |f: &Tensor<2>, bit: u32| match bit {
                        1 => f.clone(),
                        _ => f.clone().neg().add_scalar(1.0),
                    };
                    pick(&fx, o[0]) * pick(&fy, o[1]) * pick(&fz, o[2])
                })
                .collect();
            per_level.push(Tensor::cat(corners, 1));
        }
        let weights = Tensor::cat(per_level, 1); // [N, L·8]
        self.blend(rows, weights, n)
    }

    fn blend(&self, rows: Tensor<2, Int>, weights: Tensor<2>, n: usize) -> Tensor<2> {
        let levels = self.layout.levels.len();
        let features = self.layout.config.features;
        if n == 0 {
            return Tensor::<2>::zeros([0, levels * features], &self.table.device());
        }
        let gathered = self
            .table
            .val()
            .select(0, rows.reshape([n * levels * 8]))
            .reshape([n, levels, 8, features]);
        (gathered * weights.reshape([n, levels, 8, 1]))
            .sum_dim(2)
            .reshape([n, levels * features])
    }
}

/// The trilinear weight of corner `c` for cell fractions `f`, in the order [`HashGrid`] uses.
fn trilinear_weight(c: usize, f: [f32; 3]) -> f32 {
    let o = corner_offset(c);
    let pick = |fk: f32, bit: u32| if bit == 1 { fk } else { 1.0 - fk };
    pick(f[0], o[0]) * pick(f[1], o[1]) * pick(f[2], o[2])
}

fn host_f32(t: Tensor<2>) -> Vec<f32> {
    t.into_data()
        .convert::<f32>()
        .try_into_vec::<f32>()
        .expect("f32 points")
}

/// The code of one point in scalar f64, from the table's row-major values `[rows, F]`: for
/// each level, the cell of `p · N_l`, its eight corners' rows (dense or hashed), and the
/// trilinear blend, written as directly as possible.
pub fn hash_grid_reference(layout: &HashGridLayout, table: &[f32], point: [f64; 3]) -> Vec<f64> {
    let features = layout.config.features;
    assert_eq!(table.len(), layout.total_rows() * features, "table size");
    let mut code = Vec::with_capacity(layout.output_width());
    for level in &layout.levels {
        let res = level.resolution as f64;
        let mut cell = [0u32; 3];
        let mut frac = [0f64; 3];
        for k in 0..3 {
            let scaled = point[k].clamp(0.0, 1.0) * res;
            let c = scaled.floor().clamp(0.0, res - 1.0);
            cell[k] = c as u32;
            frac[k] = scaled - c;
        }
        let mut out = vec![0f64; features];
        for dx in 0..2u32 {
            for dy in 0..2u32 {
                for dz in 0..2u32 {
                    let (x, y, z) = (cell[0] + dx, cell[1] + dy, cell[2] + dz);
                    let local = if level.dense {
                        let side = level.resolution as u64 + 1;
                        (x as u64 + side * (y as u64 + side * z as u64)) as usize
                    } else {
                        let h = (x as u64 * HASH_PRIMES[0] as u64) as u32
                            ^ (y as u64 * HASH_PRIMES[1] as u64) as u32
                            ^ (z as u64 * HASH_PRIMES[2] as u64) as u32;
                        h as usize % level.rows
                    };
                    let row = level.first_row + local;
                    let w = [dx, dy, dz]
                        .iter()
                        .zip(frac)
                        .map(|(&d, f)| if d == 1 { f } else { 1.0 - f })
                        .product::<f64>();
                    for (o, v) in out
                        .iter_mut()
                        .zip(&table[row * features..(row + 1) * features])
                    {
                        *o += w * *v as f64;
                    }
                }
            }
        }
        code.extend(out);
    }
    code
}
