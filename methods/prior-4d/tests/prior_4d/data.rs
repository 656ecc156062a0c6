//! The synthetic Prior-4D capture: three videos and an evaluation camera with what the claims
//! need — floor pixels in the scene scan, the person in every acting frame, a camera-space body
//! prior that lands on the person, given normals facing the camera, the scale gap.

use crate::values;
use burn::tensor::Device;
use splatzoo_models::body::builtin_body;
use splatzoo_prior_4d::data::{Prior4dCapture, Prior4dDataConfig};
use splatzoo_train::avatar::{project, track_joints};

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
    // The camera-space truth lands on the person: its pelvis projects inside the mask's box.
    let joints = values(track_joints(
        &builtin_body().model,
        &capture.acting_truth,
        &Device::flex(),
    ));
    for (t, frame) in capture.acting.iter().enumerate() {
        let pelvis = [joints[t * 72], joints[t * 72 + 1], joints[t * 72 + 2]];
        let mut camera = frame.true_camera;
        camera.world_to_camera = [
            [1.0, 0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, 0.0],
        ];
        let (u, v, z) = project(&camera, &[pelvis])[0];
        let mask = values(frame.mask.clone());
        let inside: Vec<(usize, usize)> = (0..mask.len())
            .filter(|&p| mask[p] > 0.5)
            .map(|p| (p % 80, p / 80))
            .collect();
        let (x0, x1) = (
            inside.iter().map(|p| p.0).min().unwrap(),
            inside.iter().map(|p| p.0).max().unwrap(),
        );
        let (y0, y1) = (
            inside.iter().map(|p| p.1).min().unwrap(),
            inside.iter().map(|p| p.1).max().unwrap(),
        );
        assert!(z > 0.0, "frame {t}: pelvis behind the camera");
        assert!(
            u >= x0 as f32 - 2.0
                && u <= x1 as f32 + 3.0
                && v >= y0 as f32 - 2.0
                && v <= y1 as f32 + 3.0,
            "frame {t}: pelvis at ({u:.1}, {v:.1}) outside the person's box {x0}..{x1} × {y0}..{y1}"
        );
    }
    // The scale gap: scene-unit camera centres are metre centres / scale.
    assert_eq!(capture.scale, 0.7);
}
