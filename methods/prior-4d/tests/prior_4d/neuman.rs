//! A real capture's path (`data.capture`): the synthetic acting video written as NeuMan's
//! preprocessing leaves a scene (`splatzoo_datasets::fixtures::write_neuman_scene`: COLMAP text
//! model, images, segmentations, SMPL fits and alignments placing the camera-space body in
//! COLMAP's world at the scene's scale), read back as Prior-4D's acting video with its own
//! scene. What is read is known exactly: the cameras, the camera-space body prior, the masks;
//! the feet rule's ground pixels land on the true floor; the four stages run on it with the
//! truth scores absent; bad folders are named.

use crate::data::tiny_capture;
use crate::trainer::into_stage_d;
use crate::values;
use burn::tensor::Device;
use glam::{DMat3, DVec3};
use splatzoo_datasets::fixtures::{NeumanFrame, write_neuman_scene};
use splatzoo_datasets::formats::Similarity;
use splatzoo_models::body::builtin_body;
use splatzoo_prior_4d::Prior4d;
use splatzoo_prior_4d::data::{Prior4dCapture, Prior4dDataConfig};
use splatzoo_train::avatar::track_joints;
use splatzoo_train::harness::Method;
use splatzoo_train::host_f32;
use std::path::Path;

/// The held-out frames the test split names.
const TEST: [usize; 2] = [2, 5];

/// NeuMan's fits carry SMPL's 10 shape coefficients; the built-in body has more.
const SMPL_BETAS: usize = 10;

/// `capture`'s prior with the shape coefficients NeuMan cannot carry zeroed (what reads back).
fn smpl_shaped(capture: &mut Prior4dCapture) {
    let prior = &mut capture.acting_prior;
    let s = prior.shape_count;
    for (k, beta) in prior.betas.iter_mut().enumerate() {
        if k % s >= SMPL_BETAS {
            *beta = 0.0;
        }
    }
}

fn rotation(m: &[[f32; 4]; 3]) -> DMat3 {
    DMat3::from_cols_array_2d(&[0, 1, 2].map(|j| [0, 1, 2].map(|i| f64::from(m[i][j]))))
}

/// `capture`'s acting video as a NeuMan scene: the camera-space prior `x_c = R_c (x − J₀) +
/// J₀ + t_c` (metres) becomes SMPL's pose (global orientation `R_c`, no translation) and the
/// alignment `s = σ`, `R = R_wcᵀ`, `t = σ R_wcᵀ t_c − R_wcᵀ T_wc`, which puts it where the
/// camera `[R_wc | T_wc]` (scene units) films it.
fn write_as_neuman(capture: &Prior4dCapture, root: &Path) {
    let sigma = capture.truth.as_ref().expect("synthetic").scale;
    let prior = &capture.acting_prior;
    let frames: Vec<NeumanFrame> = capture
        .acting
        .iter()
        .enumerate()
        .map(|(t, frame)| {
            let r = rotation(&frame.camera.world_to_camera);
            let m = frame.camera.world_to_camera;
            let big_t = DVec3::new(f64::from(m[0][3]), f64::from(m[1][3]), f64::from(m[2][3]));
            let t_c = DVec3::from(prior.translation(t));
            let translation = sigma * (r.transpose() * t_c) - r.transpose() * big_t;
            let rt = r.transpose();
            NeumanFrame {
                camera: frame.camera,
                rgb: values(frame.image.clone())
                    .iter()
                    .map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8)
                    .collect(),
                person: values(frame.mask.clone()).iter().map(|&m| m > 0.5).collect(),
                pose: prior.pose(t).to_vec(),
                betas: prior.frame_betas(t)[..SMPL_BETAS].to_vec(),
                alignment: Similarity {
                    scale: sigma,
                    rotation: [0, 1, 2].map(|i| rt.row(i).to_array()),
                    translation: translation.to_array(),
                },
            }
        })
        .collect();
    let points: Vec<([f64; 3], [f32; 3])> = capture
        .acting_points
        .positions
        .iter()
        .zip(&capture.acting_points.colours)
        .map(|(p, c)| (p.map(f64::from), *c))
        .collect();
    write_neuman_scene(root, &frames, &points, &TEST);
}

