//! A capture on disk (`data.capture`, `splatzoo_illum::disk`): the tiny synthetic capture
//! written as a NeuMan folder in a world of 2.5 units a metre reads back in metres with the
//! same cameras, masks, images (to 8 bits), depth, body track and split; training runs through
//! the hand-over on it with the truth scores absent and the shadow decoder's decision saying
//! why; it resumes exactly; bad files are named.

use crate::trainer::{assert_same, tiny, with_step};
use crate::values;
use burn::tensor::Device;
use splatzoo_illum::config::IllumConfig;
use splatzoo_illum::data::IllumCapture;
use splatzoo_illum::disk::write_as_neuman;
use splatzoo_illum::method::Illum;
use splatzoo_train::harness::Method;
use std::path::Path;

const SCALE: f64 = 2.5;

/// The tiny synthetic capture and the same video written as NeuMan under `root`.
fn written(root: &Path, device: &Device) -> (IllumConfig, IllumCapture) {
    let config = tiny();
    let capture = config.data.build(device).expect("the tiny capture");
    write_as_neuman(&capture, root, SCALE).expect("written");
    (config, capture)
}

fn on_disk(config: &IllumConfig, root: &Path) -> IllumConfig {
    let mut on_disk = config.clone();
    on_disk.data.capture = Some(root.to_path_buf());
    on_disk
}

fn max_abs_difference(a: &[f32], b: &[f32]) -> f32 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max)
}

#[test]
fn a_capture_written_as_neuman_reads_back_in_metres() {
    let device = Device::flex();
    let dir = tempfile::tempdir().unwrap();
    let (config, synthetic) = written(dir.path(), &device);
    let read = on_disk(&config, dir.path())
        .data
        .build(&device)
        .expect("read back");
    assert!(read.truth.is_none());
    let frames = |c: &IllumCapture| -> Vec<(usize, bool)> {
        c.frames.iter().map(|f| (f.frame, f.held_out)).collect()
    };
    assert_eq!(frames(&read), frames(&synthetic), "frames and split");
    for (a, b) in synthetic.frames.iter().zip(&read.frames) {
        let (ca, cb) = (a.camera, b.camera);
        assert_eq!((ca.width, ca.height), (cb.width, cb.height));
        let rows = |m: [[f32; 4]; 3]| m.iter().flatten().copied().collect::<Vec<_>>();
        let camera_error = max_abs_difference(&rows(ca.world_to_camera), &rows(cb.world_to_camera));
        assert!(
            camera_error < 1e-4,
            "frame {}: camera off by {camera_error}",
            a.frame
        );
        assert!((ca.fx - cb.fx).abs() < 1e-3 && (ca.cy - cb.cy).abs() < 1e-3);
        assert_eq!(a.person, b.person, "frame {}: mask", a.frame);
        let image_error = max_abs_difference(&values(a.image.clone()), &values(b.image.clone()));
        assert!(
            image_error <= 0.5 / 255.0 + 1e-6,
            "frame {}: image off by {image_error}",
            a.frame
        );
        // Depth in metres again where the renderer saw a surface; unknown where it saw none.
        for (&da, &db) in a.depth.iter().zip(&b.depth) {
            if da.is_finite() && da > 0.0 {
                assert!(
                    (da - db).abs() <= 1e-5 * da,
                    "frame {}: depth {da} read {db}",
                    a.frame
                );
            } else {
                assert!(!db.is_finite(), "frame {}: depth where none was", a.frame);
            }
        }
        let (pa, pb) = (synthetic.prior.pose(a.frame), read.prior.pose(b.frame));
        let pose_error = pa
            .iter()
            .zip(pb)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max);
        assert!(
            pose_error < 1e-6,
            "frame {}: pose off by {pose_error}",
            a.frame
        );
        let (ta, tb) = (
            synthetic.prior.translation(a.frame),
            read.prior.translation(b.frame),
        );
        assert!(
            (0..3).all(|k| (ta[k] - tb[k]).abs() < 1e-6),
            "frame {}: translation {ta:?} read {tb:?}",
            a.frame
        );
    }
    // The scene points, in metres again.
    assert_eq!(read.scene_points.len(), synthetic.scene_points.len());
    let extent = |c: &IllumCapture| -> f32 {
        c.scene_points
            .positions
            .iter()
            .map(|p| p.iter().map(|v| v * v).sum::<f32>().sqrt())
            .fold(0.0, f32::max)
    };
    let (ea, eb) = (extent(&synthetic), extent(&read));
    assert!((ea - eb).abs() < 1e-3 * ea, "scene extent {ea} m read {eb}");
    let said = read.decisions.join("\n");
    assert!(said.contains("no truth on disk"), "{said}");
    assert!(
        said.contains(&format!(
            "depth maps for the background depth term: {0} of {0}",
            4
        )),
        "{said}"
    );
}

