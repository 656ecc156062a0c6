//! The skinned-Gaussian node: LBS of Gaussians against an f64 scalar implementation (at ±π
//! joint angles), the rest pose reproducing the canonical set, gradients reaching the pose
//! table, the Gaussians and the non-rigid hook (against finite differences), interpolation at
//! held-out frames, the joint regressor carried onto the Gaussians, and bad input named.

use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_datasets::pose_sequence::PoseSequence;
use splatzoo_datasets::synth::rng::Rng;
use splatzoo_models::body::{BodyKind, BodyModel, builtin_body};
use splatzoo_models::rotation_scalar::{axis_angle_matrix, quaternion_matrix};
use splatzoo_rasterizer::Splats;
use splatzoo_train::densify::{DensifyConfig, Strategy};
use splatzoo_train::host_f32;
use splatzoo_train::loss::scalar;
use splatzoo_train::optimizer::LearningRates;
use splatzoo_train::scene::skinned::pose_table::{matrix_from_6d, slerp};
use splatzoo_train::scene::skinned::skinning::skin_splats;
use splatzoo_train::scene::skinned::{
    CanonicalPose, JointTransforms, NonRigidField, Placement, PoseTable, Refinement, Residual,
    ResidualInput, ResidualSpace, SkinnedConfig,
};
use splatzoo_train::scene::{SceneNode, SkinnedGaussianNode};

type M3 = [[f64; 3]; 3];

fn mul(a: &M3, b: &M3) -> M3 {
    std::array::from_fn(|r| std::array::from_fn(|c| (0..3).map(|k| a[r][k] * b[k][c]).sum()))
}

fn rows(v: &[f32], n: usize, w: usize) -> Vec<Vec<f64>> {
    (0..n)
        .map(|i| v[i * w..(i + 1) * w].iter().map(|&x| x as f64).collect())
        .collect()
}

#[test]
fn lbs_of_gaussians_matches_an_f64_reference_at_extreme_angles() {
    let device = Device::flex();
    let mut rng = Rng(11);
    let (g, j) = (40, 4);
    // Joint rotations include ±π about each axis and a generic one.
    let axis_angles: [[f64; 3]; 4] = [
        [std::f64::consts::PI, 0.0, 0.0],
        [0.0, -std::f64::consts::PI, 0.0],
        [0.0, 0.0, std::f64::consts::PI - 1e-6],
        [0.4, -1.1, 0.7],
    ];
    let rot: Vec<M3> = axis_angles.iter().map(|&a| axis_angle_matrix(a)).collect();
    let trans: Vec<[f64; 3]> = (0..j)
        .map(|_| std::array::from_fn(|_| rng.range(-1.0, 1.0)))
        .collect();
    let mut weights = vec![0.0f64; g * j];
    for row in weights.chunks_mut(j) {
        // One Gaussian in four is rigid on one joint; the rest blend.
        if rng.next() < 0.25 {
            row[rng.below(j)] = 1.0;
        } else {
            row.iter_mut().for_each(|w| *w = rng.next());
            let s: f64 = row.iter().sum();
            row.iter_mut().for_each(|w| *w /= s);
        }
    }
    let means: Vec<[f64; 3]> = (0..g)
        .map(|_| std::array::from_fn(|_| rng.range(-1.0, 1.0)))
        .collect();
    let quats: Vec<[f64; 4]> = (0..g)
        .map(|_| std::array::from_fn(|_| rng.normal()))
        .collect();

    let f32s = |v: Vec<f64>| v.into_iter().map(|x| x as f32).collect::<Vec<_>>();
    let transforms = JointTransforms {
        rotations: Tensor::from_data(
            TensorData::new(
                f32s(rot.iter().flatten().flatten().copied().collect()),
                [j, 3, 3],
            ),
            &device,
        ),
        translations: Tensor::from_data(
            TensorData::new(f32s(trans.iter().flatten().copied().collect()), [j, 3]),
            &device,
        ),
    };
    let splats = Splats {
        means: Tensor::from_data(
            TensorData::new(f32s(means.iter().flatten().copied().collect()), [g, 3]),
            &device,
        ),
        quats: Tensor::from_data(
            TensorData::new(f32s(quats.iter().flatten().copied().collect()), [g, 4]),
            &device,
        ),
        log_scales: Tensor::zeros([g, 3], &device),
        opacity_logits: Tensor::zeros([g], &device),
        colors: Tensor::zeros([g, 1, 3], &device),
    };
    let weights_t = Tensor::<2>::from_data(TensorData::new(f32s(weights.clone()), [g, j]), &device);
    let out = skin_splats(splats, weights_t, &transforms);
    let (out_means, out_quats) = (
        rows(&host_f32(&out.means), g, 3),
        rows(&host_f32(&out.quats), g, 4),
    );
    for i in 0..g {
        let w = &weights[i * j..(i + 1) * j];
        let a: M3 = std::array::from_fn(|r| {
            std::array::from_fn(|c| (0..j).map(|k| w[k] * rot[k][r][c]).sum())
        });
        let b: [f64; 3] = std::array::from_fn(|r| (0..j).map(|k| w[k] * trans[k][r]).sum());
        let mean: [f64; 3] =
            std::array::from_fn(|r| (0..3).map(|c| a[r][c] * means[i][c]).sum::<f64>() + b[r]);
        for r in 0..3 {
            assert!(
                (out_means[i][r] - mean[r]).abs() < 1e-5,
                "Gaussian {i}: mean {:?} vs {mean:?}",
                out_means[i]
            );
        }
        // Rotation: Gram–Schmidt of the blended matrix's rows, then the Gaussian's own.
        let rigid = matrix_from_6d([a[0][0], a[0][1], a[0][2], a[1][0], a[1][1], a[1][2]]);
        let expected = mul(&rigid, &quaternion_matrix(quats[i]));
        let got = quaternion_matrix(std::array::from_fn(|k| out_quats[i][k]));
        for r in 0..3 {
            for c in 0..3 {
                assert!(
                    (got[r][c] - expected[r][c]).abs() < 1e-4,
                    "Gaussian {i} (weights {w:?}): rotation {got:?} vs {expected:?}"
                );
            }
        }
    }
}

