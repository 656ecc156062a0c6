//! Every capture format the loaders read feeds training: `train-3dgs`'s static path and
//! `train-avatar` each take two steps on a fixture written in each format's real layout
//! (`splatzoo_datasets::fixtures`); COLMAP's points initialise the Gaussians; a capture
//! downscaled by the trainer has the cameras and images to match; bad input (a pose track
//! shorter than the capture, a track for another skeleton, an unknown training camera, a view
//! without a person mask) is refused with the file or field named.

use burn::tensor::Device;
use splatzoo_datasets::fixtures::{
    colmap_fixture, drivestudio_fixture, ghg_fixture, nerfstudio_fixture, neuman_fixture,
    ring_points, snapshot_fixture, zju_fixture,
};
use splatzoo_datasets::formats::{BodyFrame, Dataset, Format, PoseTrack, Similarity};
use splatzoo_datasets::synth::export::write_scene;
use splatzoo_datasets::synth::{Preset, SceneConfig};
use splatzoo_models::body::builtin_body;
use splatzoo_train::avatar::{AvatarConfig, AvatarTrainer};
use splatzoo_train::densify::Strategy;
use splatzoo_train::harness::Method;
use splatzoo_train::static_scene::{StaticConfig, StaticTrainer};
use splatzoo_train::views::DataSource;
use splatzoo_train::views::people::person_sequence;
use std::path::{Path, PathBuf};

/// Writes one fixture per format under `dir`; returns (name, folder, has a pose track).
fn fixtures(dir: &Path) -> Vec<(&'static str, PathBuf, bool)> {
    let at = |name: &str| {
        let path = dir.join(name);
        std::fs::create_dir_all(&path).unwrap();
        path
    };
    let colmap_text = at("colmap_text");
    colmap_fixture(&colmap_text, false);
    let colmap_binary = at("colmap_binary");
    colmap_fixture(&colmap_binary, true);
    let nerfstudio = at("nerfstudio");
    nerfstudio_fixture(&nerfstudio, true);
    let neuman = at("neuman");
    neuman_fixture(&neuman, false);
    let zju = at("zju");
    zju_fixture(&zju);
    let snapshot = at("snapshot");
    snapshot_fixture(&snapshot, false);
    let ghg = ghg_fixture(&at("THuman"));
    let drive = at("drivestudio");
    drivestudio_fixture(&drive, true);
    let synthetic = at("synthetic");
    let scene = SceneConfig {
        width: 32,
        height: 24,
        frames: Some(4),
        supersample: 1,
        shadow_resolution: None,
        ..SceneConfig::new(Preset::Monocular, 1)
    }
    .build(&Device::flex());
    write_scene(&scene, &synthetic, &[0, 1, 2, 3], |_| {}).unwrap();
    vec![
        ("colmap text", colmap_text, false),
        ("colmap binary", colmap_binary, false),
        ("nerfstudio + ply", nerfstudio, false),
        ("neuman", neuman, true),
        ("zju", zju, true),
        ("people snapshot", snapshot, true),
        ("ghg", ghg, true),
        ("drivestudio", drive, true),
        ("synthetic export", synthetic, true),
    ]
}

fn static_config(path: &Path) -> StaticConfig {
    let mut config = StaticConfig {
        iterations: 2,
        ..StaticConfig::default()
    };
    config.data.source = DataSource::Dataset;
    config.data.path = Some(path.to_path_buf());
    config.data.random_points = 300;
    config.densify.strategy = Strategy::None;
    config
}

fn avatar_config(path: &Path) -> AvatarConfig {
    let mut config = AvatarConfig {
        iterations: 2,
        ..AvatarConfig::default()
    };
    config.data.path = Some(path.to_path_buf());
    config.node.per_face = 1;
    config.densify.strategy = Strategy::None;
    config
}

