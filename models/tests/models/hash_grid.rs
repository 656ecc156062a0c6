//! The multi-resolution hash encoding against its scalar f64 reference: the layout's row
//! counts, dense and hashed levels (the coarsest and the finest), hash collisions sharing a
//! row, the precomputed path bit for bit equal to the general one, gradients to the table and
//! to the points against finite differences, continuity across cell faces, and the hash field
//! built on it.

use crate::common::{SplitMix, fresh_seed};
use burn::module::Param;
use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_models::networks::hash_grid::{
    HASH_PRIMES, HashGrid, HashGridConfig, HashGridLayout, hash_grid_reference,
};
use splatzoo_models::networks::hash_mlp::{HashMlp, HashMlpConfig, UnitCube};

fn host<const D: usize>(t: Tensor<D>) -> Vec<f32> {
    t.into_data()
        .convert::<f32>()
        .try_into_vec::<f32>()
        .unwrap()
}

/// Six levels from 2 to 28 cells per axis in a 2⁹-row table: levels 0–1 dense, 2–5 hashed.
fn small_config() -> HashGridConfig {
    HashGridConfig {
        levels: 6,
        features: 3,
        log2_table_size: 9,
        base_resolution: 2,
        growth: 1.7,
    }
}

/// A grid whose table holds values in ±1 (the default ±1e-4 would hide errors).
fn grid_with_values(
    config: HashGridConfig,
    rng: &mut SplitMix,
    device: &Device,
) -> (HashGrid, Vec<f32>) {
    let mut grid = HashGrid::new(config, 7, device);
    let [rows, features] = grid.table.dims();
    let values: Vec<f32> = (0..rows * features)
        .map(|_| (rng.unit() * 2.0 - 1.0) as f32)
        .collect();
    grid.table = Param::from_tensor(Tensor::<2>::from_data(
        TensorData::new(values.clone(), [rows, features]),
        device,
    ));
    (grid, values)
}

fn points_tensor(points: &[[f64; 3]], device: &Device) -> Tensor<2> {
    let flat: Vec<f32> = points.iter().flatten().map(|&v| v as f32).collect();
    Tensor::<2>::from_data(TensorData::new(flat, [points.len(), 3]), device)
}

/// Random points, the cube's corners, a face, and points outside it (clamped).
fn test_points(rng: &mut SplitMix) -> Vec<[f64; 3]> {
    let mut points: Vec<[f64; 3]> = (0..40)
        .map(|_| [rng.unit(), rng.unit(), rng.unit()])
        .collect();
    points.extend([
        [0.0, 0.0, 0.0],
        [1.0, 1.0, 1.0],
        [1.0, 0.5, 0.0],
        [-0.3, 1.4, 0.5],
        [2.0, -1.0, 0.999_999],
    ]);
    points
}

#[test]
fn the_layout_counts_rows_and_switches_from_dense_to_hashed() {
    let layout = HashGridLayout::new(small_config());
    let resolutions: Vec<usize> = layout.levels.iter().map(|l| l.resolution).collect();
    // ⌊2 · 1.7^l⌋.
    assert_eq!(resolutions, vec![2, 3, 5, 9, 16, 28]);
    let dense: Vec<bool> = layout.levels.iter().map(|l| l.dense).collect();
    // (N + 1)³ = 27, 64, 216 fit in 512; 1000 does not.
    assert_eq!(dense, vec![true, true, true, false, false, false]);
    let want: usize = resolutions
        .iter()
        .map(|&n| ((n + 1) * (n + 1) * (n + 1)).min(512))
        .sum();
    assert_eq!(layout.total_rows(), want);
    assert_eq!(layout.parameter_count(), want * 3);
    assert_eq!(layout.output_width(), 18);
    let grid = HashGrid::new(small_config(), 1, &Device::flex());
    assert_eq!(grid.table.dims(), [want, 3]);
    let init = host(grid.table.val());
    assert!(
        init.iter().all(|v| v.abs() <= 1e-4),
        "instant-NGP's ±1e-4 init"
    );
    assert!(init.iter().any(|&v| v != 0.0));
    // The default: 16 levels, the finest ⌊4 · 1.5¹⁵⌋ = 1751 cells.
    let default = HashGridLayout::new(HashGridConfig::default());
    assert_eq!(default.levels.last().unwrap().resolution, 1751);
    assert!(default.levels[0].dense && !default.levels[15].dense);
}

