//! The hand-over (spec check 10): stage 2's canonical PBR Gaussians, posed by LBS and coloured
//! by `sRGB(b)` with `b = sRGB⁻¹(c)`, render the stage-1 image of the same pose (PSNR > 35 dB),
//! with F_Δ's offsets carried into canonical space; the binding's weights sum to one and its
//! normals are unit.

use crate::values;
use burn::module::Param;
use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_illum::human::{BodyMesh, RefinedBody, Stage1Config, pose_refined};
use splatzoo_illum::pbr::linear_to_srgb;
use splatzoo_illum::stage2::{PbrHuman, posed_normals};
use splatzoo_models::body::lbs::pose;
use splatzoo_models::body::{BodyTensors, PoseInput, builtin_body};
use splatzoo_models::networks::hash_grid::HashGridConfig;
use splatzoo_models::networks::hash_mlp::HashMlpConfig;
use splatzoo_rasterizer::{Camera, ColorMode, RasterSettings, rasterize};
use splatzoo_train::loss::psnr;
use splatzoo_train::scene::skinned::JointTransforms;

#[test]
fn stage_two_starts_at_the_stage_one_render() {
    let device = Device::flex();
    let mesh = BodyMesh::new(&builtin_body().model, 0).unwrap();
    let config = Stage1Config {
        subdivisions: 0,
        field: HashMlpConfig {
            grid: HashGridConfig {
                levels: 6,
                log2_table_size: 12,
                ..HashGridConfig::default()
            },
            hidden: 1,
            width: 16,
        },
        ..Stage1Config::default()
    };
    let mut body = RefinedBody::new(&mesh, &config, 9, &device);
    // Offsets of a few millimetres, so the canonical space must carry F_Δ.
    body.offset.head.bias = Some(Param::from_tensor(Tensor::<1>::from_floats(
        [0.004, -0.003, 0.005],
        &device,
    )));
    let queries = mesh.queries(&body.offset, &device);
    let model = &mesh.model;
    let joints = model.joint_count();
    let mut axis_angle = vec![0.0f32; 3 * joints];
    for (k, v) in axis_angle.iter_mut().enumerate().skip(3) {
        *v = 0.25 * ((k as f32) * 1.7).sin();
    }
    let posed = pose(
        &BodyTensors::new(model, &device),
        &PoseInput::from_axis_angle(
            Tensor::<2>::zeros([1, model.shape_count()], &device),
            Tensor::<2>::from_data(TensorData::new(axis_angle, [1, 3 * joints]), &device),
            Tensor::<2>::zeros([1, 3], &device),
        ),
    );
    let v = mesh.vertex_count();
    let camera = Camera::look_at(
        [0.0, 0.0, 3.2],
        [0.0, -0.1, 0.0],
        [0.0, -1.0, 0.0],
        40.0,
        96,
        128,
    );
    let settings = RasterSettings::new(camera, ColorMode::Features);
    let background = Tensor::<1>::from_floats([0.2, 0.3, 0.4], &device);

    let placed = pose_refined(&posed, body.offsets(&queries)).reshape([v, 3]);
    let stage1 = body.face_splats(&mesh, placed.clone(), body.vertex_colours(&queries));
    let before = rasterize(&stage1, background.clone(), &settings).unwrap();
    let covered = values(before.alpha.clone())
        .iter()
        .filter(|&&a| a > 0.5)
        .count();
    assert!(covered > 96 * 128 / 20, "the body covers {covered} pixels");

    let shaped = posed.shaped.clone().reshape([v, 3]);
    let (human, binding) = PbrHuman::from_stage1(&body, &mesh, &queries, shaped);
    let weights = values(binding.skin_weights.clone());
    for row in weights.chunks(joints) {
        assert!((row.iter().sum::<f32>() - 1.0).abs() < 1e-4);
    }
    let transforms = JointTransforms {
        rotations: posed.joint_rotations.clone().reshape([joints, 3, 3]),
        translations: posed.skinning_translations.clone().reshape([joints, 3]),
    };
    let stage2 = human.posed_splats(&binding, &transforms, linear_to_srgb(human.albedo()));
    let after = rasterize(&stage2, background, &settings).unwrap();
    let quality = psnr(after.color, before.color.clone());
    println!("hand-over PSNR {quality:.1} dB");
    assert!(quality > 35.0, "hand-over PSNR {quality}");
    // A control: canonical Gaussians off by −4 Δ (about 2 cm) fall far short.
    let (bare, bare_binding) = PbrHuman::from_stage1(
        &body,
        &mesh,
        &queries,
        posed.shaped.clone().reshape([v, 3]) - body.offsets(&queries) * 4.0,
    );
    let shifted = bare.posed_splats(&bare_binding, &transforms, linear_to_srgb(bare.albedo()));
    let control = psnr(
        rasterize(
            &shifted,
            Tensor::<1>::from_floats([0.2, 0.3, 0.4], &device),
            &settings,
        )
        .unwrap()
        .color,
        before.color,
    );
    println!("control PSNR {control:.1} dB");
    assert!(control < quality - 10.0, "control {control} vs {quality}");

    let normals = values(posed_normals(&binding, &mesh, placed));
    assert!(
        normals
            .chunks(3)
            .all(|n| ((n[0] * n[0] + n[1] * n[1] + n[2] * n[2]) - 1.0).abs() < 1e-4)
    );
}
