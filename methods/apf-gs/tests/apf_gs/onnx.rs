//! The ONNX graphs of `C`, `F_φ` and `D_ψ` (A15): named inputs and outputs, test vectors, and
//! tract reproducing Burn.

use burn::tensor::Device;
use splatzoo_apf_gs::networks::{ApfNetworks, NetworkConfig};
use splatzoo_apf_gs::onnx::{GRAPHS, export};
use splatzoo_train::onnx::{io_names, verify};

#[test]
fn every_graph_runs_in_tract_as_in_burn() {
    let device = Device::flex();
    let config = NetworkConfig {
        guidance_width: 24,
        residual_width: 16,
        accessory_width: 16,
        ..NetworkConfig::default()
    };
    let nets = ApfNetworks::new(&config, 10, 2, 1, &device);
    let dir = tempfile::tempdir().unwrap();
    let graphs = export(&nets, &config, 50, 20, dir.path(), &device).expect("exports");
    assert_eq!(graphs.len(), 3);
    for (g, (stem, input, output)) in graphs.iter().zip(GRAPHS) {
        assert!(g.graph.ends_with(format!("{stem}.onnx")));
        let (inputs, outputs) = io_names(&g.graph).unwrap();
        assert_eq!(
            (inputs, outputs),
            (vec![input.to_owned()], vec![output.to_owned()])
        );
        assert!(g.relative_error < 1e-3, "{stem}: {}", g.relative_error);
        assert_eq!(verify(&g.graph, &g.vectors).unwrap(), g.relative_error);
    }
}
