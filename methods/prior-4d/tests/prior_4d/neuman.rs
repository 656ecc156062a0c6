//! A real capture's path (`data.capture`): the synthetic acting video written as NeuMan's
//! preprocessing leaves a scene (`write_acting_as_neuman`: COLMAP text model, images,
//! segmentations, SMPL fits and alignments placing the camera-space body in COLMAP's world at
//! the scene's scale), read back as Prior-4D's acting video with its own
//! scene. What is read is known exactly: the cameras, the camera-space body prior, the masks;
//! the feet rule's ground pixels land on the true floor; the four stages run on it with the
//! truth scores absent; bad folders are named.

use crate::data::tiny_capture;
use crate::trainer::into_stage_d;
use crate::{assert_same_camera, max_abs_difference, values};
use burn::tensor::Device;
use splatzoo_models::body::builtin_body;
use splatzoo_prior_4d::Prior4d;
use splatzoo_prior_4d::data::neuman::{NEUMAN_BETAS, write_acting_as_neuman};
use splatzoo_prior_4d::data::{Prior4dCapture, Prior4dDataConfig};
use splatzoo_train::avatar::track_joints;
use splatzoo_train::harness::Method;
use splatzoo_train::host_f32;
use std::path::Path;

/// The held-out frames the test split names.
const TEST: [usize; 2] = [2, 5];

/// `capture`'s prior with the shape coefficients NeuMan cannot carry zeroed (what reads back).
fn smpl_shaped(capture: &mut Prior4dCapture) {
    let prior = &mut capture.acting_prior;
    let s = prior.shape_count;
    for (k, beta) in prior.betas.iter_mut().enumerate() {
        if k % s >= NEUMAN_BETAS {
            *beta = 0.0;
        }
    }
}

fn write_as_neuman(capture: &Prior4dCapture, root: &Path) {
    write_acting_as_neuman(capture, root, &TEST, false).expect("written");
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
        assert_same_camera(&a.camera, &b.camera, 1e-5, &format!("frame {t}"));
        let (ma, mb) = (values(a.mask.clone()), values(b.mask.clone()));
        assert_eq!(ma, mb, "frame {t}: the mask");
        let (ia, ib) = (values(a.image.clone()), values(b.image.clone()));
        let worst = max_abs_difference(&ia, &ib);
        assert!(
            worst <= 0.5 / 255.0 + 1e-6,
            "frame {t}: image off by {worst}"
        );
    }

    // The camera-space body through COLMAP's world and NeuMan's alignment and back.
    let model = &builtin_body().model;
    let device = Device::flex();
    let joints = |c: &Prior4dCapture| host_f32(&track_joints(model, &c.acting_prior, &device));
    let worst = max_abs_difference(&joints(&real), &joints(&synthetic));
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
    assert!(
        share > 0.8,
        "{share:.3} of the {all} ground pixels on the floor"
    );
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
    let device = Device::flex();
    let mut method = Prior4d::new(config.clone(), &device).expect("a run on the folder");
    let decisions = method.decisions().join("\n");
    for expected in [
        "every held-out frame is scored",
        "in place of a scan (the capture has none)",
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
    let error = read(dir.path(), 80, 8)
        .err()
        .expect("a missing mask is refused");
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
    let error = read(dir.path(), 80, 8)
        .err()
        .expect("a distorted camera is refused");
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
    let error = read(dir.path(), 80, 8)
        .err()
        .expect("nothing held out is refused");
    assert!(error.contains("held out"), "{error}");
}

/// The synthetic capture's own noisy keypoints, normal maps, monocular depth and ground masks
/// written beside the NeuMan folder (`data::given`) read back as they were and turn on what
/// needs them: stage C's keypoint fit, the normal term, the normal score on held-out frames.
#[test]
fn given_priors_read_back_and_turn_their_terms_on() {
    let synthetic = tiny_capture();
    let dir = tempfile::tempdir().unwrap();
    write_acting_as_neuman(&synthetic, dir.path(), &TEST, true).expect("written");
    let real = read(dir.path(), 80, 8).expect("the folder reads");
    assert_eq!(real.acting_keypoints.len(), real.acting.len());
    for (t, (a, b)) in real
        .acting_keypoints
        .iter()
        .zip(&synthetic.acting_keypoints)
        .enumerate()
    {
        for (p, q) in a.iter().zip(b) {
            let d = (0..3).map(|c| (p[c] - q[c]).abs()).fold(0.0, f32::max);
            assert!(d < 1e-4, "frame {t}: keypoint {p:?} against {q:?}");
        }
    }
    for (t, (a, b)) in real.acting.iter().zip(&synthetic.acting).enumerate() {
        assert_eq!(a.ground, b.ground, "frame {t}: the ground mask");
        assert_eq!(
            values(a.mono_inverse_depth.clone()),
            values(b.mono_inverse_depth.clone()),
            "frame {t}: the monocular depth"
        );
        let (na, nb) = (
            values(a.normals.clone().expect("given")),
            values(b.normals.clone().expect("synthetic")),
        );
        let mask = values(a.mask.clone());
        let mut compared = 0;
        for k in 0..mask.len() {
            let (p, q) = (&na[3 * k..3 * k + 3], &nb[3 * k..3 * k + 3]);
            let lq = q.iter().map(|v| v * v).sum::<f32>().sqrt();
            if mask[k] > 0.5 && lq > 1e-3 {
                let cosine = (0..3).map(|c| p[c] * q[c]).sum::<f32>() / lq;
                assert!(cosine > 0.9999, "frame {t} pixel {k}: cosine {cosine}");
                compared += 1;
            } else if mask[k] < 0.5 {
                assert!(
                    p.iter().all(|&v| v == 0.0),
                    "frame {t}: a normal off the person"
                );
            }
        }
        assert!(compared > 30, "frame {t}: {compared} normals compared");
        let sparse = a.depth.iter().filter(|d| d.is_finite()).count();
        assert!(sparse > 50, "frame {t}: {sparse} pixels of sparse depth");
    }
    assert!(real.eval.iter().all(|e| e.normals.is_some()));

    let mut config = into_stage_d(8);
    config.data.capture = Some(dir.path().to_path_buf());
    config.body_fit.keypoints = true;
    config.body_fit.iterations = 10;
    let device = Device::flex();
    let mut method = Prior4d::new(config.clone(), &device).expect("a run on the folder");
    let decisions = method.decisions().join("\n");
    assert!(
        decisions.contains("keypoints/, normals/, mono_depth/, ground/")
            && decisions.contains("refined on the keypoints")
            && !decisions.contains("no normal maps"),
        "{decisions}"
    );
    assert!(method.config.joint.normal > 0.0 && method.config.body_fit.keypoints);
    while method.steps() < config.iterations {
        assert!(method.step().expect("a step").loss.is_finite());
    }
    let scores = method.final_scores(None).expect("scores");
    let normal = scores
        .normal_mean_degrees
        .expect("scored against the given normals");
    assert!((0.0..=90.0).contains(&normal), "{scores:?}");
    assert!(scores.truth.is_none());

    // A mis-shaped map is named with the shape expected.
    let path = dir.path().join("normals/00001.npy");
    splatzoo_datasets::synth::export::write_npy_f32(&path, &[60, 80], &vec![0.0; 4800]).unwrap();
    let error = read(dir.path(), 80, 8).err().expect("refused");
    assert!(
        error.contains("normals/00001.npy") && error.contains("expected [60, 80, 3]"),
        "{error}"
    );
}