/// A three-joint chain along +y wrapped in a strip of eight vertices (two per level).
fn tiny_body() -> BodyModel {
    let levels = [0.0f32, 0.5, 1.0, 1.5];
    let template: Vec<f32> = levels
        .iter()
        .flat_map(|&y| [-0.1, y, 0.0, 0.1, y, 0.05])
        .collect();
    let mut faces = Vec::new();
    for l in 0..3u32 {
        let (a, b, c, d) = (2 * l, 2 * l + 1, 2 * l + 2, 2 * l + 3);
        faces.extend([a, b, c, b, d, c]);
    }
    let (v, j) = (8, 3);
    let mut joint_regressor = vec![0.0f32; j * v];
    for k in 0..j {
        joint_regressor[k * v + 2 * k] = 0.5;
        joint_regressor[k * v + 2 * k + 1] = 0.5;
    }
    let per_level: [[f32; 3]; 4] = [
        [1.0, 0.0, 0.0],
        [0.3, 0.7, 0.0],
        [0.0, 0.4, 0.6],
        [0.0, 0.0, 1.0],
    ];
    let skin_weights: Vec<f32> = (0..v).flat_map(|i| per_level[i / 2]).collect();
    BodyModel {
        kind: BodyKind::Builtin,
        template,
        faces,
        joint_regressor,
        parents: vec![None, Some(0), Some(1)],
        skin_weights,
        shape_dirs: vec![0.0; v * 3],
        pose_dirs: None,
        expression_dirs: None,
        joint_names: vec!["root".into(), "middle".into(), "top".into()],
        face_landmarks: None,
    }
}

/// A node of `model` over `prior` with default learning rates and density control.
fn node_of(
    model: &BodyModel,
    prior: &PoseSequence,
    trained: Vec<bool>,
    config: &SkinnedConfig,
) -> Result<SkinnedGaussianNode, String> {
    let device = Device::flex();
    SkinnedGaussianNode::new(
        "person",
        model,
        prior,
        trained,
        config,
        LearningRates::default(),
        &DensifyConfig::default(),
        1.0,
        1,
        &device,
    )
    .map_err(|e| e.to_string())
}