fn read(root: &Path, width: u32, held_out_every: usize) -> Result<Prior4dCapture, String> {
    Prior4dDataConfig {
        capture: Some(root.to_path_buf()),
        width,
        held_out_every,
        capture_betas: true,
        ..Prior4dDataConfig::default()
    }
    .build(&Device::flex())
    .map_err(|e| e.to_string())
}

#[test]
fn a_neuman_folder_reads_back_the_cameras_body_and_masks_it_was_written_from() {
    let mut synthetic = tiny_capture();
    smpl_shaped(&mut synthetic);
    let dir = tempfile::tempdir().unwrap();
    write_as_neuman(&synthetic, dir.path());
    let real = read(dir.path(), synthetic.acting[0].camera.width, 8).expect("the folder reads");
    assert!(real.truth.is_none() && real.acting_keypoints.is_empty());
    assert!(real.scene_scan.is_empty() && real.human_scan.is_empty());
    assert_eq!(real.acting.len(), synthetic.acting.len());
    let held: Vec<usize> = (0..real.acting.len())
        .filter(|&t| real.acting[t].held_out)
        .collect();
    assert_eq!(held, TEST);
    let pointed: Vec<usize> = real.eval.iter().map(|e| e.acting_frame).collect();
    assert_eq!(pointed, TEST);
    assert_eq!(real.scene_points.len(), synthetic.acting_points.len());

    for (t, (a, b)) in real.acting.iter().zip(&synthetic.acting).enumerate() {
        assert!(a.normals.is_none());
        let (ca, cb) = (&a.camera, &b.camera);
        assert_eq!((ca.width, ca.height), (cb.width, cb.height));
        assert!((ca.fx - cb.fx).abs() < 1e-4 && (ca.cy - cb.cy).abs() < 1e-4);
        for i in 0..3 {
            for j in 0..4 {
                let d = (ca.world_to_camera[i][j] - cb.world_to_camera[i][j]).abs();
                assert!(d < 1e-5, "frame {t}: world_to_camera[{i}][{j}] off by {d}");
            }
        }
        let (ma, mb) = (values(a.mask.clone()), values(b.mask.clone()));
        assert_eq!(ma, mb, "frame {t}: the mask");
        let (ia, ib) = (values(a.image.clone()), values(b.image.clone()));
        let worst = ia
            .iter()
            .zip(&ib)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f32::max);
        assert!(worst <= 0.5 / 255.0 + 1e-6, "frame {t}: image off by {worst}");
    }

    // The camera-space body through COLMAP's world and NeuMan's alignment and back.
    let model = &builtin_body().model;
    let device = Device::flex();
    let joints = |c: &Prior4dCapture| host_f32(&track_joints(model, &c.acting_prior, &device));
    let worst = joints(&real)
        .iter()
        .zip(joints(&synthetic))
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f32::max);
    assert!(worst < 1e-3, "joints off by {worst} m");

    // The feet rule: ground pixels in most frames, nearly all on the floor (the synthetic
    // capture's floor mask outside the person, itself jittered by a pixel).
    let (mut framed, mut on, mut all) = (0, 0, 0);
    for (a, b) in real.acting.iter().zip(&synthetic.acting) {
        framed += usize::from(a.ground.area() > 0);
        let floor = b.ground.dilate(2);
        on += (0..a.ground.data.len())
            .filter(|&k| a.ground.data[k] && floor.data[k])
            .count();
        all += a.ground.area();
    }
    assert!(framed >= 5, "ground pixels in {framed} of 6 frames");
    let share = on as f64 / all.max(1) as f64;
    assert!(share > 0.8, "{share:.3} of the {all} ground pixels on the floor");
}

