//! A user's body model as the avatar's body (`data.body_model`, `data.body_marks`): a file these
//! tests write in the SMPL-H layout (the built-in body with 28 hand joints added, 52 joints, a
//! topology no landmark table knows, so it brings a marks file). It must pose exactly as the
//! body it extends, be fitted to the portrait, place the face camera and mask from its marks,
//! and carry the trainer and the animation.

use crate::common::tiny_portrait;
use splatzoo_aagaussian::Aag;
use splatzoo_aagaussian::animate::{AnimationConfig, animate, builtin_motion};
use splatzoo_aagaussian::body_prior::AvatarBody;
use splatzoo_aagaussian::config::AagConfig;
use splatzoo_aagaussian::data::{PortraitCapture, PortraitConfig};
use splatzoo_datasets::synth::scene::posed_once;
use splatzoo_models::body::{BodyKind, BodyModel, SurfaceMarks, builtin_body, save_npz};
use splatzoo_train::backend::Backend;
use splatzoo_train::harness::Method;
use std::path::{Path, PathBuf};

/// SMPL-H's hand joints per side, children of the wrists (20, 21) in a chain of three.
const FINGER_JOINTS: usize = 15;

/// The built-in body with SMPL-H's 30 finger joints in place of SMPL's two hand joints: joints
/// 22 and 23 and the new ones sit at the wrists and skin nothing, so every pose of the 22 body
/// joints moves the mesh exactly as the built-in body's does with its hands at rest.
fn smplh_layout() -> BodyModel {
    let model = builtin_body().model.clone();
    let (v, j) = (model.vertex_count(), model.joint_count());
    let joints = 22 + 2 * FINGER_JOINTS;
    let mut parents: Vec<Option<usize>> = model.parents[..22].to_vec();
    for side in 0..2 {
        let wrist = 20 + side;
        for _finger in 0..5 {
            for k in 0..3 {
                let here = parents.len();
                parents.push(Some(if k == 0 { wrist } else { here - 1 }));
            }
        }
    }
    assert_eq!(parents.len(), joints);
    let row = |k: usize| &model.joint_regressor[k * v..(k + 1) * v];
    let mut regressor = Vec::with_capacity(joints * v);
    for k in 0..joints {
        let source = if k < 22 {
            k
        } else {
            20 + (k - 22) / FINGER_JOINTS
        };
        regressor.extend_from_slice(row(source));
    }
    let mut weights = vec![0.0f32; v * joints];
    for i in 0..v {
        weights[i * joints..i * joints + 22]
            .copy_from_slice(&model.skin_weights[i * j..i * j + 22]);
        // SMPL's hand joints skin the hands: give that weight to the wrists.
        weights[i * joints + 20] += model.skin_weights[i * j + 22];
        weights[i * joints + 21] += model.skin_weights[i * j + 23];
    }
    let mut names: Vec<String> = model.joint_names[..22].to_vec();
    for side in ["left", "right"] {
        for finger in ["index", "middle", "pinky", "ring", "thumb"] {
            for k in 1..=3 {
                names.push(format!("{side}_{finger}{k}"));
            }
        }
    }
    BodyModel {
        kind: BodyKind::SmplH,
        joint_regressor: regressor,
        parents,
        skin_weights: weights,
        pose_dirs: None,
        joint_names: names,
        ..model
    }
}

/// Writes the SMPL-H-layout body and a marks file with the built-in landmarks (the face region
/// left to the rule) into `dir`.
fn write_user_body(dir: &Path) -> (PathBuf, PathBuf) {
    let model_path = dir.join("smplh_layout.npz");
    save_npz(&smplh_layout(), &model_path).expect("saved");
    let landmarks: Vec<String> = SurfaceMarks::builtin()
        .landmarks
        .iter()
        .map(|(n, v)| format!("\"{n}\": {v}"))
        .collect();
    let marks_path = dir.join("marks.json");
    std::fs::write(
        &marks_path,
        format!("{{\"landmarks\": {{{}}}}}", landmarks.join(", ")),
    )
    .expect("written");
    (model_path, marks_path)
}

