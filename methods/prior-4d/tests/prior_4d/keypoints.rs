//! Stage C's keypoint fit: the capture's BODY_25 keypoints are the true camera-space body
//! projected (exactly, without noise; with the configured misses otherwise), and refining the
//! noisy body prior on them brings it closer to the truth — with the pull towards the prior;
//! without it the 3-D pose moves away; bad knobs are refused by name.

use crate::trainer::into_stage_d;
use burn::tensor::Device;
use splatzoo_models::body::builtin_body;
use splatzoo_models::body::fit::{KeypointTarget, body25_targets};
use splatzoo_prior_4d::Prior4d;
use splatzoo_prior_4d::body_fit::{BodyFitConfig, refine_on_keypoints};
use splatzoo_prior_4d::data::{Prior4dCapture, Prior4dDataConfig};
use splatzoo_train::avatar::track_joints;
use splatzoo_train::harness::Method;
use splatzoo_train::harness::extremes::{StepOutcome, after_steps, assert_stable};
use splatzoo_train::host_f32;

fn capture(noise_px: f64, miss_rate: f64) -> Prior4dCapture {
    Prior4dDataConfig {
        width: 80,
        height: 60,
        acting_frames: 4,
        scene_views: 4,
        scan_views: 4,
        supersample: 1,
        keypoint_noise_px: noise_px,
        keypoint_miss_rate: miss_rate,
        ..Prior4dDataConfig::default()
    }
    .build(&Device::flex())
    .expect("a tiny capture")
}

#[test]
fn keypoints_are_the_true_body_projected() {
    let exact = capture(0.0, 0.0);
    let device = Device::flex();
    let model = &builtin_body().model;
    // Camera-space truth: the keypoints of joints must be its joints through the intrinsics.
    let truth = exact.truth.as_ref().expect("the synthetic capture's truth");
    let joints = host_f32(&track_joints(model, &truth.acting_motion, &device));
    let j = model.joint_count();
    let targets = body25_targets(|n| builtin_body().landmark(n));
    let mut checked = 0;
    for (t, keypoints) in exact.acting_keypoints.iter().enumerate() {
        assert_eq!(keypoints.len(), 25);
        let camera = &exact.acting[t].camera;
        for (slot, target) in targets.iter().enumerate() {
            let Some(KeypointTarget::Joint(k)) = target else {
                continue;
            };
            let p = &joints[3 * (t * j + k)..3 * (t * j + k) + 3];
            let u = camera.fx * p[0] / p[2] + camera.cx;
            let v = camera.fy * p[1] / p[2] + camera.cy;
            let seen = u >= 0.0 && v >= 0.0 && u < 80.0 && v < 60.0;
            let [x, y, c] = keypoints[slot];
            if seen {
                assert!(
                    (x - u).abs() < 0.05 && (y - v).abs() < 0.05 && c > 0.0,
                    "frame {t} slot {slot}: ({x}, {y}) against ({u}, {v})"
                );
                checked += 1;
            } else {
                assert_eq!(
                    keypoints[slot], [0.0; 3],
                    "frame {t} slot {slot} off the image"
                );
            }
        }
    }
    assert!(checked >= 4 * 10, "{checked} joints on the images");
    // Half the points missed: about half reported.
    let missing = capture(0.0, 0.5);
    let count = |c: &Prior4dCapture| -> usize {
        c.acting_keypoints
            .iter()
            .flatten()
            .filter(|k| k[2] > 0.0)
            .count()
    };
    let (all, kept) = (count(&exact), count(&missing));
    assert!(
        (0.3..0.7).contains(&(kept as f64 / all as f64)),
        "{kept} of {all} reported"
    );
}

#[test]
fn refining_the_prior_on_keypoints_moves_it_towards_the_truth() {
    let noisy = capture(2.0, 0.05);
    let config = BodyFitConfig {
        keypoints: true,
        ..BodyFitConfig::default()
    };
    let (refined, report) = refine_on_keypoints(&noisy, &config, &Device::flex()).unwrap();
    eprintln!("{}", report.line());
    assert_eq!((report.fitted, report.kept), (4, 0));
    assert_eq!(refined.frames(), noisy.acting_prior.frames());
    // Shapes are held; poses and translations move.
    assert_eq!(refined.betas, noisy.acting_prior.betas);
    assert_ne!(refined.poses, noisy.acting_prior.poses);
    assert!(
        report.fitted_reprojection_px < 0.8 * report.prior_reprojection_px,
        "{report:?}"
    );
    let mpjpe = report.mpjpe.as_ref().expect("scored against the truth");
    assert!(
        mpjpe.fitted_aligned_mm < 0.95 * mpjpe.prior_aligned_mm && mpjpe.fitted_mm < mpjpe.prior_mm,
        "{report:?}"
    );
    // Without the pull towards the prior (SMPLify's objective alone) the fit matches the
    // keypoints better still but moves the 3-D pose away from the truth: one view cannot tell a
    // limb's depth.
    let free = BodyFitConfig {
        prior_weight: 0.0,
        ..config
    };
    let (_, unpulled) = refine_on_keypoints(&noisy, &free, &Device::flex()).unwrap();
    eprintln!("without the pull: {}", unpulled.line());
    assert!(
        unpulled.fitted_reprojection_px < report.fitted_reprojection_px
            && unpulled.mpjpe.as_ref().unwrap().fitted_aligned_mm > mpjpe.prior_aligned_mm,
        "{unpulled:?}"
    );
}

#[test]
fn stage_d_starts_from_the_refined_prior_and_bad_knobs_are_named() {
    let mut config = into_stage_d(5);
    config.body_fit.keypoints = true;
    config.body_fit.iterations = 20;
    let method = Prior4d::new(config.clone(), &Device::flex()).expect("a tiny run");
    assert!(
        method
            .capture
            .decisions
            .iter()
            .any(|d| d.starts_with("stage C: body prior refined on the keypoints")),
        "{:?}",
        method.capture.decisions
    );
    let outcome = assert_stable(
        "keypoint-refined prior",
        after_steps::<Prior4d>(config.clone(), &Device::flex(), 5),
    );
    assert!(matches!(outcome, StepOutcome::Finite { .. }), "{outcome:?}");
    let mut bad = config;
    bad.body_fit.iterations = 0;
    let outcome = after_steps::<Prior4d>(bad, &Device::flex(), 1).unwrap();
    assert!(
        matches!(&outcome, StepOutcome::Refused(e) if e.contains("body_fit.iterations")),
        "{outcome:?}"
    );
}
