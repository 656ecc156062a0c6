//! `train-apf --data`: a drivestudio processed-Waymo scene (the datasets crate's fixture: two
//! frames of cameras 0 and 3, a pedestrian tracked in frame 0 only, a LiDAR wall 10 m ahead)
//! read into the method's capture and trained through S2; bad scenes refused by name.

use crate::trainer::small;
use burn::tensor::Device;
use splatzoo_apf_gs::config::ApfConfig;
use splatzoo_apf_gs::scene::FrameInputs;
use splatzoo_apf_gs::trainer::ApfTrainer;
use splatzoo_datasets::fixtures::drivestudio_fixture;
use splatzoo_train::harness::extremes::{StepOutcome, after_steps, assert_stable};
use splatzoo_train::host_f32;
use std::path::Path;

fn on_disk(root: &Path) -> ApfConfig {
    let mut c = small();
    c.data.path = Some(root.to_path_buf());
    c.data.cameras = vec![0, 3];
    c.data.downscale = 1;
    c.data.test_every = 2;
    c.data.min_track_frames = 1;
    c
}

#[test]
fn a_drivestudio_scene_becomes_the_capture() {
    let dir = tempfile::tempdir().unwrap();
    drivestudio_fixture(dir.path(), true);
    let device = Device::flex();
    let trainer = ApfTrainer::assemble(on_disk(dir.path()), &device).unwrap();
    let capture = &trainer.capture;
    // Frame 1 is held out (test_every 2), in both cameras.
    assert_eq!((capture.frames, capture.views.len()), (2, 4));
    assert_eq!((capture.train.len(), capture.test.len()), (2, 2));
    assert!(capture.test.iter().all(|&i| capture.views[i].frame == 1));
    assert!(capture.views.iter().all(|v| v.true_human.is_none()));
    // The pedestrian: valid in frame 0 only, so present there and hidden in frame 1; the root
    // joint on the box centre (8, 0, 0.9); no vehicle among the people.
    assert_eq!(capture.people.len(), 1);
    let person = &capture.people[0];
    assert_eq!(person.present, vec![true, false]);
    let root = person.prior_frames[0].joints[0];
    assert!(
        (0..3).all(|i| (root[i] - [8.0, 0.0, 0.9][i]).abs() < 1e-3),
        "{root:?}"
    );
    let [lo, hi] = person.boxes[0].unwrap();
    assert!(
        lo[2] < 0.0 && hi[2] > 1.8 && hi[0] - lo[0] > 0.6,
        "{lo:?} {hi:?}"
    );
    assert_eq!(capture.untracked, 0);
    // The LiDAR wall lands in camera 0's training view as nine depths of 10 m; camera 3 looks
    // sideways and sees none of it.
    for &i in &capture.train {
        let view = &capture.views[i];
        let depths: Vec<f32> = view
            .lidar
            .as_ref()
            .unwrap()
            .iter()
            .copied()
            .filter(|d| d.is_finite())
            .collect();
        let expected = if view.camera_index == 0 { 9 } else { 0 };
        assert_eq!(depths.len(), expected, "view {}", view.name);
        assert!(depths.iter().all(|d| (d - 10.0).abs() < 1e-3), "{depths:?}");
    }
    assert!(
        capture
            .views
            .iter()
            .all(|v| v.lidar.is_none() == (v.frame == 1))
    );
    assert!(!capture.scene_points.is_empty());
    assert!(
        capture.decisions[0].contains("drivestudio scene"),
        "{:?}",
        capture.decisions
    );
    // The hidden person composes with every opacity under the rasterizer's cut-off.
    let alpha = |frame: usize| {
        let view = capture.views.iter().find(|v| v.frame == frame).unwrap();
        let composed = trainer.scene.compose(
            &FrameInputs {
                camera: &view.camera,
                frame,
                time: 0.0,
                guided: &[],
                nets: &trainer.nets,
                stage: trainer.stage(0),
                duration: trainer.duration(),
                in_step: false,
            },
            &trainer.config,
        );
        let logits = host_f32(&composed.splats.opacity_logits);
        let rows = composed.rows[0].clone();
        logits[rows]
            .iter()
            .map(|&l| 1.0 / (1.0 + (-l).exp()))
            .fold(0.0f32, f32::max)
    };
    assert!(alpha(0) > 1.0 / 255.0, "present: {}", alpha(0));
    assert!(alpha(1) < 1.0 / 255.0, "hidden: {}", alpha(1));
}

