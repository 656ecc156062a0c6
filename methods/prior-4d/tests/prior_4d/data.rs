//! The synthetic Prior-4D capture: three videos and an evaluation camera with what the claims
//! need — floor pixels in the scene scan, the person in every acting frame, given normals facing
//! the camera; camera-space body tracks that pose the same body; scene units.

use crate::{Rng, fresh_seed, values};
use burn::tensor::Device;
use splatzoo_datasets::pose_sequence::PoseSequence;
use splatzoo_models::body::builtin_body;
use splatzoo_prior_4d::data::occluder::stopping_frame;
use splatzoo_prior_4d::data::{Prior4dCapture, Prior4dDataConfig, scaled_camera, to_camera_space};
use splatzoo_rasterizer::Camera;
use splatzoo_train::avatar::track_joints;

pub fn tiny_capture() -> Prior4dCapture {
    Prior4dDataConfig {
        width: 80,
        height: 60,
        acting_frames: 6,
        scene_views: 8,
        scan_views: 6,
        supersample: 1,
        ..Prior4dDataConfig::default()
    }
    .build(&Device::flex())
    .expect("a tiny capture")
}

#[test]
fn the_capture_has_what_the_claims_need() {
    let capture = tiny_capture();
    assert_eq!(capture.scene_scan.len(), 8);
    assert_eq!(capture.human_scan.len(), 6);
    assert_eq!(capture.acting.len(), 6);
    assert_eq!(capture.eval.len(), 6);
    // Floor pixels in every scene-scan view.
    for (k, view) in capture.scene_scan.iter().enumerate() {
        let share = view.ground.area() as f64 / (80.0 * 60.0);
        assert!(
            share > 0.05,
            "scan view {k}: {share:.3} of its pixels are floor"
        );
    }
    // The person in every acting and scan frame; normals unit and facing the camera.
    for (t, frame) in capture.acting.iter().enumerate() {
        let mask = values(frame.mask.clone());
        let area = mask.iter().filter(|&&m| m > 0.5).count();
        assert!(area > 30, "acting frame {t}: {area} person pixels");
        let normals = values(
            frame
                .normals
                .clone()
                .expect("the synthetic capture's normals"),
        );
        let facing = (0..mask.len())
            .filter(|&p| normals[3 * p + 2] < 0.0)
            .count();
        let on = (0..mask.len())
            .filter(|&p| normals[3 * p..3 * p + 3].iter().any(|v| *v != 0.0))
            .count();
        assert!(
            on > 0 && facing as f64 > 0.8 * on as f64,
            "frame {t}: {facing} of {on} face the camera"
        );
    }
}

/// A world body track in each frame's camera frame poses, by LBS, exactly the world body seen
/// from that camera (the root turns about the rest pelvis, so its translation must move too).
#[test]
fn camera_space_tracks_pose_the_same_body() {
    let seed = fresh_seed();
    let mut rng = Rng(seed);
    let model = &builtin_body().model;
    let frames = 4;
    let track = PoseSequence {
        joints: 24,
        poses: (0..frames * 72).map(|_| rng.range(-0.6, 0.6)).collect(),
        translations: (0..frames * 3).map(|_| rng.range(-1.0, 1.0)).collect(),
        betas: (0..frames * 4).map(|_| rng.range(-1.5, 1.5)).collect(),
        shape_count: 4,
        fps: None,
    };
    let cameras: Vec<Camera> = (0..frames)
        .map(|_| {
            let position = [0.0; 3].map(|_| rng.range(-4.0, 4.0) as f32);
            let target = [0.0; 3].map(|_| rng.range(-0.5, 0.5) as f32);
            Camera::look_at(position, target, [0.0, 1.0, 0.0], 60.0, 64, 48)
        })
        .collect();
    let device = Device::flex();
    let world = values(track_joints(model, &track, &device));
    let local = values(track_joints(
        model,
        &to_camera_space(&track, &cameras, model),
        &device,
    ));
    for (t, camera) in cameras.iter().enumerate() {
        let m = camera.world_to_camera;
        for j in 0..24 {
            let p = &world[(t * 24 + j) * 3..(t * 24 + j) * 3 + 3];
            let want: [f32; 3] =
                std::array::from_fn(|r| m[r][0] * p[0] + m[r][1] * p[1] + m[r][2] * p[2] + m[r][3]);
            let got = &local[(t * 24 + j) * 3..(t * 24 + j) * 3 + 3];
            for c in 0..3 {
                assert!(
                    (got[c] - want[c]).abs() < 1e-4,
                    "seed {seed}: frame {t} joint {j}: {got:?} vs {want:?}"
                );
            }
        }
    }
    // Scene units: a camera's centre scales with the scene.
    let scaled = scaled_camera(&cameras[0], 0.7);
    for c in 0..3 {
        assert!((scaled.position()[c] - 0.7 * cameras[0].position()[c]).abs() < 1e-5);
    }
}

