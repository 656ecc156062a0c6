//! Mesh-anchored Gaussians: barycentric placement (NLF-GS Eq. 1), face frames that follow the
//! mesh, subdivision that keeps a closed mesh closed and the rest pose unchanged, and
//! area-uniform surface sampling.

use crate::common::values;
use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_models::anchor::{
    MeshAnchors, anchored_positions, face_frames, fixed_barycentrics, subdivide,
};
use splatzoo_models::body::{BodyKind, BodyModel, BodyTensors, PoseInput, lbs};
use splatzoo_models::rotation::axis_angle_to_matrix;

/// A closed octahedron with outward winding.
fn octahedron() -> (Vec<f32>, Vec<u32>) {
    let v = vec![
        1.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, -1.0,
    ];
    let f = vec![
        0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5,
    ];
    (v, f)
}

#[test]
fn fixed_barycentrics_are_inside_and_distinct() {
    for k in [1, 4, 6, 16] {
        let w = fixed_barycentrics(k);
        assert_eq!(w.len(), k);
        for b in &w {
            assert!(
                (b.iter().sum::<f32>() - 1.0).abs() < 1e-6 && b.iter().all(|&x| x >= 0.0),
                "{b:?}"
            );
        }
        for i in 0..k {
            for j in i + 1..k {
                assert!(
                    w[i].iter().zip(&w[j]).any(|(a, b)| (a - b).abs() > 1e-4),
                    "k={k}: duplicate points"
                );
            }
        }
    }
}

#[test]
fn anchors_follow_eq1_and_offsets_live_in_the_face_frame() {
    let device = Device::flex();
    let (v, f) = octahedron();
    let anchors = MeshAnchors::per_face(8, 4);
    let verts = Tensor::<3>::from_data(TensorData::new(v.clone(), [1, 6, 3]), &device);
    let zero = Tensor::<3>::zeros([1, 32, 3], &device);
    let (on_face, _) = anchored_positions(verts.clone(), &f, &anchors, zero);
    let got = values(on_face);
    for (g, (face, b)) in anchors
        .face_from_gaussian
        .iter()
        .zip(&anchors.barycentric)
        .enumerate()
    {
        for c in 0..3 {
            let expected: f32 = (0..3)
                .map(|j| b[j] * v[3 * f[3 * *face as usize + j] as usize + c])
                .sum();
            assert!((got[3 * g + c] - expected).abs() < 1e-6);
        }
    }
    // An offset of 0.1 along the local normal moves every Gaussian 0.1 outward (octahedron faces
    // are at distance 1/√3 from the centre).
    let normal: Vec<f32> = (0..32).flat_map(|_| [0.0, 0.0, 0.1]).collect();
    let normal = Tensor::<3>::from_data(TensorData::new(normal, [1, 32, 3]), &device);
    let (lifted, _) = anchored_positions(verts, &f, &anchors, normal);
    let lifted = values(lifted);
    for g in 0..32 {
        let p = &lifted[3 * g..3 * g + 3];
        let plane = p[0].abs() + p[1].abs() + p[2].abs(); // |x|+|y|+|z| = 1 on the surface
        assert!((plane - 1.0 - 0.1 * 3f32.sqrt()).abs() < 1e-5, "{plane}");
    }
}

#[test]
fn face_frames_are_orthonormal_and_rotate_with_the_mesh() {
    let device = Device::flex();
    let (v, f) = octahedron();
    let verts = Tensor::<3>::from_data(TensorData::new(v, [1, 6, 3]), &device);
    let frames = face_frames(verts.clone(), &f); // [1, 8, 3, 3]
    let ftf = values(frames.clone().swap_dims(2, 3).matmul(frames.clone()));
    for m in ftf.chunks(9) {
        for (i, x) in m.iter().enumerate() {
            let e = if i % 4 == 0 { 1.0 } else { 0.0 };
            assert!((x - e).abs() < 1e-5);
        }
    }
    let rot = axis_angle_to_matrix(Tensor::<2>::from_floats([[0.3, -1.1, 0.7]], &device)); // [1, 3, 3]
    let rotated = verts.matmul(rot.clone().swap_dims(1, 2)); // v Rᵀ
    let frames_rot = values(face_frames(rotated, &f));
    let expected = values(
        rot.reshape([1, 1, 3, 3])
            .expand([1, 8, 3, 3])
            .matmul(frames),
    );
    for (a, b) in frames_rot.iter().zip(&expected) {
        assert!((a - b).abs() < 1e-5);
    }
}

