//! The synthetic Prior-4D capture: three videos and an evaluation camera with what the claims
//! need — floor pixels in the scene scan, the person in every acting frame, given normals facing
//! the camera; camera-space body tracks that pose the same body; scene units.

use crate::{Rng, fresh_seed, values};
use burn::tensor::Device;
use splatzoo_datasets::pose_sequence::PoseSequence;
use splatzoo_models::body::builtin_body;
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
        let normals = values(frame.normals.clone());
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