/// The default acting video, 60 frames at 96×72 (the whole clip), with or without the cabinet;
/// masks without jitter.
fn acting_capture(occluder: bool) -> Prior4dCapture {
    Prior4dDataConfig {
        width: 96,
        height: 72,
        scene_views: 4,
        scan_views: 4,
        supersample: 1,
        mask_jitter: 0,
        occluder,
        ..Prior4dDataConfig::default()
    }
    .build(&Device::flex())
    .expect("an acting capture")
}

fn rotation_of(camera: &Camera) -> glam::DMat3 {
    let m = camera.world_to_camera;
    glam::DMat3::from_cols_array(&[
        f64::from(m[0][0]),
        f64::from(m[1][0]),
        f64::from(m[2][0]),
        f64::from(m[0][1]),
        f64::from(m[1][1]),
        f64::from(m[2][1]),
        f64::from(m[0][2]),
        f64::from(m[1][2]),
        f64::from(m[2][2]),
    ])
}

/// Fig. 5's condition for the avatar prior: the hand-held acting camera and the person turn
/// together, so every acting frame films her within about 50° of her front, while the fixed
/// evaluation camera sees her back (more than 90° from her front) in some frames.
#[test]
fn the_acting_video_films_the_front_and_the_evaluation_camera_sees_the_back() {
    let capture = acting_capture(false);
    let truth = capture
        .truth
        .as_ref()
        .expect("the synthetic capture's truth");
    let (mut acting, mut evaluation) = (Vec::new(), Vec::new());
    for (t, true_camera) in truth.acting_cameras.iter().enumerate() {
        let root = truth.acting_motion.pose(t);
        let in_camera = glam::DQuat::from_scaled_axis(glam::DVec3::new(root[0], root[1], root[2]))
            * glam::DVec3::Z;
        // −z in a camera's frame: 1 facing it, −1 showing it her back.
        acting.push(-in_camera.z);
        let world = rotation_of(true_camera).transpose() * in_camera;
        evaluation.push(-(rotation_of(&capture.eval[t].camera) * world).z);
    }
    let least = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
    assert!(
        least(&acting) > 0.6,
        "acting video: the least frontal frame has cos {:.3}",
        least(&acting)
    );
    assert!(
        least(&evaluation) < 0.0,
        "evaluation camera: the least frontal frame has cos {:.3}",
        least(&evaluation)
    );
}

/// The cabinet stands between the acting camera and where the person stops: halfway through
/// her standing part it hides a good part of her (the legs), leaves the rest in view, and the
/// rows it hides are the lowest.
#[test]
fn the_cabinet_hides_the_standing_persons_legs() {
    use splatzoo_datasets::synth::{Preset, SceneConfig};
    let motion = SceneConfig {
        frames: Some(60),
        ..SceneConfig::new(Preset::Monocular, 0)
    }
    .build(&Device::flex())
    .people[0]
        .motion
        .clone();
    let frame = (stopping_frame(&motion) + 59) / 2;
    let mask_rows = |capture: &Prior4dCapture| {
        let mask = values(capture.acting[frame].mask.clone());
        let rows: Vec<usize> = (0..mask.len())
            .filter(|&p| mask[p] > 0.5)
            .map(|p| p / 96)
            .collect();
        rows
    };
    let open = mask_rows(&acting_capture(false));
    let hidden = mask_rows(&acting_capture(true));
    assert!(
        !hidden.is_empty() && (hidden.len() as f64) < 0.85 * open.len() as f64,
        "frame {frame}: {} person pixels behind the cabinet against {} in the open",
        hidden.len(),
        open.len()
    );
    let lowest = |rows: &[usize]| rows.iter().copied().max().unwrap_or(0);
    assert!(
        lowest(&hidden) + 3 < lowest(&open),
        "frame {frame}: the lowest visible row {} against {} in the open",
        lowest(&hidden),
        lowest(&open)
    );
}