fn octahedron_model() -> BodyModel {
    let (v, f) = octahedron();
    BodyModel {
        kind: BodyKind::Builtin,
        template: v,
        faces: f,
        joint_regressor: vec![1.0 / 6.0; 12],
        parents: vec![None, Some(0)],
        skin_weights: (0..6)
            .flat_map(|i| if i % 2 == 0 { [1.0, 0.0] } else { [0.3, 0.7] })
            .collect(),
        shape_dirs: (0..18).map(|k| k as f32 * 0.01).collect(),
        pose_dirs: Some(vec![0.0; 6 * 3 * 9]),
        expression_dirs: None,
        joint_names: vec!["root".into(), "child".into()],
        face_landmarks: None,
    }
}

#[test]
fn subdivision_keeps_the_mesh_closed_and_the_rest_pose() {
    let model = octahedron_model();
    let (fine, parents) = subdivide(&model);
    fine.validate("subdivided").unwrap();
    assert_eq!(fine.vertex_count(), 6 + 12); // V + E
    assert_eq!(fine.face_count(), 32);
    assert_eq!(parents.len(), 12);
    // Closed: every edge shared by exactly two faces; Euler characteristic 2.
    let mut edges = std::collections::HashMap::new();
    for t in fine.faces.chunks(3) {
        for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
            *edges.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    assert!(edges.values().all(|&c| c == 2));
    assert_eq!(
        fine.vertex_count() as i64 - edges.len() as i64 + fine.face_count() as i64,
        2
    );
    for w in fine.skin_weights.chunks(2) {
        assert!((w[0] + w[1] - 1.0).abs() < 1e-6);
    }
    // Same joints, and a posed coarse vertex is unchanged by subdivision.
    let device = Device::flex();
    let pose = |m: &BodyModel| {
        let body = BodyTensors::new(m, &device);
        let input = PoseInput::from_axis_angle(
            Tensor::from_floats([[0.5]], &device),
            Tensor::from_floats([[0.1, 0.2, 0.3, 0.4, -0.5, 0.6]], &device),
            Tensor::zeros([1, 3], &device),
        );
        let p = lbs::pose(&body, &input);
        (values(p.vertices), values(p.joints))
    };
    let (coarse_v, coarse_j) = pose(&model);
    let (fine_v, fine_j) = pose(&fine);
    assert_eq!(coarse_j, fine_j);
    for (a, b) in coarse_v.iter().zip(&fine_v[..18]) {
        assert!((a - b).abs() < 1e-6);
    }
}

#[test]
fn surface_samples_are_area_uniform() {
    // Two triangles with areas 1 and 3.
    let v = vec![
        0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 2.0, 0.0, 10.0, 0.0, 0.0, 13.0, 0.0, 0.0, 10.0, 2.0, 0.0,
    ];
    let f = vec![0, 1, 2, 3, 4, 5];
    let s = MeshAnchors::sample_surface(&v, &f, 100_000, 7);
    assert_eq!(s.len(), 100_000);
    let on_first = s.face_from_gaussian.iter().filter(|&&f| f == 0).count() as f64 / 1e5;
    assert!((on_first - 0.25).abs() < 0.01, "{on_first}");
    assert!(
        s.barycentric
            .iter()
            .all(|b| b.iter().all(|&x| x >= 0.0) && (b.iter().sum::<f32>() - 1.0).abs() < 1e-5)
    );
    // Uniform inside a triangle: the mean barycentric is the centroid.
    let mean: Vec<f64> = (0..3)
        .map(|j| s.barycentric.iter().map(|b| b[j] as f64).sum::<f64>() / 1e5)
        .collect();
    assert!(
        mean.iter().all(|m| (m - 1.0 / 3.0).abs() < 0.01),
        "{mean:?}"
    );
    // Same seed, same samples.
    let again = MeshAnchors::sample_surface(&v, &f, 100_000, 7);
    assert_eq!(again.face_from_gaussian, s.face_from_gaussian);
}