#[test]
fn a_drivestudio_scene_trains_through_s2() {
    let dir = tempfile::tempdir().unwrap();
    drivestudio_fixture(dir.path(), true);
    let mut config = on_disk(dir.path());
    config.warmup = 1;
    let outcome = assert_stable(
        "drivestudio scene",
        after_steps::<ApfTrainer>(config, &Device::flex(), 2),
    );
    assert!(matches!(outcome, StepOutcome::Finite { .. }), "{outcome:?}");
}

#[test]
fn bad_scenes_are_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    drivestudio_fixture(dir.path(), true);
    let device = Device::flex();
    let refusal = |config: ApfConfig| match ApfTrainer::assemble(config, &device) {
        Ok(_) => panic!("accepted"),
        Err(e) => e.to_string(),
    };
    let mut no_camera = on_disk(dir.path());
    no_camera.data.cameras = vec![4];
    let e = refusal(no_camera);
    assert!(
        e.contains("data.cameras [4]") && e.contains("[\"0\", \"3\"]"),
        "{e}"
    );
    let mut long_window = on_disk(dir.path());
    long_window.data.end_frame = Some(5);
    let e = refusal(long_window);
    assert!(
        e.contains("data.end_frame 5") && e.contains("2 frames"),
        "{e}"
    );
    let mut too_short = on_disk(dir.path());
    too_short.data.min_track_frames = 2;
    let e = refusal(too_short);
    assert!(
        e.contains("track 1 stays in the background") && e.contains("train-3dgs"),
        "{e}"
    );
    std::fs::write(dir.path().join("lidar/000.bin"), [0u8; 12]).unwrap();
    let e = refusal(on_disk(dir.path()));
    assert!(e.contains("lidar/000.bin") && e.contains("12 bytes"), "{e}");
    let empty = tempfile::tempdir().unwrap();
    let mut elsewhere = on_disk(empty.path());
    elsewhere.data.path = Some(empty.path().to_path_buf());
    let e = refusal(elsewhere);
    assert!(e.contains(&empty.path().display().to_string()), "{e}");
}

#[test]
fn train_apf_runs_on_a_drivestudio_scene_from_the_command_line() {
    let scene = tempfile::tempdir().unwrap();
    drivestudio_fixture(scene.path(), true);
    let runs = tempfile::tempdir().unwrap();
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_train-apf"))
        .arg("--data")
        .arg(scene.path())
        .args(["--iterations", "3", "--name", "waymo", "--runs"])
        .arg(runs.path())
        .args([
            "--set",
            "data.cameras=[0, 3]",
            "--set",
            "data.downscale=1",
            "--set",
            "data.test_every=2",
            "--set",
            "data.min_track_frames=1",
            "--set",
            "warmup=1",
            "--set",
            "onnx=false",
            "--set",
            "repose_frames=0",
        ])
        .output()
        .unwrap();
    let log = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{log}");
    let dir = runs.path().join("apf/waymo");
    let metrics: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("metrics.json")).unwrap()).unwrap();
    let novel = &metrics["final"]["novel_view"];
    // Scored on the held-out frame; no ground truth on disk, so no true-body scores.
    assert!(
        novel["full"]["psnr"].as_f64().unwrap().is_finite(),
        "{novel}"
    );
    assert!(novel.get("human_true").is_none(), "{novel}");
    assert!(
        metrics["decisions"]
            .to_string()
            .contains("drivestudio scene")
    );
    assert!(dir.join("human_0_canonical.ply").is_file());
    assert!(dir.join("background.ply").is_file());
}