fn track(joints: usize, frames: usize, rng: &mut Rng, spread: f64) -> PoseSequence {
    PoseSequence {
        joints,
        poses: (0..frames * joints * 3)
            .map(|_| rng.range(-spread, spread))
            .collect(),
        translations: (0..frames * 3).map(|_| rng.range(-0.2, 0.2)).collect(),
        betas: vec![0.0; frames],
        shape_count: 1,
        fps: None,
    }
}

fn tiny_node(prior: &PoseSequence, trained: Vec<bool>, device: &Device) -> SkinnedGaussianNode {
    let config = SkinnedConfig {
        placement: Placement::PerFace,
        per_face: 2,
        canonical_pose: CanonicalPose::TPose,
        ..SkinnedConfig::default()
    };
    let densify = DensifyConfig {
        strategy: Strategy::None,
        ..DensifyConfig::default()
    };
    SkinnedGaussianNode::new(
        "person",
        &tiny_body(),
        prior,
        trained,
        &config,
        LearningRates::default(),
        &densify,
        1.0,
        3,
        device,
    )
    .unwrap()
}

/// A canonical-space offset field holding one tensor `[G, 3]`.
struct Offsets(Tensor<2>);

impl NonRigidField for Offsets {
    fn space(&self) -> ResidualSpace {
        ResidualSpace::Canonical
    }

    fn residual(&self, _input: &ResidualInput) -> Residual {
        Residual {
            means: Some(self.0.clone()),
            ..Residual::default()
        }
    }
}

/// `Σ W ⊙ μ' + Σ Q ⊙ q'` of the posed splats.
fn probe(splats: &Splats, w: &Tensor<2>, q: &Tensor<2>) -> Tensor<1> {
    (splats.means.clone() * w.clone()).sum() + (splats.quats.clone() * q.clone()).sum()
}

