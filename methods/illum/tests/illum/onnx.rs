//! The ONNX graphs of F_vis, F_ao and F_m's network: written with named inputs and outputs,
//! their test vectors beside them, and tract's outputs equal to Burn's.

use burn::tensor::Device;
use splatzoo_illum::onnx::{GRAPHS, IllumNetworks, export};
use splatzoo_illum::shadow::ShadowDecoder;
use splatzoo_illum::visibility::{VisibilityConfig, VisibilityNet};
use splatzoo_models::networks::hash_grid::HashGridConfig;
use splatzoo_models::networks::hash_mlp::{HashMlp, HashMlpConfig};
use splatzoo_train::onnx::io_names;

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
    let dir = tempfile::tempdir().unwrap();
    let graphs = export(
        &IllumNetworks {
            visibility: &visibility,
            shadow: &shadow,
            materials: &materials,
        },
        64,
        dir.path(),
        &device,
    )
    .unwrap();
    assert_eq!(graphs.len(), 3);
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
}
