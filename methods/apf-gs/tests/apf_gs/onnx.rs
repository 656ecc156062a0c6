//! The ONNX graphs of `C`, `F_φ` and `D_ψ` (A15), and of `F_φ`'s hash `γ` where it has one:
//! named inputs and outputs, test vectors, and tract reproducing Burn.

use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_apf_gs::networks::{ApfNetworks, NetworkConfig, PositionEncoding};
use splatzoo_apf_gs::onnx::{GRAPHS, POSITION_CODE_GRAPH, export};
use splatzoo_models::networks::hash_grid::HashGridConfig;
use splatzoo_train::onnx::{io_names, max_relative_difference, run_graph, verify};

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

    // With a hash γ, a fourth graph computes F_φ's position code from μ̄, and chained before
    // `residual.onnx` it gives F_φ of (μ̄, c_t).
    let hashed = NetworkConfig {
        position_encoding: PositionEncoding::Hash,
        position_hash: HashGridConfig {
            levels: 4,
            log2_table_size: 9,
            ..HashGridConfig::default()
        },
        ..config
    };
    let nets = ApfNetworks::new(&hashed, 10, 2, 1, &device);
    let graphs = export(&nets, &hashed, 50, 20, dir.path(), &device).expect("exports");
    assert_eq!(graphs.len(), 4);
    let code = &graphs[3];
    let (inputs, outputs) = io_names(&code.graph).unwrap();
    assert_eq!(
        (inputs, outputs),
        (
            vec![POSITION_CODE_GRAPH.1.to_owned()],
            vec![POSITION_CODE_GRAPH.2.to_owned()]
        )
    );
    assert!(code.relative_error < 1e-5, "{}", code.relative_error);
    let mu: Vec<f32> = (0..50 * 3)
        .map(|i| ((i * 37) % 101) as f32 / 50.0 - 1.0)
        .collect();
    let (shape, got) = run_graph(&code.graph, &[50, 3], &mu).unwrap();
    let mu = Tensor::<2>::from_data(TensorData::new(mu, [50, 3]), &device);
    let expected = nets.residual.encode_positions(mu, hashed.position_levels);
    assert_eq!(shape, expected.dims().to_vec());
    let expected = expected.into_data().try_into_vec::<f32>().unwrap();
    let difference = max_relative_difference(&got, &expected);
    assert!(difference < 1e-5, "{difference}");
}