#[test]
fn a_user_smplh_layout_body_carries_the_avatar() {
    let device = Backend::Flex.device();
    let dir = tempfile::tempdir().expect("temp dir");
    let (model_path, marks_path) = write_user_body(dir.path());
    let user = AvatarBody::load(Some(&model_path), Some(&marks_path)).expect("loaded");
    assert_eq!(user.model.joint_count(), 52);
    assert_eq!(user.source, model_path.display().to_string());

    // Posing: the 52-joint body in any 72-D pose is the built-in body with its hands at rest.
    let motion = builtin_motion(6, 6.0);
    let betas = vec![0.4, -0.3, 0.2];
    for t in [1, 4] {
        let mut pose = [0.0; 72];
        pose.copy_from_slice(motion.pose(t));
        let posed = user.posed(&betas, &pose, &device);
        pose[66..].fill(0.0);
        let builtin = posed_once(&betas, &pose, &device);
        let worst = posed
            .vertices
            .iter()
            .zip(&builtin.vertices)
            .flat_map(|(a, b)| (0..3).map(move |c| (a[c] - b[c]).abs()))
            .fold(0.0f32, f32::max);
        assert!(worst < 1e-4, "frame {t}: {worst} m apart");
    }

    // The capture: fitted, the face where the marks put it (measured: 2.57 px and +2.4 % of the
    // height, the built-in body's own fit, since the 22 body joints keep SMPL's angle limits;
    // 34 of 256 face pixels; face cameras 0.006 units apart).
    let config = PortraitConfig {
        body_fit: true,
        body_model: Some(model_path.clone()),
        body_marks: Some(marks_path.clone()),
        ..tiny_portrait(16)
    };
    let capture = PortraitCapture::build(&config, &device).expect("a capture");
    let fit = capture.body_fit.as_ref().expect("fitted");
    assert!(fit.reprojection_rms_px < 4.0, "{fit:?}");
    assert!(fit.height_error.expect("graded").abs() < 0.07, "{fit:?}");
    assert_eq!(capture.canonical.len(), user.model.vertex_count());
    assert_eq!(capture.body.faces.len(), user.model.face_count());
    let pose = config.canonical.axis_angle();
    let again = capture.posed_body(&pose, &device);
    for (a, b) in again.iter().zip(&capture.canonical) {
        assert!((0..3).all(|c| (a[c] - b[c]).abs() < 1e-5));
    }
    let face_pixels = capture.face_mask.iter().filter(|m| **m).count();
    assert!(
        face_pixels * 10 > capture.face_mask.len(),
        "{face_pixels} face pixels"
    );
    // The same portrait fitted on the built-in body places the face camera within 2 cm (in
    // the normalised units, 1.556 per body height): the rule's face is the hand-made one's.
    let builtin = PortraitCapture::build(
        &PortraitConfig {
            body_fit: true,
            ..tiny_portrait(16)
        },
        &device,
    )
    .expect("a capture");
    let centre = |c: &PortraitCapture| -> [f64; 3] {
        let m = &c.face_camera.world_to_camera;
        std::array::from_fn(|k| -(0..3).map(|r| f64::from(m[r][k] * m[r][3])).sum::<f64>())
    };
    let (a, b) = (centre(&capture), centre(&builtin));
    let apart = (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt();
    assert!(
        apart < 0.02,
        "face cameras {apart} units apart: {a:?} {b:?}"
    );

    // The trainer steps on it, and the avatar animates on it.
    let mut aag = AagConfig {
        gaussians: 300,
        batch: 2,
        render_size: 8,
        data: config,
        ..AagConfig::default()
    };
    aag.face.start = 1;
    aag.face.probability = 1.0;
    let mut method = Aag::new(aag, &device).expect("assembles");
    for _ in 0..3 {
        let record = method.trainer.train_step().expect("a step");
        assert!(record.loss.is_finite(), "{record:?}");
    }
    let scores = animate(
        &method.trainer.node.set,
        &method.trainer.capture,
        &builtin_motion(3, 6.0),
        &AnimationConfig {
            size: 16,
            azimuths: vec![0.0],
            ..AnimationConfig::default()
        },
        None,
    )
    .expect("animated");
    assert!(
        scores
            .identity
            .as_ref()
            .is_some_and(|kept| kept.frame_psnr.iter().all(|p| p.is_finite())),
        "{scores:?}"
    );
}

/// Misuse is named: a marks file without a model, a model the marks do not fit, and
/// `body_fit = false` (the identity's built-in shape) with a user's model.
#[test]
fn user_body_misuse_is_named() {
    let dir = tempfile::tempdir().expect("temp dir");
    let (model_path, marks_path) = write_user_body(dir.path());
    let message = AvatarBody::load(None, Some(&marks_path))
        .expect_err("marks alone")
        .to_string();
    assert!(message.contains("data.body_model"), "{message}");
    let message = AvatarBody::load(Some(&model_path), None)
        .expect_err("no table for this topology")
        .to_string();
    assert!(
        message.contains("smplh_layout.npz") && message.contains("marks file"),
        "{message}"
    );
    let config = PortraitConfig {
        body_fit: false,
        body_model: Some(model_path),
        ..tiny_portrait(8)
    };
    let message = config.validate().expect_err("no true shape");
    assert!(message.contains("body_fit"), "{message}");
}