#[test]
fn gradients_reach_the_pose_table_the_gaussians_and_the_non_rigid_hook() {
    let device = Device::flex();
    let mut rng = Rng(4);
    let prior = track(3, 3, &mut rng, 0.8);
    let trained = vec![true, true, false];
    let mut node = tiny_node(&prior, trained.clone(), &device);
    let g = node.gaussians();
    let random = |n: usize, w: usize, rng: &mut Rng| -> Vec<f32> {
        (0..n * w).map(|_| rng.range(-1.0, 1.0) as f32).collect()
    };
    let (wv, qv, ov) = (
        random(g, 3, &mut rng),
        random(g, 4, &mut rng),
        random(g, 3, &mut rng),
    );
    let tensor =
        |v: &[f32], w: usize| Tensor::<2>::from_data(TensorData::new(v.to_vec(), [g, w]), &device);
    let (w, q) = (tensor(&wv, 3), tensor(&qv, 4));
    let offsets = tensor(&ov, 3).mul_scalar(0.05);
    let frame = 1;

    node.begin_step();
    let offset_leaf = offsets.clone().autodiff().require_grad();
    node.set_non_rigid(Some(Box::new(Offsets(offset_leaf.clone()))));
    let leaves = node.canonical_leaves().unwrap().clone();
    let posed = node.posed(leaves.splats(), frame).splats;
    let grads = probe(&posed, &w.clone().autodiff(), &q.clone().autodiff()).backward();
    let table = node.poses.leaves().unwrap();
    let (delta_leaf, trans_leaf) = (&table.deltas, &table.translations);
    let delta_grad = host_f32(&delta_leaf.grad(&grads).unwrap());
    let trans_grad = host_f32(&trans_leaf.grad(&grads).unwrap());
    let means_grad = host_f32(&leaves.means.grad(&grads).unwrap());
    let offset_grad = host_f32(&offset_leaf.grad(&grads).unwrap());

    // Finite differences on a twin node outside any step.
    let mut twin = tiny_node(&prior, trained, &device);
    let base_splats = twin.canonical_set().splats();
    let eval = |twin: &SkinnedGaussianNode, canonical: Splats, offsets: Tensor<2>| -> f64 {
        // The twin has no field: the offsets go on before skinning, where the field adds them.
        let moved = Residual {
            means: Some(offsets),
            ..Residual::default()
        }
        .apply(canonical);
        scalar(probe(&twin.posed(moved, frame).splats, &w, &q))
    };
    let eps = 1e-3;
    let check = |what: &str, analytic: f32, plus: f64, minus: f64| {
        let fd = (plus - minus) / (2.0 * eps);
        assert!(
            (analytic as f64 - fd).abs() < 2e-2 + 2e-2 * fd.abs(),
            "{what}: autodiff {analytic} vs finite differences {fd}"
        );
    };
    // Pose deltas of the rendered frame: every joint, a few components.
    let j = 3;
    for (joint, c) in [(0, 0), (0, 4), (1, 2), (2, 5), (1, 3)] {
        let at = (frame * j + joint) * 6 + c;
        let base = host_f32(&twin.poses.deltas);
        let mut shifted = |delta: f64| {
            let mut v = base.clone();
            v[at] += delta as f32;
            twin.poses.deltas = Tensor::from_data(TensorData::new(v, [3, j, 6]), &device);
            eval(&twin, base_splats.clone(), offsets.clone())
        };
        let (plus, minus) = (shifted(eps), shifted(-eps));
        check(
            &format!("delta[{frame}, {joint}, {c}]"),
            delta_grad[at],
            plus,
            minus,
        );
        twin.poses.deltas = Tensor::from_data(TensorData::new(base, [3, j, 6]), &device);
    }
    // Other frames' rows get nothing from this frame.
    assert!(
        delta_grad[..j * 6].iter().all(|&v| v == 0.0),
        "frame 0 untouched"
    );
    for a in 0..3 {
        let base = host_f32(&twin.poses.translation_deltas);
        let mut shifted = |delta: f64| {
            let mut v = base.clone();
            v[3 * frame + a] += delta as f32;
            twin.poses.translation_deltas = Tensor::from_data(TensorData::new(v, [3, 3]), &device);
            eval(&twin, base_splats.clone(), offsets.clone())
        };
        let (plus, minus) = (shifted(eps), shifted(-eps));
        check(
            &format!("translation[{frame}, {a}]"),
            trans_grad[3 * frame + a],
            plus,
            minus,
        );
        twin.poses.translation_deltas = Tensor::from_data(TensorData::new(base, [3, 3]), &device);
    }
    // Canonical means and the residual offsets.
    for (row, a) in [(0, 0), (3, 1), (g - 1, 2)] {
        let shift = |delta: f64, on_offsets: bool| {
            let mut canonical = base_splats.clone();
            let mut offs = offsets.clone();
            let bump = |t: Tensor<2>| {
                let mut v = host_f32(&t);
                v[3 * row + a] += delta as f32;
                Tensor::<2>::from_data(TensorData::new(v, [g, 3]), &device)
            };
            if on_offsets {
                offs = bump(offs);
            } else {
                canonical.means = bump(canonical.means);
            }
            eval(&twin, canonical, offs)
        };
        check(
            &format!("mean[{row}, {a}]"),
            means_grad[3 * row + a],
            shift(eps, false),
            shift(-eps, false),
        );
        check(
            &format!("offset[{row}, {a}]"),
            offset_grad[3 * row + a],
            shift(eps, true),
            shift(-eps, true),
        );
    }
}

#[test]
fn the_rest_pose_reproduces_the_canonical_set() {
    let model = &builtin_body().model;
    for canonical_pose in [CanonicalPose::DaPose, CanonicalPose::APose] {
        let pose = canonical_pose.axis_angles(model.joint_count());
        let prior = PoseSequence {
            joints: model.joint_count(),
            poses: pose.repeat(2),
            translations: vec![0.0; 6],
            betas: vec![0.0; 2 * model.shape_count()],
            shape_count: model.shape_count(),
            fps: None,
        };
        let config = SkinnedConfig {
            canonical_pose,
            per_face: 1,
            ..SkinnedConfig::default()
        };
        let node = node_of(model, &prior, vec![true, false], &config).unwrap();
        let canonical = node.canonical_set().splats();
        for frame in [0, 1] {
            let posed = node.posed(canonical.clone(), frame).splats;
            let diff = scalar((posed.means - canonical.means.clone()).abs().max());
            assert!(
                diff < 1e-4,
                "{canonical_pose:?}, frame {frame}: means move by {diff}"
            );
            let q = host_f32(&posed.quats);
            assert!(
                q.chunks(4).all(|q| (q[0].abs() - 1.0).abs() < 1e-4),
                "{canonical_pose:?}: rotations stay the identity"
            );
        }
    }
}