#[test]
fn codes_match_the_scalar_reference_on_dense_and_hashed_levels() {
    let seed = fresh_seed();
    let mut rng = SplitMix(seed);
    let device = Device::flex();
    let (grid, table) = grid_with_values(small_config(), &mut rng, &device);
    let points = test_points(&mut rng);
    let general = host(grid.encode(points_tensor(&points, &device)));
    let queries = grid.queries(points_tensor(&points, &device));
    let fixed = host(grid.encode_queries(&queries));
    let width = grid.output_width();
    for (i, p) in points.iter().enumerate() {
        let want = hash_grid_reference(grid.layout(), &table, *p);
        for k in 0..width {
            let got = general[i * width + k] as f64;
            assert!(
                (got - want[k]).abs() < 2e-5,
                "seed {seed}: point {p:?} column {k}: {got} vs {}",
                want[k]
            );
        }
    }
    assert_eq!(general, fixed, "seed {seed}: the two paths differ");
}

#[test]
fn the_finest_hashed_level_uses_the_literal_hash_and_colliding_corners_share_a_row() {
    let config = small_config();
    let layout = HashGridLayout::new(config);
    let finest = *layout.levels.last().unwrap();
    assert!(!finest.dense);
    // The row of a corner is (x·π₁ ⊕ y·π₂ ⊕ z·π₃) mod T in 32-bit arithmetic.
    let corner = [27u32, 3, 14];
    let hash = ((27u64 * HASH_PRIMES[0] as u64) as u32)
        ^ ((3u64 * HASH_PRIMES[1] as u64) as u32)
        ^ ((14u64 * HASH_PRIMES[2] as u64) as u32);
    assert_eq!(finest.row(corner), finest.first_row + (hash % 512) as usize);
    // Find two distinct corners of the finest level that collide.
    let side = finest.resolution as u32 + 1;
    let mut seen = std::collections::HashMap::new();
    let mut pair = None;
    'search: for z in 0..side {
        for y in 0..side {
            for x in 0..side {
                if let Some(other) = seen.insert(finest.row([x, y, z]), [x, y, z]) {
                    pair = Some((other, [x, y, z]));
                    break 'search;
                }
            }
        }
    }
    let (a, b) = pair.expect("29³ corners in 512 rows collide");
    // Editing the shared row moves the code at both corners (points exactly on the corners).
    let device = Device::flex();
    let mut grid = HashGrid::new(config, 3, &device);
    let n = finest.resolution as f64;
    let at = |c: [u32; 3]| c.map(|v| v as f64 / n);
    let points = points_tensor(&[at(a), at(b)], &device);
    let before = host(grid.encode(points.clone()));
    let [rows, features] = grid.table.dims();
    let row = finest.row(a);
    let mut values = host(grid.table.val());
    values[row * features] += 1.0;
    grid.table = Param::from_tensor(Tensor::<2>::from_data(
        TensorData::new(values, [rows, features]),
        &device,
    ));
    let after = host(grid.encode(points));
    let width = grid.output_width();
    let column = (config.levels - 1) * features;
    for i in 0..2 {
        let moved = after[i * width + column] - before[i * width + column];
        assert!((moved - 1.0).abs() < 1e-6, "corner {i} moved by {moved}");
    }
}