/// `data.pose_clothing`: the acting video's person wears clothing that moves with her pose, so
/// her frames change where her knees bend (her pixels, and the room only at her shadow's
/// edge), while the neutral-pose human scan barely changes.
#[test]
fn pose_dependent_clothing_changes_the_acting_frames_where_the_knees_bend() {
    let build = |pose_clothing: bool| {
        Prior4dDataConfig {
            width: 64,
            height: 48,
            acting_frames: 12,
            scene_views: 4,
            scan_views: 4,
            supersample: 1,
            mask_jitter: 0,
            pose_clothing,
            ..Prior4dDataConfig::default()
        }
        .build(&Device::flex())
        .expect("an acting capture")
    };
    let (plain, dressed) = (build(false), build(true));
    let pixels = |t: &burn::tensor::Tensor<3>| t.clone().into_data().try_into_vec::<f32>().unwrap();
    let mut changed_frames = 0;
    for (a, b) in plain.acting.iter().zip(&dressed.acting) {
        let (x, y) = (pixels(&a.image), pixels(&b.image));
        let mask = a.mask.clone().into_data().try_into_vec::<f32>().unwrap();
        // Her silhouette grows by up to 15 mm (a third of a pixel here): pixels next to it may
        // turn, so "the room" is what lies over a pixel away from her mask.
        let (w, h) = (64usize, 48usize);
        let near = |i: usize| {
            let (r, c) = ((i / w) as i64, (i % w) as i64);
            (-1..=1).any(|dr| {
                (-1..=1).any(|dc| {
                    let (rr, cc) = (r + dr, c + dc);
                    (0..h as i64).contains(&rr)
                        && (0..w as i64).contains(&cc)
                        && mask[rr as usize * w + cc as usize] > 0.0
                })
            })
        };
        let mut room_changed = 0;
        let mut on_person = 0.0f32;
        for (i, (p, q)) in x.iter().zip(&y).enumerate() {
            let d = (p - q).abs();
            if near(i / 3) {
                on_person = on_person.max(d);
            } else {
                room_changed += usize::from(d > 0.01);
            }
        }
        // Only the edges of her cast shadow may move.
        assert!(
            room_changed < 10,
            "{room_changed} values of the room changed"
        );
        changed_frames += usize::from(on_person > 0.01);
    }
    assert!(
        changed_frames >= 3,
        "only {changed_frames} frames changed on the person"
    );
    for (a, b) in plain.human_scan.iter().zip(&dressed.human_scan) {
        let (x, y) = (pixels(&a.image), pixels(&b.image));
        let most = x
            .iter()
            .zip(&y)
            .map(|(p, q)| (p - q).abs())
            .fold(0.0f32, f32::max);
        assert!(most < 0.05, "the neutral scan changed by {most}");
    }
}

/// `data.textureless_wall`: a plain panel covers the wall behind her in the evaluation view, so
/// the room's pixels there lose the wallpaper's pattern (its local contrast falls), while the
/// scene scan films it too (it is part of the room).
#[test]
fn the_textureless_wall_is_behind_her_in_the_evaluation_view() {
    let build = |textureless_wall: bool| {
        Prior4dDataConfig {
            width: 96,
            height: 72,
            acting_frames: 2,
            scene_views: 8,
            scan_views: 4,
            supersample: 1,
            mask_jitter: 0,
            textureless_wall,
            ..Prior4dDataConfig::default()
        }
        .build(&Device::flex())
        .expect("a capture")
    };
    let (papered, painted) = (build(false), build(true));
    let (w, h) = (96usize, 72usize);
    let rgb = |t: &burn::tensor::Tensor<3>| t.clone().into_data().try_into_vec::<f32>().unwrap();
    let (before, after) = (rgb(&papered.eval[0].image), rgb(&painted.eval[0].image));
    // The panel's pixels: where the two views differ (and their right neighbour too).
    let differs = |i: usize| (0..3).any(|k| (before[3 * i + k] - after[3 * i + k]).abs() > 0.02);
    let panel: Vec<usize> = (0..w * h)
        .filter(|&i| i % w + 1 < w && differs(i) && differs(i + 1))
        .collect();
    assert!(
        panel.len() * 20 > w * h,
        "the panel covers only {} pixels",
        panel.len()
    );
    // Mean |horizontal difference| there: the wallpaper's pattern, then none.
    let contrast = |rgb: &[f32]| {
        panel
            .iter()
            .map(|&i| {
                (0..3)
                    .map(|k| f64::from((rgb[3 * (i + 1) + k] - rgb[3 * i + k]).abs()))
                    .sum::<f64>()
            })
            .sum::<f64>()
            / panel.len() as f64
    };
    let (papered_contrast, painted_contrast) = (contrast(&before), contrast(&after));
    assert!(
        painted_contrast < 0.5 * papered_contrast,
        "local contrast {papered_contrast:.4} → {painted_contrast:.4}"
    );
    let changed = |a: &burn::tensor::Tensor<3>, b: &burn::tensor::Tensor<3>| {
        let (a, b) = (
            a.clone().into_data().try_into_vec::<f32>().unwrap(),
            b.clone().into_data().try_into_vec::<f32>().unwrap(),
        );
        a.iter()
            .zip(&b)
            .filter(|(x, y)| (*x - *y).abs() > 0.02)
            .count()
    };
    let scan_changed: usize = papered
        .scene_scan
        .iter()
        .zip(&painted.scene_scan)
        .map(|(a, b)| changed(&a.image, &b.image))
        .sum();
    assert!(scan_changed > 0, "the scene scan never sees the panel");
}