#[test]
fn held_out_frames_interpolate_their_trained_neighbours() {
    let device = Device::flex();
    let mut rng = Rng(21);
    let prior = track(2, 6, &mut rng, 0.5);
    let trained = vec![true, false, false, true, false, false];
    let mut table = PoseTable::new(
        &prior,
        trained,
        Refinement {
            rotations: true,
            translation: true,
            sequence_offset: true,
        },
        &device,
    );
    let a = axis_angle_matrix([0.3, -0.2, 0.9]);
    let b = axis_angle_matrix([-0.5, 0.4, 0.1]);
    let six = |m: &M3| [m[0][0], m[0][1], m[0][2], m[1][0], m[1][1], m[1][2]];
    let mut deltas = host_f32(&table.deltas);
    for (frame, m) in [(0, &a), (3, &b)] {
        for joint in 0..2 {
            for (c, v) in six(m).iter().enumerate() {
                deltas[(frame * 2 + joint) * 6 + c] = *v as f32;
            }
        }
    }
    table.deltas = Tensor::from_data(TensorData::new(deltas, [6, 2, 6]), &device);
    let mut trans = vec![0.0f32; 18];
    trans[0..3].copy_from_slice(&[0.3, 0.0, -0.3]);
    trans[9..12].copy_from_slice(&[0.0, 0.6, 0.3]);
    table.translation_deltas = Tensor::from_data(TensorData::new(trans, [6, 3]), &device);
    for (frame, expected_delta, expected_trans) in [
        (1, slerp(&a, &b, 1.0 / 3.0), [0.2, 0.2, -0.1]),
        (2, slerp(&a, &b, 2.0 / 3.0), [0.1, 0.4, 0.1]),
        (4, b, [0.0, 0.6, 0.3]),
        (5, b, [0.0, 0.6, 0.3]),
    ] {
        let pose = table.frame(frame, false);
        let rot = host_f32(&pose.rotations);
        for joint in 0..2 {
            let p = prior.pose(frame);
            let prior_rot = axis_angle_matrix([p[3 * joint], p[3 * joint + 1], p[3 * joint + 2]]);
            let expected = mul(&prior_rot, &expected_delta);
            for r in 0..3 {
                for c in 0..3 {
                    let got = rot[joint * 9 + r * 3 + c] as f64;
                    assert!(
                        (got - expected[r][c]).abs() < 1e-5,
                        "frame {frame} joint {joint}: {got} vs {}",
                        expected[r][c]
                    );
                }
            }
        }
        let t = host_f32(&pose.translation);
        let truth = prior.translation(frame);
        for k in 0..3 {
            let want = truth[k] + expected_trans[k];
            assert!((t[k] as f64 - want).abs() < 1e-5, "frame {frame}: {t:?}");
        }
    }
    // Smoothness: zero on a constant track, positive once trained rows differ.
    table.begin_step();
    let smooth = scalar(table.smoothness().unwrap());
    assert!(smooth > 0.0, "rows 0 and 3 differ: {smooth}");
    // Distance from the prior: rows 0 and 3 of 6 moved by (A, t₀) and (B, t₃).
    let six_a = six(&a);
    let six_b = six(&b);
    let identity = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
    let sq = |v: [f64; 6]| (0..6).map(|c| (v[c] - identity[c]).powi(2)).sum::<f64>();
    let expected =
        2.0 * (sq(six_a) + sq(six_b)) / (6.0 * 2.0 * 6.0) + (0.09 + 0.09 + 0.36 + 0.09) / 18.0;
    let distance = scalar(table.prior_distance().unwrap());
    assert!(
        (distance - expected).abs() < 1e-5,
        "{distance} vs {expected}"
    );
    let fresh = {
        let mut t = PoseTable::new(
            &prior,
            vec![true; 6],
            Refinement {
                rotations: true,
                translation: true,
                sequence_offset: true,
            },
            &device,
        );
        t.begin_step();
        (
            scalar(t.smoothness().unwrap()),
            scalar(t.prior_distance().unwrap()),
        )
    };
    assert_eq!(fresh, (0.0, 0.0));
}

