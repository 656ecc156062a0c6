//! The hand-written ONNX graph of the hash encoding, run in tract, against Burn's
//! `HashGrid::encode` and the scalar f64 reference: dense and hashed levels, colliding corners,
//! points outside the cube and on its faces, the cube map folded in, any row count, a finest
//! level at the 2²¹-cell cap (int64 products near 2⁵³), and a clear error for no samples.

use crate::losses_and_ply::fresh_seed;
use burn::module::Param;
use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_datasets::synth::rng::Rng;
use splatzoo_models::networks::hash_grid::{HashGrid, HashGridConfig, hash_grid_reference};
use splatzoo_models::networks::hash_mlp::UnitCube;
use splatzoo_train::onnx::{export_hash_grid, io_names, run_graph};

/// A grid whose table holds values in ±1 (the default ±1e-4 would hide errors).
fn grid_with_values(
    config: HashGridConfig,
    rng: &mut Rng,
    device: &Device,
) -> (HashGrid, Vec<f32>) {
    let mut grid = HashGrid::new(config, 3, device);
    let [rows, features] = grid.table.dims();
    let values: Vec<f32> = (0..rows * features)
        .map(|_| (rng.next() * 2.0 - 1.0) as f32)
        .collect();
    grid.table = Param::from_tensor(Tensor::<2>::from_data(
        TensorData::new(values.clone(), [rows, features]),
        device,
    ));
    (grid, values)
}

/// `count` random points of the box `[lo, hi]³`, then the cube's corners and a point on each
/// face.
fn points(rng: &mut Rng, count: usize, lo: f64, hi: f64) -> Vec<[f64; 3]> {
    let mut points: Vec<[f64; 3]> = (0..count)
        .map(|_| std::array::from_fn(|_| lo + (hi - lo) * rng.next()))
        .collect();
    points.extend([
        [0.0, 0.0, 0.0],
        [1.0, 1.0, 1.0],
        [0.0, 0.5, 1.0],
        [1.0, 0.25, 0.0],
    ]);
    points
}

fn tensor(points: &[[f64; 3]], device: &Device) -> Tensor<2> {
    let flat: Vec<f32> = points.iter().flatten().map(|&v| v as f32).collect();
    Tensor::<2>::from_data(TensorData::new(flat, [points.len(), 3]), device)
}

/// Six levels, 2 to 28 cells per axis, in a 2⁹-row table: levels 0–1 dense, 2–5 hashed (where
/// corners collide).
fn small_config() -> HashGridConfig {
    HashGridConfig {
        levels: 6,
        features: 3,
        log2_table_size: 9,
        base_resolution: 2,
        growth: 1.7,
    }
}

#[test]
fn the_hash_grid_graph_matches_burn_and_the_f64_reference() {
    let device = Device::flex();
    let mut rng = Rng(fresh_seed());
    let (grid, table) = grid_with_values(small_config(), &mut rng, &device);
    let layout = grid.layout();
    assert!(layout.levels.iter().any(|l| l.dense) && layout.levels.iter().any(|l| !l.dense));
    let dir = tempfile::tempdir().unwrap();

    // Unit-cube inputs, some outside it (clamped), at two row counts (the axis is symbolic).
    let (a, b) = (
        points(&mut rng, 37, -0.2, 1.2),
        points(&mut rng, 5, 0.0, 1.0),
    );
    let exported = export_hash_grid(
        &grid,
        None,
        &[tensor(&a, &device), tensor(&b, &device)],
        ("code", "positions", "code"),
        dir.path(),
    )
    .unwrap();
    assert!(
        exported.relative_error < 1e-5,
        "{}",
        exported.relative_error
    );
    let (inputs, outputs) = io_names(&exported.graph).unwrap();
    assert_eq!(
        (inputs, outputs),
        (vec!["positions".into()], vec!["code".into()])
    );

    // The graph's values against the f64 reference, point by point.
    let flat: Vec<f32> = a.iter().flatten().map(|&v| v as f32).collect();
    let (shape, got) = run_graph(&exported.graph, &[a.len(), 3], &flat).unwrap();
    let width = layout.output_width();
    assert_eq!(shape, vec![a.len(), width]);
    for (i, p) in a.iter().enumerate() {
        let reference = hash_grid_reference(layout, &table, p.map(|v| v as f32 as f64));
        for (k, r) in reference.iter().enumerate() {
            let g = got[i * width + k] as f64;
            assert!(
                (g - r).abs() < 1e-5 * (1.0 + r.abs()),
                "point {i} column {k}: {g} vs {r}"
            );
        }
    }

    // The cube map folded in: world points give the code of their unit-cube images.
    let cube = UnitCube {
        min: [-0.8, 0.3, -1.5],
        size: 2.5,
    };
    let world: Vec<[f64; 3]> = (0..23)
        .map(|_| std::array::from_fn(|k| cube.min[k] - 0.1 + 2.7 * rng.next()))
        .collect();
    let mapped = export_hash_grid(
        &grid,
        Some(&cube),
        &[tensor(&world, &device)],
        ("cube", "canonical_positions", "code"),
        dir.path(),
    )
    .unwrap();
    assert!(mapped.relative_error < 1e-5, "{}", mapped.relative_error);

    let none = export_hash_grid(&grid, None, &[], ("empty", "p", "c"), dir.path());
    let e = none.unwrap_err().to_string();
    assert!(e.contains("empty.onnx") && e.contains("no sample"), "{e}");
}

/// The finest level at the 2²¹-cell cap hashes corners whose products with π₂ near 2⁵³: the
/// graph's int64 arithmetic must give Burn's rows, and a dense coarsest level of one cell.
#[test]
fn the_hash_grid_graph_holds_at_the_coarsest_and_finest_levels() {
    let device = Device::flex();
    let mut rng = Rng(fresh_seed());
    let config = HashGridConfig {
        levels: 5,
        features: 2,
        log2_table_size: 12,
        base_resolution: 1,
        growth: 60.0,
    };
    let (grid, _) = grid_with_values(config, &mut rng, &device);
    let levels = &grid.layout().levels;
    assert_eq!(levels[0].resolution, 1);
    assert_eq!(levels[4].resolution, 1 << 21);
    let dir = tempfile::tempdir().unwrap();
    let near_top = points(&mut rng, 30, 0.999, 1.0);
    let exported = export_hash_grid(
        &grid,
        None,
        &[
            tensor(&points(&mut rng, 30, 0.0, 1.0), &device),
            tensor(&near_top, &device),
        ],
        ("extremes", "positions", "code"),
        dir.path(),
    )
    .unwrap();
    assert!(
        exported.relative_error < 1e-5,
        "{}",
        exported.relative_error
    );
}