#[test]
fn training_on_a_neuman_folder_scores_without_truth_and_resumes_exactly() {
    let device = Device::flex();
    let dir = tempfile::tempdir().unwrap();
    let (config, _) = written(dir.path(), &device);
    let config = on_disk(&config, dir.path());
    let mut whole = Illum::new(config.clone(), &device).unwrap();
    let choice = &whole.trainer.shadow_choice;
    assert!(
        choice.enabled && choice.reason.contains("no person-free view"),
        "{choice:?}"
    );
    let start = with_step(&whole);
    for _ in 0..config.iterations {
        assert!(whole.step().unwrap().loss.is_finite());
    }
    assert!(whole.trainer.stage2.is_some(), "stage 2 ran");
    let scores = whole.trainer.evaluate(None).unwrap();
    assert!(scores.truth.is_none(), "{scores:?}");
    assert!(scores.frames == 2 && scores.psnr.is_finite() && scores.human_psnr.is_finite());
    assert!(scores.visibility_accuracy.is_some_and(f64::is_finite));
    let json = serde_json::to_value(&scores).unwrap();
    assert!(json.get("relit_human_psnr").is_none() && json.get("psnr").is_some());

    let mut first = Illum::resume(config.clone(), &start, &device).unwrap();
    for _ in 0..5 {
        first.step().unwrap();
    }
    let mut resumed = Illum::resume(config.clone(), &with_step(&first), &device).unwrap();
    for _ in 5..config.iterations {
        resumed.step().unwrap();
    }
    assert_same(
        &with_step(&whole),
        &with_step(&resumed),
        "resumed at step 5",
    );
}

#[test]
fn bad_neuman_files_are_named() {
    let device = Device::flex();
    let dir = tempfile::tempdir().unwrap();
    let (config, _) = written(dir.path(), &device);
    let config = on_disk(&config, dir.path());
    // A depth map of the wrong shape.
    let depth = dir.path().join("depth_maps").join("00001.png.npy");
    splatzoo_datasets::synth::export::write_npy_f32(&depth, &[2, 3], &[1.0; 6]).unwrap();
    let err = config.data.build(&device).unwrap_err().to_string();
    assert!(
        err.contains("00001.png.npy") && err.contains("[2, 3]"),
        "{err}"
    );
    // A missing person mask.
    std::fs::remove_file(&depth).unwrap();
    std::fs::remove_file(dir.path().join("segmentations").join("00002.png")).unwrap();
    let err = config.data.build(&device).unwrap_err().to_string();
    assert!(err.contains("00002"), "{err}");
    // No such folder.
    let mut missing = config.clone();
    missing.data.capture = Some(dir.path().join("absent"));
    let err = missing.data.build(&device).unwrap_err().to_string();
    assert!(err.contains("absent"), "{err}");
}

/// ZJU-MoCap's layout (the loaders' fixture: two cameras, two frames, no points, no depth)
/// reads through the same path: every camera trains, every 2nd frame is held out, the scene
/// starts from random points in the cameras' box, and a step is finite.
#[test]
fn zju_mocap_reads_through_the_same_path() {
    let device = Device::flex();
    let dir = tempfile::tempdir().unwrap();
    splatzoo_datasets::fixtures::zju_fixture(dir.path());
    let mut config = on_disk(&tiny(), dir.path());
    config.data.test_every = 2;
    config.iterations = 2;
    let capture = config.data.build(&device).expect("the ZJU-MoCap fixture");
    let frames: Vec<(usize, bool)> = capture
        .frames
        .iter()
        .map(|f| (f.frame, f.held_out))
        .collect();
    assert_eq!(frames, vec![(0, false), (0, false), (1, true), (1, true)]);
    assert!(
        capture
            .frames
            .iter()
            .all(|f| f.depth.iter().all(|d| !d.is_finite()))
    );
    let said = capture.decisions.join("\n");
    assert!(
        said.contains("random points") && said.contains("0 of 2"),
        "{said}"
    );
    let mut method = Illum::from_capture(config.clone(), capture, &device).unwrap();
    for _ in 0..config.iterations {
        assert!(method.step().unwrap().loss.is_finite());
    }
    let scores = method.trainer.evaluate(None).unwrap();
    assert!(
        scores.truth.is_none() && scores.psnr.is_finite(),
        "{scores:?}"
    );
}
