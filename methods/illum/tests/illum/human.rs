//! Stage 1 (Eq. 1): the refined body starts exactly at the template, its face Gaussians sit at
//! the barycentres with the face normal as their thin axis, the in-circle radius in-plane and
//! 1 mm (for 1.7 m) across; a loss on the Gaussians reaches both hash fields and the in-plane
//! parameters; offsets stay within their bound; and offsets ride the LBS transforms.

use crate::{fresh_seed, values};
use burn::module::Param;
use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_illum::human::{BodyMesh, RefinedBody, Stage1Config, pose_refined};
use splatzoo_models::body::lbs::pose;
use splatzoo_models::body::{BodyTensors, PoseInput, builtin_body};
use splatzoo_models::networks::hash_grid::HashGridConfig;
use splatzoo_models::networks::hash_mlp::HashMlpConfig;
use splatzoo_models::rotation::quaternion_to_matrix;

/// A small field so the tests stay quick; the body is not subdivided.
fn config() -> Stage1Config {
    Stage1Config {
        subdivisions: 0,
        field: HashMlpConfig {
            grid: HashGridConfig {
                levels: 6,
                features: 2,
                log2_table_size: 12,
                base_resolution: 4,
                growth: 1.6,
            },
            hidden: 1,
            width: 16,
        },
        max_offset: 0.05,
        opacity: 0.99,
    }
}

#[test]
fn face_gaussians_start_on_the_template_faces() {
    let device = Device::flex();
    let mesh = BodyMesh::new(&builtin_body().model, 0).unwrap();
    let body = RefinedBody::new(&mesh, &config(), fresh_seed(), &device);
    let queries = mesh.queries(&body.offset, &device);
    let offsets = values(body.offsets(&queries));
    assert!(offsets.iter().all(|&v| v == 0.0), "F_Δ starts at zero");
    let colours = body.vertex_colours(&queries);
    assert!(values(colours.clone()).iter().all(|&c| c > 0.0 && c < 1.0));
    let splats = body.face_splats(&mesh, mesh.template(&device), colours);
    let f = mesh.face_count();
    assert_eq!(splats.means.dims(), [f, 3]);
    assert_eq!(splats.colors.dims(), [f, 1, 3]);
    let means = values(splats.means);
    let rotations = values(quaternion_to_matrix(splats.quats));
    let scales = values(splats.log_scales);
    let template = &mesh.model.template;
    let vertex = |i: u32| [0, 1, 2].map(|k| f64::from(template[3 * i as usize + k]));
    for (face, t) in mesh.model.faces.chunks(3).enumerate().step_by(97) {
        let [a, b, c] = [t[0], t[1], t[2]].map(vertex);
        for k in 0..3 {
            let centre = (a[k] + b[k] + c[k]) / 3.0;
            assert!(
                (f64::from(means[face * 3 + k]) - centre).abs() < 1e-5,
                "face {face}"
            );
        }
        let e1 = [0, 1, 2].map(|k| b[k] - a[k]);
        let e2 = [0, 1, 2].map(|k| c[k] - a[k]);
        let n = [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ];
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        // The rotation's third column is the unit face normal (row-major [3, 3]).
        let column: Vec<f64> = (0..3)
            .map(|r| f64::from(rotations[face * 9 + r * 3 + 2]))
            .collect();
        let cosine: f64 = (0..3).map(|k| column[k] * n[k] / len).sum();
        assert!(cosine > 0.9999, "face {face}: normal cosine {cosine}");
        let r = mesh.inradius[face].ln();
        assert!((f64::from(scales[face * 3]) - r).abs() < 1e-5);
        assert!((f64::from(scales[face * 3 + 1]) - r).abs() < 1e-5);
        let thin = (1e-3 * mesh.height / 1.7).ln();
        assert!((f64::from(scales[face * 3 + 2]) - thin).abs() < 1e-5);
    }
    assert!(
        mesh.height > 1.0 && mesh.height < 2.5,
        "height {}",
        mesh.height
    );
}

#[test]
fn a_loss_on_the_gaussians_reaches_both_fields_and_the_in_plane_parameters() {
    let device = Device::flex().autodiff();
    let mesh = BodyMesh::new(&builtin_body().model, 0).unwrap();
    let body = RefinedBody::new(&mesh, &config(), fresh_seed(), &device);
    let queries = mesh.queries(&body.offset, &device);
    let offsets = body.offsets(&queries);
    let refined = mesh.template(&device) + offsets;
    let splats = body.face_splats(&mesh, refined, body.vertex_colours(&queries));
    let loss = splats.means.sum() + splats.colors.sum() + splats.log_scales.sum();
    let grads = loss.backward();
    let nonzero = |t: Tensor<2>| values(t).iter().any(|&v| v != 0.0);
    // The offset head starts at zero: its own gradient is what moves it first.
    let head = body
        .offset
        .head
        .weight
        .val()
        .grad(&grads)
        .expect("F_Δ head gradient");
    assert!(nonzero(head), "F_Δ head");
    let table = body
        .colour
        .grid
        .table
        .val()
        .grad(&grads)
        .expect("F_c table gradient");
    assert!(nonzero(table), "F_c table");
    let in_plane = body.in_plane.val().grad(&grads).expect("in-plane gradient");
    assert!(nonzero(in_plane), "in-plane parameters");
}

#[test]
fn offsets_are_bounded_and_ride_the_skinning_transforms() {
    let device = Device::flex();
    let mesh = BodyMesh::new(&builtin_body().model, 0).unwrap();
    let mut body = RefinedBody::new(&mesh, &config(), 3, &device);
    // A head bias of 10 m: every component is clamped to 0.05 H.
    body.offset.head.bias = Some(Param::from_tensor(Tensor::<1>::from_floats(
        [10.0, -10.0, 0.0],
        &device,
    )));
    let queries = mesh.queries(&body.offset, &device);
    let offsets = body.offsets(&queries);
    let bound = (0.05 * mesh.height) as f32;
    for row in values(offsets.clone()).chunks(3) {
        assert!((row[0] - bound).abs() < 1e-6 && (row[1] + bound).abs() < 1e-6 && row[2] == 0.0);
    }
    // A global turn of 90° about y: the offset (+x, −y) turns with the body.
    let model = &mesh.model;
    let tensors = BodyTensors::new(model, &device);
    let joints = model.joint_count();
    let mut axis_angle = vec![0.0f32; 3 * joints];
    axis_angle[1] = std::f32::consts::FRAC_PI_2;
    let input = PoseInput::from_axis_angle(
        Tensor::<2>::zeros([1, model.shape_count()], &device),
        Tensor::<2>::from_data(TensorData::new(axis_angle, [1, 3 * joints]), &device),
        Tensor::<2>::zeros([1, 3], &device),
    );
    let posed = pose(&tensors, &input);
    let moved = values(pose_refined(&posed, offsets) - posed.vertices.clone());
    for row in moved.chunks(3) {
        // R_y(90°) (b, −b, 0) = (0, −b, −b).
        assert!(
            row[0].abs() < 1e-5 && (row[1] + bound).abs() < 1e-5 && (row[2] + bound).abs() < 1e-5,
            "{row:?}"
        );
    }
}