#[test]
fn four_stages_run_on_a_neuman_folder_without_truth_scores() {
    let synthetic = tiny_capture();
    let dir = tempfile::tempdir().unwrap();
    write_as_neuman(&synthetic, dir.path());
    let mut config = into_stage_d(10);
    config.data.capture = Some(dir.path().to_path_buf());
    config.data.width = 80;
    config.body_fit.keypoints = true;
    config.joint.eval_stride = 1;
    let device = Device::flex();
    let mut method = Prior4d::new(config.clone(), &device).expect("a run on the folder");
    let decisions = method.decisions().join("\n");
    for expected in [
        "no scene scan",
        "no human scan",
        "no 2-D keypoints",
        "no normal maps",
        "NeuMan capture",
    ] {
        assert!(decisions.contains(expected), "{expected:?} in\n{decisions}");
    }
    assert_eq!(method.config.joint.normal, 0.0);
    assert!(!method.config.body_fit.keypoints);
    while method.steps() < config.iterations {
        let report = method.step().expect("a step");
        assert!(report.loss.is_finite(), "step {}", method.steps());
    }
    let scores = method.final_scores(None).expect("scores");
    assert!(scores.truth.is_none() && scores.normal_mean_degrees.is_none());
    assert!(method.sigma_star().is_none());
    assert_eq!(scores.frames, TEST.len());
    assert!(scores.psnr.is_finite() && scores.psnr > 5.0, "{scores:?}");
    assert!((0.0..=1.0).contains(&scores.mask_iou), "{scores:?}");
    let json = serde_json::to_value(&scores).unwrap();
    assert!(json.get("sigma_error").is_none() && json.get("psnr").is_some());
}

#[test]
fn bad_neuman_folders_are_named() {
    let synthetic = tiny_capture();
    let dir = tempfile::tempdir().unwrap();
    write_as_neuman(&synthetic, dir.path());
    let mask = dir.path().join("segmentations/00003.png");
    std::fs::remove_file(&mask).unwrap();
    let error = read(dir.path(), 80, 8).err().expect("a missing mask is refused");
    assert!(
        error.contains("00003.png") && error.contains("mask"),
        "{error}"
    );

    let dir = tempfile::tempdir().unwrap();
    write_as_neuman(&synthetic, dir.path());
    let cameras = dir.path().join("sparse/cameras.txt");
    let text = std::fs::read_to_string(&cameras).unwrap();
    let lines: Vec<String> = text
        .lines()
        .map(|l| {
            if l.starts_with("4 PINHOLE") {
                // OPENCV: fx fy cx cy k1 k2 p1 p2.
                format!("{} 0.1 0 0 0", l.replace("PINHOLE", "OPENCV"))
            } else {
                l.to_owned()
            }
        })
        .collect();
    std::fs::write(&cameras, lines.join("\n")).unwrap();
    let error = read(dir.path(), 80, 8).err().expect("a distorted camera is refused");
    assert!(
        error.contains("cameras.txt") && error.contains("00003.png") && error.contains("undistort"),
        "{error}"
    );

    let dir = tempfile::tempdir().unwrap();
    write_as_neuman(&synthetic, dir.path());
    // An empty test split: every `held_out_every`-th frame instead, and at least one frame
    // must be held out and two trained on.
    std::fs::write(dir.path().join("test_split.txt"), "").unwrap();
    let fallback = read(dir.path(), 80, 3).expect("every third frame held out");
    let held: Vec<usize> = (0..fallback.acting.len())
        .filter(|&t| fallback.acting[t].held_out)
        .collect();
    assert_eq!(held, [2, 5]);
    let error = read(dir.path(), 80, 8).err().expect("nothing held out is refused");
    assert!(error.contains("held out"), "{error}");
}