#[test]
fn gradients_reach_the_table_and_the_points_as_finite_differences_say() {
    let seed = fresh_seed();
    let mut rng = SplitMix(seed);
    let device = Device::flex().autodiff();
    let config = small_config();
    let (grid, table) = grid_with_values(config, &mut rng, &device);
    let width = grid.output_width();
    // Points away from every level's cell faces, so the cell stays put under ±h.
    let layout = grid.layout().clone();
    let interior = |p: &[f64; 3]| {
        layout.levels.iter().all(|l| {
            p.iter().all(|&v| {
                let f = v * l.resolution as f64;
                (f - f.round()).abs() > 1e-3
            })
        })
    };
    let points: Vec<[f64; 3]> = std::iter::repeat_with(|| [rng.unit(), rng.unit(), rng.unit()])
        .filter(interior)
        .take(4)
        .collect();
    let probe: Vec<f64> = (0..points.len() * width)
        .map(|_| rng.unit() - 0.5)
        .collect();
    let loss_of = |table: &[f32], points: &[[f64; 3]]| -> f64 {
        points
            .iter()
            .enumerate()
            .map(|(i, p)| {
                hash_grid_reference(&layout, table, *p)
                    .iter()
                    .zip(&probe[i * width..])
                    .map(|(c, r)| c * r)
                    .sum::<f64>()
            })
            .sum()
    };
    let leaf = points_tensor(&points, &device).require_grad();
    let weights = Tensor::<2>::from_data(
        TensorData::new(
            probe.iter().map(|&v| v as f32).collect::<Vec<_>>(),
            [points.len(), width],
        ),
        &device,
    );
    let grads = (grid.encode(leaf.clone()) * weights).sum().backward();
    let table_grad = host(grid.table.val().grad(&grads).expect("a table gradient"));
    let point_grad = host(leaf.grad(&grads).expect("a point gradient"));
    // The loss is linear in the table: one-sided differences are exact up to rounding.
    let mut touched = 0;
    for (row, g) in table_grad.iter().enumerate() {
        if *g == 0.0 && rng.unit() > 0.02 {
            continue;
        }
        let mut bumped = table.clone();
        bumped[row] += 0.5;
        let fd = (loss_of(&bumped, &points) - loss_of(&table, &points)) / 0.5;
        assert!(
            (fd - *g as f64).abs() < 1e-4,
            "seed {seed}: table entry {row}: {g} vs {fd}"
        );
        touched += (*g != 0.0) as usize;
    }
    assert!(touched > 0, "seed {seed}: no table gradient");
    let h = 1e-5;
    for (i, p) in points.iter().enumerate() {
        for k in 0..3 {
            let shifted = |d: f64| {
                let mut q = points.clone();
                q[i][k] = p[k] + d;
                loss_of(&table, &q)
            };
            let fd = (shifted(h) - shifted(-h)) / (2.0 * h);
            let g = point_grad[i * 3 + k] as f64;
            assert!(
                (fd - g).abs() < 1e-2 * (1.0 + fd.abs()),
                "seed {seed}: point {i} axis {k}: {g} vs {fd}"
            );
        }
    }
}

#[test]
fn codes_are_continuous_across_cell_faces_and_equal_a_corner_row_on_a_corner() {
    let seed = fresh_seed();
    let mut rng = SplitMix(seed);
    let device = Device::flex();
    let (grid, table) = grid_with_values(small_config(), &mut rng, &device);
    let layout = grid.layout().clone();
    let coarsest = layout.levels[0];
    // A point on a corner of the coarsest (dense) level reads that corner's row.
    let code = host(grid.encode(points_tensor(&[[0.5, 0.0, 1.0]], &device)));
    let row = coarsest.row([1, 0, 2]);
    for f in 0..3 {
        assert!((code[f] - table[row * 3 + f]).abs() < 1e-6, "seed {seed}");
    }
    // Either side of a face of every level (x = 1/2 is a face of the levels with even N).
    for _ in 0..10 {
        let (y, z) = (rng.unit(), rng.unit());
        let eps = 1e-6;
        let left = hash_grid_reference(&layout, &table, [0.5 - eps, y, z]);
        let right = hash_grid_reference(&layout, &table, [0.5 + eps, y, z]);
        for (a, b) in left.iter().zip(&right) {
            assert!((a - b).abs() < 1e-3, "seed {seed}: {a} vs {b}");
        }
    }
}

#[test]
fn the_hash_field_starts_at_zero_and_its_paths_agree() {
    let device = Device::flex();
    let config = HashMlpConfig {
        grid: small_config(),
        hidden: 2,
        width: 16,
    };
    let zero = HashMlp::new(config, 3, true, 5, &device);
    let points = points_tensor(&[[0.1, 0.2, 0.3], [0.9, 0.5, 0.0]], &device);
    assert!(host(zero.forward(points.clone())).iter().all(|&v| v == 0.0));
    let field = HashMlp::new(config, 2, false, 5, &device);
    let queries = field.grid.queries(points.clone());
    assert_eq!(
        host(field.forward(points)),
        host(field.forward_queries(&queries))
    );
    // The unit cube holds a box with a margin, without stretching it.
    let cube = UnitCube::around(&[[-1.0, 0.0, 2.0], [1.0, 4.0, 2.5]], 1.05).unwrap();
    assert!((cube.size - 4.2).abs() < 1e-12);
    let mapped = host(cube.apply(points_tensor(&[[-1.0, 0.0, 2.0], [1.0, 4.0, 2.5]], &device)));
    assert!(mapped.iter().all(|v| (0.0..=1.0).contains(v)), "{mapped:?}");
    assert!((mapped[4] - mapped[1] - (4.0 / 4.2) as f32).abs() < 1e-6);
    assert!(UnitCube::around(&[], 1.05).is_none());
    assert!(UnitCube::around(&[[f64::NAN, 0.0, 0.0]], 1.05).is_none());
}
