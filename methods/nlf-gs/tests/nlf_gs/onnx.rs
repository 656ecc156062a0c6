//! NLF-GS's ONNX graphs run in tract (a pure-Rust ONNX runtime) and reproduce Burn: the exported
//! test vectors, fresh inputs at another view count (the encoder's dynamic axis), and the whole
//! pipeline encoder → query → decoder against `NlfGs::generate`.

use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_models::anchor::MeshAnchors;
use splatzoo_models::body::builtin_body;
use splatzoo_models::networks::resnet::Depth;
use splatzoo_nlf_gs::data::NlfSubject;
use splatzoo_nlf_gs::network::{NlfConfig, NlfGs};
use splatzoo_nlf_gs::onnx::{OnnxSamples, export, max_relative_difference, run_graph, verify};
use splatzoo_train::checkpoint::Checkpoint;
use splatzoo_train::host_f32;
use std::path::Path;

fn run_tract(path: &Path, shape: &[usize], values: &[f32]) -> (Vec<usize>, Vec<f32>) {
    run_graph(path, shape, values).unwrap()
}

fn small_config() -> NlfConfig {
    NlfConfig {
        depth: Depth::R18,
        fpn_channels: 8,
        gaussians_per_face: 1,
        hidden: vec![32, 32],
        // The optional colour input, so that the exported decoder covers it.
        image_colour: true,
        ..NlfConfig::default()
    }
}

fn random_images(v: usize, size: usize, seed: u32, device: &Device) -> Tensor<4> {
    let values: Vec<f32> = (0..v * 3 * size * size)
        .map(|i| {
            ((i as u32).wrapping_mul(2_654_435_761).wrapping_add(seed) >> 8) as f32 / 16_777_216.0
        })
        .collect();
    Tensor::from_data(TensorData::new(values, [v, 3, size, size]), device)
}

#[test]
fn exported_graphs_reproduce_burn_in_tract() {
    let device = Device::flex();
    let size = 64usize;
    let config = small_config();
    let model = NlfGs::new(&config, &device);
    let faces = builtin_body().model.faces.clone();
    let anchors = MeshAnchors::per_face(faces.len() / 3, config.gaussians_per_face);
    let subject = NlfSubject::synthetic(3, size as u32, &device);
    let inputs = subject.nlf_inputs(&faces, &anchors);
    let images = inputs.images.clone();
    let features = model.encoder.forward_inference(images.clone());
    let fused = model.query(features, &inputs, config.fusion, config.occlusion_tolerance);
    let dir = tempfile::tempdir().unwrap();
    let files = export(
        &model,
        &config,
        &anchors,
        &OnnxSamples {
            images: vec![images.clone(), random_images(2, size, 7, &device)],
            fused: vec![fused.clone()],
        },
        dir.path(),
    )
    .unwrap();

    // Every stored vector, through tract.
    for (graph, vectors) in [
        (&files.encoder, &files.encoder_vectors),
        (&files.decoder, &files.decoder_vectors),
    ] {
        let worst = verify(graph, vectors).unwrap();
        assert!(worst < 1e-4, "{}: {worst}", graph.display());
    }
    // Verification notices a graph that does not match its vectors: another graph's inputs,
    // or a changed output.
    assert!(verify(&files.decoder, &files.encoder_vectors).is_err());
    let mut tampered = Checkpoint::read(&files.decoder_vectors).unwrap();
    tampered.tensors.get_mut("attributes.0").unwrap().1[5] += 1.0;
    let tampered_path = dir.path().join("tampered.safetensors");
    tampered.write(&tampered_path).unwrap();
    assert!(verify(&files.decoder, &tampered_path).unwrap() > 0.3);

    // A view count the export never saw.
    let four = random_images(4, size, 99, &device);
    let (shape, got) = run_tract(&files.encoder, &[4, 3, size, size], &host_f32(&four));
    let expected = model.encoder.forward_inference(four);
    assert_eq!(shape, expected.dims().to_vec());
    let worst = max_relative_difference(&got, &host_f32(&expected));
    assert!(worst < 1e-4, "encoder at 4 views: {worst}");

    // The whole pipeline: tract encoder → Burn query → tract decoder equals `generate`, and the
    // inference encoder equals the training one.
    let (shape, maps) = run_tract(&files.encoder, &[3, 3, size, size], &host_f32(&images));
    let maps = Tensor::<4>::from_data(
        TensorData::new(maps, [shape[0], shape[1], shape[2], shape[3]]),
        &device,
    );
    let training_maps = model.encoder.forward(images.clone());
    assert!(max_relative_difference(&host_f32(&maps), &host_f32(&training_maps)) < 1e-4);
    let fused_tract = model.query(maps, &inputs, config.fusion, config.occlusion_tolerance);
    let [g, c] = fused_tract.dims();
    let (_, packed) = run_tract(&files.decoder, &[g, c], &host_f32(&fused_tract));
    let reference = model
        .generate(&inputs, config.fusion, config.occlusion_tolerance)
        .attributes
        .packed();
    let worst = max_relative_difference(&packed, &host_f32(&reference));
    assert!(worst < 1e-3, "pipeline: {worst}");

    // The anchors table and the README are there and describe this export.
    let table = Checkpoint::read(&files.anchors).unwrap();
    assert_eq!(table.tensors["barycentric"].0, vec![anchors.len(), 3]);
    let readme = std::fs::read_to_string(&files.readme).unwrap();
    assert!(readme.contains(&format!("[{}, {}]", anchors.len(), c)));
}

#[test]
fn export_refuses_misshapen_samples() {
    let device = Device::flex();
    let config = small_config();
    let model = NlfGs::new(&config, &device);
    let faces = builtin_body().model.faces.clone();
    let anchors = MeshAnchors::per_face(faces.len() / 3, 1);
    let dir = tempfile::tempdir().unwrap();
    let good = Tensor::<2>::zeros([anchors.len(), 35], &device);
    let cases = [
        (
            vec![
                random_images(2, 64, 1, &device),
                random_images(2, 64, 2, &device),
            ],
            good.clone(),
            "differ in view count".to_string(),
        ),
        (
            vec![
                random_images(2, 64, 1, &device),
                random_images(3, 48, 2, &device),
            ],
            good.clone(),
            "expected [_, 3, 64, 64]".to_string(),
        ),
        (
            vec![
                random_images(2, 64, 1, &device),
                random_images(3, 64, 2, &device),
            ],
            Tensor::<2>::zeros([10, 35], &device),
            format!("expected [{}, 35]", anchors.len()),
        ),
    ];
    for (images, fused, message) in cases {
        let error = export(
            &model,
            &config,
            &anchors,
            &OnnxSamples {
                images,
                fused: vec![fused],
            },
            dir.path(),
        )
        .unwrap_err();
        assert!(error.to_string().contains(&message), "{error}");
    }
    assert!(
        !dir.path().join("encoder.onnx").exists(),
        "nothing written on refusal"
    );
}
