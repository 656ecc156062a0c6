//! The ONNX graphs of F_Δ and F_c (stage 1) and of F_vis, F_ao and F_m (stage 2): written with
//! named inputs and outputs, their test vectors beside them, tract's outputs equal to Burn's,
//! each code graph chained to its network equal to the field from canonical positions, and
//! F_Δ's clamp kept in the graph.

use burn::tensor::{Device, Distribution, Tensor, TensorData};
use splatzoo_illum::human::{BodyMesh, RefinedBody, Stage1Config};
use splatzoo_illum::onnx::{
    BODY_GRAPHS, IllumNetworks, STAGE2_GRAPHS, Stage2Networks, export, material_output,
};
use splatzoo_illum::shadow::ShadowDecoder;
use splatzoo_illum::visibility::{VisibilityConfig, VisibilityNet};
use splatzoo_models::body::builtin_body;
use splatzoo_models::networks::hash_grid::HashGridConfig;
use splatzoo_models::networks::hash_mlp::{HashMlp, HashMlpConfig};
use splatzoo_models::networks::initialised;
use splatzoo_train::onnx::{ExportedGraph, io_names, max_relative_difference, run_graph};

const ROWS: usize = 64;

fn small_field() -> HashMlpConfig {
    HashMlpConfig {
        grid: HashGridConfig {
            levels: 4,
            log2_table_size: 10,
            ..HashGridConfig::default()
        },
        hidden: 2,
        width: 16,
    }
}

/// The built-in body's mesh and a stage-1 body on it whose F_Δ head is drawn at random (the
/// trained one starts at zero, which would hide the clamp).
fn body(device: &Device) -> (BodyMesh, RefinedBody) {
    let mesh = BodyMesh::new(&builtin_body().model, 0).unwrap();
    let config = Stage1Config {
        subdivisions: 0,
        field: small_field(),
        ..Stage1Config::default()
    };
    let mut body = RefinedBody::new(&mesh, &config, 3, device);
    body.offset = HashMlp::new(config.field, 3, false, 11, device);
    (mesh, initialised(body))
}

fn host(t: Tensor<2>) -> Vec<f32> {
    t.into_data().try_into_vec::<f32>().unwrap()
}

fn assert_named(graphs: &[ExportedGraph], names: &[(&str, &str, &str)]) {
    assert_eq!(graphs.len(), names.len());
    for (graph, &(stem, input, output)) in graphs.iter().zip(names) {
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

/// `code` graph then `network` graph on `positions` `[ROWS, 3]`: the network's output.
fn chained(code: &ExportedGraph, network: &ExportedGraph, positions: &[f32]) -> Vec<f32> {
    let (shape, code) = run_graph(&code.graph, &[ROWS, 3], positions).unwrap();
    let (_, out) = run_graph(&network.graph, &[ROWS, shape[1]], &code).unwrap();
    out
}

#[test]
fn the_body_fields_export_alone_and_chain_to_the_fields_at_the_template() {
    let device = Device::flex();
    let (mesh, body) = body(&device);
    let dir = tempfile::tempdir().unwrap();
    let nets = IllumNetworks {
        body: &body,
        cube: &mesh.cube,
        stage2: None,
    };
    let graphs = export(&nets, ROWS, dir.path(), &device).unwrap();
    assert_named(&graphs, &BODY_GRAPHS);
    for name in STAGE2_GRAPHS.map(|(stem, _, _)| stem) {
        assert!(!dir.path().join(format!("{name}.onnx")).exists());
    }

    // Chained at the first template vertices, the graphs give what training uses.
    let template = mesh.template(&device).slice([0..ROWS, 0..3]);
    let positions = host(template.clone());
    let queries = body.offset.grid.queries(mesh.cube.apply(template.clone()));
    let offsets = host(body.offsets(&queries));
    let graph_offsets = chained(&graphs[0], &graphs[1], &positions);
    let difference = max_relative_difference(&graph_offsets, &offsets);
    assert!(difference < 1e-5, "offsets: {difference}");
    let queries = body.colour.grid.queries(mesh.cube.apply(template));
    let colours = host(body.vertex_colours(&queries));
    let graph_colours = chained(&graphs[2], &graphs[3], &positions);
    let difference = max_relative_difference(&graph_colours, &colours);
    assert!(difference < 1e-5, "colours: {difference}");
    assert!(graph_colours.iter().all(|&c| c > 0.0 && c < 1.0));

    // Codes far outside the trained range drive F_Δ into its clamp, and the graph clamps too.
    let width = body.offset.grid.output_width();
    let codes = Tensor::<2>::random([ROWS, width], Distribution::Normal(0.0, 30.0), &device);
    let expected = host(body.offsets_from_code(codes.clone()));
    let (_, got) = run_graph(&graphs[1].graph, &[ROWS, width], &host(codes)).unwrap();
    let bound = body.max_offset() as f32;
    let clamped = expected
        .iter()
        .filter(|v| (v.abs() - bound).abs() < 1e-7)
        .count();
    assert!(clamped > 0, "no output reached ±{bound}");
    assert!(got.iter().all(|v| v.abs() <= bound * (1.0 + 1e-6)));
    let difference = max_relative_difference(&got, &expected);
    assert!(difference < 1e-5, "clamped offsets: {difference}");
}

#[test]
fn the_stage_two_networks_export_after_the_body_and_run_in_tract_as_in_burn() {
    let device = Device::flex();
    let (mesh, body) = body(&device);
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
    let materials = HashMlp::new(small_field(), 2, false, 3, &device);
    let cube = mesh.cube;
    let dir = tempfile::tempdir().unwrap();
    let graphs = export(
        &IllumNetworks {
            body: &body,
            cube: &cube,
            stage2: Some(Stage2Networks {
                visibility: &visibility,
                shadow: &shadow,
                materials: &materials,
            }),
        },
        ROWS,
        dir.path(),
        &device,
    )
    .unwrap();
    let names: Vec<_> = BODY_GRAPHS.into_iter().chain(STAGE2_GRAPHS).collect();
    assert_named(&graphs, &names);

    // Chained, the two material graphs are F_m from canonical positions.
    let positions: Vec<f32> = (0..ROWS * 3)
        .map(|i| [-0.5f32, 0.1, -0.2][i % 3] + 0.013 * (i / 3) as f32)
        .collect();
    let material = chained(&graphs[6], &graphs[7], &positions);
    assert_eq!(material.len(), ROWS * 2);
    let points = Tensor::<2>::from_data(TensorData::new(positions, [ROWS, 3]), &device);
    let expected = host(material_output(
        &materials,
        materials.grid.encode(cube.apply(points)),
    ));
    let difference = max_relative_difference(&material, &expected);
    assert!(difference < 1e-5, "{difference}");
}