#[test]
fn every_capture_format_trains_both_trainers_two_steps() {
    let dir = tempfile::tempdir().unwrap();
    let device = Device::flex();
    for (name, path, has_people) in fixtures(dir.path()) {
        let mut trainer = StaticTrainer::new(static_config(&path), &device)
            .unwrap_or_else(|e| panic!("{name}: train-3dgs: {e}"));
        for _ in 0..2 {
            let report = trainer.step().unwrap_or_else(|e| panic!("{name}: {e}"));
            assert!(report.loss.is_finite(), "{name}: loss {}", report.loss);
        }
        let evaluation = trainer.evaluate(None).unwrap();
        assert!(evaluation.scores.psnr.is_finite(), "{name}");
        let described = trainer.decisions().join("\n");
        if has_people {
            // Where people move across the capture's moments a static scene leaves them out;
            // a single moment (GHG's scans) keeps them.
            let expected = if described.contains(" 1 moment(s)") {
                "people stand still"
            } else {
                "person pixels left out"
            };
            assert!(described.contains(expected), "{name}: {described}");
        }
        if !has_people {
            continue;
        }
        let mut avatar = AvatarTrainer::new(avatar_config(&path), &device)
            .unwrap_or_else(|e| panic!("{name}: train-avatar: {e}"));
        for _ in 0..2 {
            let report = avatar.step().unwrap_or_else(|e| panic!("{name}: {e}"));
            assert!(report.loss.is_finite(), "{name}: loss {}", report.loss);
        }
        assert!(!avatar.capture.train.is_empty(), "{name}");
        let evaluation = avatar.evaluate(None).unwrap();
        assert!(evaluation.scores.psnr.is_finite(), "{name}");
    }
}

#[test]
fn colmap_points_initialise_and_the_trainer_downscales() {
    let dir = tempfile::tempdir().unwrap();
    let device = Device::flex();
    colmap_fixture(dir.path(), true);
    let trainer = StaticTrainer::new(static_config(dir.path()), &device).unwrap();
    assert_eq!(trainer.graph.gaussians(), ring_points().len());
    let decisions = trainer.decisions().join("\n");
    assert!(decisions.contains("sparse points"), "{decisions}");
    let full = trainer.views.train[0].camera;
    let mut config = static_config(dir.path());
    config.data.downscale = 2;
    let mut half = StaticTrainer::new(config, &device).unwrap();
    let camera = half.views.train[0].camera;
    assert_eq!(
        (camera.width, camera.height),
        (full.width / 2, full.height / 2)
    );
    assert!((camera.fx - full.fx / 2.0).abs() < 1e-5 && (camera.cx - full.cx / 2.0).abs() < 1e-5);
    let frame = half.views.frame(&half.views.train[0]).unwrap();
    assert_eq!(
        frame.image.dims(),
        [camera.height as usize, camera.width as usize, 3]
    );
    assert!(half.step().unwrap().loss.is_finite());
}

/// A capture of `frames` frames with one person valid in each, whose track has `rows` rows of
/// `joints` joints.
fn person_capture(frames: usize, rows: usize, joints: usize) -> Dataset {
    let frame = BodyFrame {
        global_orient: [0.1, 0.2, 0.3],
        body_pose: vec![0.05; 3 * (joints - 1)],
        betas: vec![0.0; 10],
        transl: [0.0, 0.2, 3.0],
        world_from_smpl: Similarity::IDENTITY,
        root_position: None,
        extra: Default::default(),
    };
    Dataset {
        format: Format::Zju,
        root: PathBuf::from("/captures/CoreView_000"),
        frame_count: frames,
        frame_times: Vec::new(),
        views: Vec::new(),
        people: vec![PoseTrack {
            person: "subject".into(),
            frames: vec![Some(frame); rows],
        }],
        splits: Default::default(),
        points: Vec::new(),
        boxes: Vec::new(),
        warnings: Vec::new(),
        image_downscale: 1,
    }
}