#[test]
fn joints_regress_from_the_gaussians_as_from_the_mesh() {
    let model = &builtin_body().model;
    let prior = PoseSequence {
        joints: 24,
        poses: vec![0.0; 72],
        translations: vec![0.0; 3],
        betas: vec![0.0; model.shape_count()],
        shape_count: model.shape_count(),
        fps: None,
    };
    for (placement, tolerance) in [(Placement::Vertices, 1e-5), (Placement::PerFace, 0.02)] {
        let config = SkinnedConfig {
            placement,
            per_face: 1,
            canonical_pose: CanonicalPose::TPose,
            ..SkinnedConfig::default()
        };
        let node = node_of(model, &prior, vec![true], &config).unwrap();
        let from_gaussians = node.regress_joints(node.canonical_set().means.clone());
        let from_mesh = node.joint_positions(0);
        let err = scalar((from_gaussians - from_mesh).abs().max());
        assert!(err < tolerance, "{placement:?}: joints differ by {err} m");
    }
}

#[test]
fn a_track_that_does_not_fit_the_body_is_named() {
    let mut rng = Rng(1);
    let build = |prior: &PoseSequence, trained: Vec<bool>| {
        node_of(&tiny_body(), prior, trained, &SkinnedConfig::default())
            .err()
            .unwrap_or_default()
    };
    let message = build(&track(24, 2, &mut rng, 0.1), vec![true; 2]);
    assert!(
        message.contains("24 joints") && message.contains("has 3"),
        "{message}"
    );
    let message = build(&track(3, 2, &mut rng, 0.1), vec![true; 5]);
    assert!(
        message.contains("5 frames") && message.contains("has 2"),
        "{message}"
    );
}

/// An avatar loaded into a node built on another motion takes its skeleton with its shape: at
/// the canonical pose it still reproduces its canonical Gaussians.
#[test]
fn a_loaded_avatar_keeps_the_skeleton_of_its_shape() {
    use splatzoo_train::checkpoint::Checkpoint;
    let device = Device::flex();
    let model = &builtin_body().model;
    let s = model.shape_count();
    let canonical_pose = CanonicalPose::DaPose;
    let prior = PoseSequence {
        joints: model.joint_count(),
        poses: canonical_pose.axis_angles(model.joint_count()),
        translations: vec![0.0; 3],
        betas: vec![0.0; s],
        shape_count: s,
        fps: None,
    };
    let config = SkinnedConfig {
        canonical_pose,
        per_face: 1,
        refine_shape: false,
        ..SkinnedConfig::default()
    };
    let build = || node_of(model, &prior, vec![true], &config).unwrap();
    let mut checkpoint = Checkpoint::default();
    build().save(&mut checkpoint, "person");
    // A trained shape far from the new prior's zero shape.
    let betas = checkpoint.tensors.get_mut("person.betas").unwrap();
    betas
        .1
        .iter_mut()
        .enumerate()
        .for_each(|(k, b)| *b = if k % 2 == 0 { 1.5 } else { -1.5 });
    let mut node = build();
    node.load_avatar(&checkpoint, "person", &device).unwrap();
    assert_eq!(host_f32(node.betas())[0], 1.5);
    let canonical = node.canonical_set().splats();
    let posed = node.posed(canonical.clone(), 0).splats;
    let diff = scalar((posed.means - canonical.means).abs().max());
    assert!(
        diff < 1e-4,
        "the canonical pose moves Gaussians by {diff} m"
    );
}
