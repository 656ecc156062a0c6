//! Stage 1 on the synthetic capture: the refined body, posed by the person's motion, learns
//! the person's colours (the image loss falls by more than 15 % within 25 Adam steps on two
//! frames; 24 % measured), F_Δ starts moving the mesh, L_mesh and L_scale stay finite, and a
//! pose of the wrong size is named.

use burn::module::Module;
use burn::optim::{AdamConfig, GradientsParams};
use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_illum::IllumError;
use splatzoo_illum::data::{IllumCapture, IllumDataConfig};
use splatzoo_illum::human::{BodyMesh, RefinedBody, Stage1Config};
use splatzoo_illum::stage1::{HumanView, Stage1Weights, stage1_terms};
use splatzoo_models::body::lbs::pose;
use splatzoo_models::body::{BodyTensors, PoseInput, Posed, builtin_body};
use splatzoo_models::laplacian::UniformLaplacian;
use splatzoo_models::networks::hash_grid::HashGridConfig;
use splatzoo_models::networks::hash_mlp::HashMlpConfig;
use splatzoo_rasterizer::{ColorMode, RasterSettings};
use splatzoo_train::loss::scalar;

fn posed_at(capture: &IllumCapture, tensors: &BodyTensors, frame: usize, device: &Device) -> Posed {
    let motion = capture.truth.as_ref().unwrap().motion();
    let f32s = |v: &[f64]| v.iter().map(|&x| x as f32).collect::<Vec<_>>();
    let p = motion.pose(frame);
    let betas = motion.frame_betas(frame);
    let input = PoseInput::from_axis_angle(
        Tensor::<2>::from_data(TensorData::new(f32s(betas), [1, betas.len()]), device),
        Tensor::<2>::from_data(TensorData::new(f32s(p), [1, p.len()]), device),
        Tensor::<2>::from_data(
            TensorData::new(f32s(&motion.translation(frame)), [1, 3]),
            device,
        ),
    );
    pose(tensors, &input)
}

#[test]
fn stage_one_learns_the_person_and_names_a_bad_pose() {
    let cpu = Device::flex();
    let capture = IllumDataConfig {
        width: 64,
        height: 48,
        frames: 5,
        novel_pose_frames: 1,
        supersample: 1,
        shadow_resolution: 128,
        scene_points: 500,
        ..IllumDataConfig::default()
    }
    .build(&cpu)
    .unwrap();
    let device = Device::flex().autodiff();
    let mesh = BodyMesh::new(&builtin_body().model, 0).unwrap();
    let config = Stage1Config {
        subdivisions: 0,
        field: HashMlpConfig {
            grid: HashGridConfig {
                levels: 8,
                log2_table_size: 12,
                ..HashGridConfig::default()
            },
            hidden: 1,
            width: 32,
        },
        ..Stage1Config::default()
    };
    let mut body = RefinedBody::new(&mesh, &config, 5, &device);
    let queries = mesh.queries(&body.offset, &device);
    let laplacian = UniformLaplacian::new(mesh.vertex_count(), &mesh.model.faces);
    let tensors = BodyTensors::new(&mesh.model, &device);
    let frames: Vec<usize> = vec![0, 2];
    let weights = Stage1Weights::default();
    let loss_at = |body: &RefinedBody, frame: usize| {
        let f = &capture.frames[frame];
        let settings = RasterSettings::new(f.camera, ColorMode::Features);
        stage1_terms(
            body,
            &mesh,
            &laplacian,
            &queries,
            &posed_at(&capture, &tensors, frame, &device),
            HumanView {
                settings: &settings,
                image: f.image.clone().autodiff(),
                mask: f.mask.clone().autodiff(),
                background: [0.5; 3],
            },
            &weights,
        )
        .unwrap()
    };
    let start: f64 = frames
        .iter()
        .map(|&t| scalar(loss_at(&body, t).image))
        .sum();
    let mut optimiser = AdamConfig::new().init();
    for step in 0..25 {
        let terms = loss_at(&body, frames[step % frames.len()]);
        assert!(scalar(terms.mesh.clone()).is_finite() && scalar(terms.scale.clone()).is_finite());
        let grads = GradientsParams::from_grads(terms.total.backward(), &body);
        body = optimiser.step(5e-3, body, grads);
    }
    let end: f64 = frames
        .iter()
        .map(|&t| scalar(loss_at(&body, t).image))
        .sum();
    println!("image loss {start:.4} → {end:.4}");
    assert!(end < 0.85 * start, "image loss {start} → {end}");
    let moved = body
        .valid()
        .offsets(&mesh.queries(&body.valid().offset, &cpu));
    let moved = scalar(moved.abs().max());
    assert!(moved > 0.0, "F_Δ has not moved the mesh");

    // A pose of the unsubdivided body for a subdivided mesh is named, not a panic.
    let fine = BodyMesh::new(&builtin_body().model, 1).unwrap();
    let f = &capture.frames[0];
    let settings = RasterSettings::new(f.camera, ColorMode::Features);
    let fine_body = RefinedBody::new(&fine, &config, 5, &cpu);
    let result = stage1_terms(
        &fine_body,
        &fine,
        &UniformLaplacian::new(fine.vertex_count(), &fine.model.faces),
        &fine.queries(&fine_body.offset, &cpu),
        &posed_at(&capture, &BodyTensors::new(&mesh.model, &cpu), 0, &cpu),
        HumanView {
            settings: &settings,
            image: f.image.clone(),
            mask: f.mask.clone(),
            background: [0.5; 3],
        },
        &weights,
    );
    assert!(matches!(result, Err(IllumError::Input { .. })));
}
