//! `train-nlf` on a real capture's layout (`data.train`, `data.test`): THuman2.0 as GHG renders
//! it, written by the datasets crate's fixture (two training subjects, one held out, with their
//! SMPL-X fits). Each subject has GHG's three input and three target views at the training
//! side, the body posed by its fit where the cameras see it, and its depth where the body is;
//! the trainer steps, scores the held-out subject finitely and resumes exactly; a missing
//! split or target view is refused by name.

use burn::tensor::Device;
use splatzoo_datasets::fixtures::{ghg_fit, ghg_subject};
use splatzoo_models::body::builtin_body;
use splatzoo_nlf_gs::capture::capture_subjects;
use splatzoo_nlf_gs::config::{NlfData, NlfTrainConfig};
use splatzoo_nlf_gs::trainer::NlfTrainer;
use splatzoo_train::harness::{History, Method, MethodConfig, full_checkpoint};
use splatzoo_train::host_f32;
use std::path::Path;

/// GHG's protocol positions (inputs 0, 6, 11; targets 3, 8, 13).
const POSITIONS: [usize; 6] = [0, 3, 6, 8, 11, 13];

fn write_thuman(thuman: &Path) {
    for subject in ["0004", "0007"] {
        ghg_subject(&thuman.join("train"), subject, &POSITIONS, 1);
        ghg_fit(thuman, subject);
    }
    ghg_subject(&thuman.join("val"), "0011", &POSITIONS, 1);
    ghg_fit(thuman, "0011");
}

fn tiny(thuman: &Path) -> NlfTrainConfig {
    let mut c = NlfTrainConfig {
        size: 32,
        train_subjects: 2,
        test_subjects: 1,
        iterations: 3,
        onnx: false,
        data: NlfData {
            train: Some(thuman.join("train")),
            test: Some(thuman.join("val")),
            body_model: None,
        },
        ..NlfTrainConfig::default()
    };
    c.network.fpn_channels = 8;
    c.network.gaussians_per_face = 1;
    c
}

#[test]
fn a_thuman_capture_gives_subjects_that_train_score_and_resume() {
    let device = Device::flex();
    let dir = tempfile::tempdir().unwrap();
    write_thuman(dir.path());
    let dataset = splatzoo_datasets::formats::load(&dir.path().join("train"), None).unwrap();
    let model = &builtin_body().model;
    let (subjects, _) = capture_subjects(&dataset, model, 32, 8, &device).unwrap();
    assert_eq!(subjects.len(), 2);
    for subject in &subjects {
        assert_eq!((subject.inputs.len(), subject.targets.len()), (3, 3));
        for view in subject.inputs.iter().chain(&subject.targets) {
            assert_eq!(view.image.dims(), [32, 32, 3]);
            assert_eq!((view.camera.width, view.camera.height), (32, 32));
            let mask = host_f32(&view.mask);
            assert!(mask.iter().all(|&m| m == 0.0 || m == 1.0));
            assert!(
                mask.contains(&1.0),
                "the fixture's mask corner survives the resize"
            );
        }
        assert_eq!(subject.vertices.dims(), [1, model.vertex_count(), 3]);
        let depth = host_f32(&subject.input_depth);
        assert!(
            depth.iter().any(|d| d.is_finite() && *d > 0.0),
            "the body is in view"
        );
        // Depth is the posed body's: in front of every input camera, within its distance.
        let finite: Vec<f32> = depth.into_iter().filter(|d| d.is_finite()).collect();
        assert!(
            finite.iter().all(|&d| d > 0.5 && d < 4.0),
            "{:?}",
            &finite[..4.min(finite.len())]
        );
    }

    let config = tiny(dir.path());
    config.validate().unwrap();
    let mut whole = NlfTrainer::new(config.clone(), &device).unwrap();
    assert!(
        whole.decisions()[0].starts_with("subjects: 2 training"),
        "{:?}",
        whole.decisions()
    );
    let history = History::default();
    let start = full_checkpoint(&whole, &config, &history);
    for _ in 0..config.iterations {
        assert!(whole.step().unwrap().loss.is_finite());
    }
    let scores = whole.evaluate(None).unwrap();
    assert!(scores.scores.psnr.is_finite(), "{scores:?}");
    let mut partial = NlfTrainer::resume(config.clone(), &start, &device).unwrap();
    partial.step().unwrap();
    let middle = full_checkpoint(&partial, &config, &history);
    let mut resumed = NlfTrainer::resume(config.clone(), &middle, &device).unwrap();
    for _ in 1..config.iterations {
        resumed.step().unwrap();
    }
    assert_eq!(whole.checkpoint().tensors, resumed.checkpoint().tensors);
}

#[test]
fn a_capture_missing_a_split_or_a_view_is_refused_by_name() {
    let device = Device::flex();
    let dir = tempfile::tempdir().unwrap();
    write_thuman(dir.path());
    let mut one_split = tiny(dir.path());
    one_split.data.test = None;
    let error = one_split.validate().unwrap_err().to_string();
    assert!(error.contains("data.test"), "{error}");
    let mut body_alone = tiny(dir.path());
    body_alone.data = NlfData {
        body_model: Some("SMPLX_NEUTRAL.npz".into()),
        ..NlfData::default()
    };
    let error = body_alone.validate().unwrap_err().to_string();
    assert!(error.contains("data.body_model"), "{error}");

    // A held-out subject without target position 13.
    let broken = dir.path().join("broken");
    ghg_subject(&broken.join("val"), "0011", &POSITIONS[..5], 1);
    ghg_fit(&broken, "0011");
    let dataset = splatzoo_datasets::formats::load(&broken.join("val"), None).unwrap();
    let error = capture_subjects(&dataset, &builtin_body().model, 32, 1, &device)
        .err()
        .expect("refused")
        .to_string();
    assert!(error.contains("2 `targets` views"), "{error}");
}