#[test]
fn bad_captures_are_named() {
    let model = &builtin_body().model;
    let ok = person_sequence(&person_capture(5, 5, 24), 0, model, false).unwrap();
    assert_eq!(ok.sequence.frames(), 5);
    assert_eq!(ok.sequence.joints, 24);
    // An SMPL-X track keeps its body joints on the 24-joint body.
    let smplx = person_sequence(&person_capture(5, 5, 55), 0, model, false).unwrap();
    assert_eq!(smplx.sequence.joints, 24);
    for (dataset, person, expected) in [
        (person_capture(5, 3, 24), 0, "3 frames"),
        (person_capture(5, 5, 10), 0, "poses"),
        (person_capture(5, 5, 24), 1, "person 1"),
    ] {
        let error = person_sequence(&dataset, person, model, false)
            .expect_err("refused")
            .to_string();
        assert!(error.contains(expected), "{error}");
        assert!(error.contains("CoreView_000"), "{error}");
    }
    // An unknown training camera, and a capture without person masks.
    let dir = tempfile::tempdir().unwrap();
    let device = Device::flex();
    zju_fixture(dir.path());
    let mut config = avatar_config(dir.path());
    config.data.train_cameras = vec!["Camera_B99".into()];
    let error = AvatarTrainer::new(config, &device)
        .err()
        .expect("refused")
        .to_string();
    assert!(error.contains("Camera_B99"), "{error}");
    let plain = dir.path().join("plain");
    std::fs::create_dir_all(&plain).unwrap();
    nerfstudio_fixture(&plain, false);
    let error = AvatarTrainer::new(avatar_config(&plain), &device)
        .err()
        .expect("refused")
        .to_string();
    assert!(error.contains("pose track"), "{error}");
}

#[test]
fn a_capture_with_a_background_node_resumes_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let device = Device::flex();
    neuman_fixture(dir.path(), false);
    let config = avatar_config(dir.path());
    let mut whole = AvatarTrainer::new(config.clone(), &device).unwrap();
    assert!(whole.scenery.is_some(), "{:?}", whole.decisions());
    for _ in 0..6 {
        whole.step().unwrap();
    }
    let mut first = AvatarTrainer::new(config.clone(), &device).unwrap();
    for _ in 0..3 {
        first.step().unwrap();
    }
    let mut checkpoint = first.checkpoint();
    checkpoint.put_meta("step", 3);
    let mut second = AvatarTrainer::resume(config.clone(), &checkpoint, &device).unwrap();
    for _ in 0..3 {
        second.step().unwrap();
    }
    let (a, b) = (whole.checkpoint(), second.checkpoint());
    assert!(a.tensors.contains_key("background.splats.means"));
    assert_eq!(
        a.tensors.keys().collect::<Vec<_>>(),
        b.tensors.keys().collect::<Vec<_>>()
    );
    for (name, value) in &a.tensors {
        assert_eq!(value, &b.tensors[name], "{name} differs after resuming");
    }
    let evaluation = whole.evaluate(None).unwrap();
    assert!(evaluation.extra.contains_key("novel_pose_scene_psnr"));
    let chosen = whole.modules().remove(0);
    assert!(chosen.enabled && chosen.forced_by.is_none(), "{chosen:?}");
    assert!(chosen.reason.contains("sparse points"), "{chosen:?}");
    // Forced off, the same capture has no background node, and says why.
    let mut off = config;
    off.scenery = Some(false);
    let off = AvatarTrainer::new(off, &device).unwrap();
    assert!(off.scenery.is_none());
    let chosen = off.modules().remove(0);
    assert!(
        !chosen.enabled && chosen.forced_by.as_deref() == Some("scenery"),
        "{chosen:?}"
    );
}

#[test]
fn a_body_model_file_skins_the_avatar() {
    let dir = tempfile::tempdir().unwrap();
    let device = Device::flex();
    zju_fixture(dir.path());
    // The built-in body written in SMPL's `.npz` key layout: read back as an SMPL-family file.
    let model = dir.path().join("model.npz");
    splatzoo_models::body::save_npz(&builtin_body().model, &model).unwrap();
    let mut config = avatar_config(dir.path());
    config.body_model = Some(model);
    let mut trainer = AvatarTrainer::new(config.clone(), &device).unwrap();
    let decisions = trainer.decisions().join("\n");
    assert!(decisions.contains("shape coefficients kept"), "{decisions}");
    // A studio capture without points of its surroundings gets no background node.
    let chosen = trainer.modules().remove(0);
    assert!(!chosen.enabled && chosen.forced_by.is_none(), "{chosen:?}");
    assert!(trainer.scenery.is_none());
    assert!(trainer.step().unwrap().loss.is_finite());
    config.body_model = Some(dir.path().join("missing.npz"));
    let error = AvatarTrainer::new(config, &device)
        .err()
        .expect("refused")
        .to_string();
    assert!(error.contains("missing.npz"), "{error}");
}
