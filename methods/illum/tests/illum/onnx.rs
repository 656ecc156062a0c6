//! The ONNX graphs of F_vis, F_ao, F_m's hash encoding and F_m's network: written with named inputs and outputs,
//! their test vectors beside them, tract's outputs equal to Burn's, and the two material graphs
//! chained equal to F_m from canonical positions.

use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_illum::onnx::{GRAPHS, IllumNetworks, export, material_output};
use splatzoo_illum::shadow::ShadowDecoder;
use splatzoo_illum::visibility::{VisibilityConfig, VisibilityNet};
use splatzoo_models::networks::hash_grid::HashGridConfig;
use splatzoo_models::networks::hash_mlp::{HashMlp, HashMlpConfig, UnitCube};
use splatzoo_train::onnx::{io_names, max_relative_difference, run_graph};

#[test]
fn the_networks_export_and_run_in_tract_as_in_burn() {
    let device = Device::flex();
    let visibility = VisibilityNet::new(
        VisibilityConfig {
            width: 32,
            depth: 3,
            ..VisibilityConfig::default()
        },
        72,
        &device,
    );
    let shadow = ShadowDecoder::new(16, &device);
    let materials = HashMlp::new(
        HashMlpConfig {
            grid: HashGridConfig {
                levels: 4,
                log2_table_size: 10,
                ..HashGridConfig::default()
            },
            hidden: 2,
            width: 16,
        },
        2,
        false,
        3,
        &device,
    );
    let cube = UnitCube {
        min: [-0.6, -0.1, -0.4],
        size: 1.9,
    };
    let dir = tempfile::tempdir().unwrap();
    let graphs = export(
        &IllumNetworks {
            visibility: &visibility,
            shadow: &shadow,
            materials: &materials,
            cube: &cube,
        },
        64,
        dir.path(),
        &device,
    )
    .unwrap();
    assert_eq!(graphs.len(), 4);
    for (graph, (stem, input, output)) in graphs.iter().zip(GRAPHS) {
        assert!(graph.graph.ends_with(format!("{stem}.onnx")));
        assert!(graph.vectors.exists());
        assert!(
            graph.relative_error < 1e-4,
            "{stem}: {}",
            graph.relative_error
        );
        let (inputs, outputs) = io_names(&graph.graph).unwrap();
        assert_eq!(
            (inputs, outputs),
            (vec![input.to_string()], vec![output.to_string()])
        );
    }

    // Chained, the two material graphs are F_m from canonical positions.
    let positions: Vec<f32> = (0..64 * 3)
        .map(|i| [-0.5f32, 0.1, -0.2][i % 3] + 0.013 * (i / 3) as f32)
        .collect();
    let (_, code) = run_graph(&graphs[2].graph, &[64, 3], &positions).unwrap();
    let width = materials.grid.output_width();
    let (shape, material) = run_graph(&graphs[3].graph, &[64, width], &code).unwrap();
    assert_eq!(shape, vec![64, 2]);
    let points = Tensor::<2>::from_data(TensorData::new(positions, [64, 3]), &device);
    let expected = material_output(&materials, materials.grid.encode(cube.apply(points)))
        .into_data()
        .try_into_vec::<f32>()
        .unwrap();
    let difference = max_relative_difference(&material, &expected);
    assert!(difference < 1e-5, "{difference}");
}
