//! `train-illum`'s method on a tiny capture: it crosses the hand-over and a density edit of
//! the human, resumes bit-exactly on the CPU from a stage-1 and from a stage-2 checkpoint,
//! scores every held-out quantity, each Table-4 arm is one `--set` line that runs, a shared
//! environment fitted before the probes resumes exactly too (and a checkpoint from before it
//! as before), and a schedule that leaves no stage 2 is refused by name.

use burn::module::Module;
use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_illum::config::IllumConfig;
use splatzoo_illum::data::IllumDataConfig;
use splatzoo_illum::method::{Illum, IllumArgs};
use splatzoo_illum::visibility::bce_with_logits;
use splatzoo_train::checkpoint::Checkpoint;
use splatzoo_train::densify::DensifyConfig;
use splatzoo_train::harness::{Method, MethodConfig};

pub fn tiny() -> IllumConfig {
    let mut config = IllumConfig {
        iterations: 8,
        data: IllumDataConfig {
            width: 48,
            height: 36,
            frames: 6,
            test_every: 3,
            novel_pose_frames: 1,
            supersample: 1,
            shadow_resolution: 64,
            scene_points: 600,
            ..IllumDataConfig::default()
        },
        ..IllumConfig::default()
    };
    config.stage1.steps = 3;
    config.stage2.samples = 4;
    config.stage2.eval_samples = 4;
    // Every Gaussian qualifies for growth at step 4, capped at 40 more rows: a density edit
    // whose re-binding the resumed run must reproduce.
    config.stage2.densify = DensifyConfig {
        start: 3,
        stop: 100,
        every: 2,
        grad_threshold: 0.0,
        max_gaussians: 14_036,
        ..config.stage2.densify.clone()
    };
    config.visibility.labels = 128;
    config.visibility.warmup = 4;
    config
}

pub fn with_step(method: &Illum) -> Checkpoint {
    let mut checkpoint = method.checkpoint();
    checkpoint.put_meta("step", method.steps());
    checkpoint
}

pub fn assert_same(a: &Checkpoint, b: &Checkpoint, what: &str) {
    assert_eq!(
        a.tensors.keys().collect::<Vec<_>>(),
        b.tensors.keys().collect::<Vec<_>>(),
        "{what}: the checkpoints hold different tensors"
    );
    let differing: Vec<&String> = a
        .tensors
        .iter()
        .filter(|(name, value)| *value != &b.tensors[*name])
        .map(|(name, _)| name)
        .collect();
    assert!(differing.is_empty(), "{what}: {differing:?} differ");
}

#[test]
fn crosses_the_hand_over_and_resumes_exactly() {
    let device = Device::flex();
    let config = tiny();
    let mut whole = Illum::new(config.clone(), &device).unwrap();
    // Initial weights come from the process-wide generator, which the other tests of this
    // binary draw from concurrently; both runs start from the same step-0 state instead.
    let start = with_step(&whole);
    let faces = whole.trainer.mesh.face_count();
    let mut notes = Vec::new();
    for _ in 0..config.iterations {
        let report = whole.step().unwrap();
        assert!(report.loss.is_finite(), "loss {}", report.loss);
        notes.extend(report.note);
    }
    assert!(
        notes
            .iter()
            .any(|n| n.starts_with("stage 2") && n.contains("F_vis warmed up for 4 steps")),
        "no hand-over note with F_vis's warm-up in {notes:?}"
    );
    let human = whole
        .trainer
        .stage2
        .as_ref()
        .expect("stage 2 ran")
        .human
        .set
        .len();
    assert!(
        human > faces,
        "no density edit: {human} Gaussians from {faces}"
    );

    let mut first = Illum::resume(config.clone(), &start, &device).unwrap();
    first.step().unwrap();
    first.step().unwrap();
    let in_stage_one = with_step(&first);
    for _ in 2..5 {
        first.step().unwrap();
    }
    let in_stage_two = with_step(&first);
    for (checkpoint, from) in [(&in_stage_one, 2), (&in_stage_two, 5)] {
        let mut resumed = Illum::resume(config.clone(), checkpoint, &device).unwrap();
        assert_eq!(resumed.steps(), from);
        for _ in from..config.iterations {
            resumed.step().unwrap();
        }
        assert_same(
            &with_step(&whole),
            &with_step(&resumed),
            &format!("resumed at step {from}"),
        );
    }

    let scores = whole.trainer.evaluate(None).unwrap();
    println!("{scores:?}");
    let truth = scores
        .truth
        .as_ref()
        .expect("the synthetic capture's truth scores");
    for (name, value) in [
        ("psnr", scores.psnr),
        ("human_psnr", scores.human_psnr),
        ("relit_human_psnr", truth.relit_human_psnr),
        ("shadow_error", truth.shadow_error),
        ("novel_pose_psnr", truth.novel_pose_psnr),
    ] {
        assert!(value.is_finite(), "{name} = {value}");
    }
    assert_eq!(truth.relit.len(), 2, "{:?}", truth.relit);
    assert!(truth.albedo_psnr.is_some_and(f64::is_finite));
    assert!(truth.probe_relative_error.is_some_and(f64::is_finite));
    assert!(truth.probe_relative_error_seen.is_some_and(f64::is_finite));
    let probes = whole.trainer.volume.grid().count();
    let seen = truth.probes_seen.expect("counted with the error");
    assert!(
        seen >= 8 && seen <= probes,
        "{seen} of {probes} probes seen"
    );
    assert!(truth.shadow_error_without_ao.is_some());
}

/// `light.shared_environment` with `light.probes_from_step`: in stage 2 only the shared
/// environment moves until that step (the probes' own parts stay exactly 0), then both do; a
/// run resumed between the two phases ends bit-identical.
#[test]
fn the_shared_environment_is_fitted_first_and_resumes_exactly() {
    let device = Device::flex();
    let mut config = tiny();
    assert!(config.light.shared_environment, "on by default");
    config.light.probes_from_step = 6;
    let mut whole = Illum::new(config.clone(), &device).unwrap();
    let start = with_step(&whole);
    let initial = whole.trainer.volume.environment.val().into_data();
    for _ in 0..6 {
        whole.step().unwrap();
    }
    let residuals = crate::values(whole.trainer.volume.sh.val());
    assert!(
        residuals.iter().all(|&v| v == 0.0),
        "the probes moved early"
    );
    assert_ne!(
        whole.trainer.volume.environment.val().into_data(),
        initial,
        "the environment did not move in stage 2"
    );
    for _ in 6..config.iterations {
        whole.step().unwrap();
    }
    let residuals = crate::values(whole.trainer.volume.sh.val());
    assert!(
        residuals.iter().any(|&v| v != 0.0),
        "the probes never moved"
    );

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

/// A checkpoint written before the shared environment existed (no `volume.environment` and no
/// optimiser state for it) resumes to exactly what the full checkpoint resumes to; asking it
/// for a shared environment is refused by name.
#[test]
fn a_checkpoint_from_before_the_environment_resumes_as_before() {
    let device = Device::flex();
    let mut config = tiny();
    config.light.shared_environment = false;
    let mut run = Illum::new(config.clone(), &device).unwrap();
    for _ in 0..4 {
        run.step().unwrap();
    }
    let full = with_step(&run);
    let mut old = full.clone();
    old.tensors
        .retain(|name, _| !name.starts_with("volume.environment"));
    old.metadata
        .retain(|name, _| !name.starts_with("volume.environment"));
    assert!(old.tensors.len() < full.tensors.len());
    let mut from_full = Illum::resume(config.clone(), &full, &device).unwrap();
    let mut from_old = Illum::resume(config.clone(), &old, &device).unwrap();
    for _ in 4..config.iterations {
        from_full.step().unwrap();
        from_old.step().unwrap();
    }
    assert_same(
        &with_step(&from_full),
        &with_step(&from_old),
        "resumed without the environment",
    );
    let mut shared = config;
    shared.light.shared_environment = true;
    let error = Illum::resume(shared, &old, &device)
        .err()
        .expect("refused")
        .to_string();
    assert!(error.contains("volume.environment"), "{error}");
}

#[test]
fn each_arm_is_one_line_and_runs() {
    let device = Device::flex();
    let arms = [
        (
            "baseline",
            IllumArgs {
                baseline: true,
                ..IllumArgs::default()
            },
        ),
        (
            "no_two_stage",
            IllumArgs {
                no_two_stage: true,
                ..IllumArgs::default()
            },
        ),
    ];
    for (name, args) in arms {
        let sets = Illum::overrides(&args);
        let mut base = tiny();
        base.iterations = 4;
        let config: IllumConfig = splatzoo_train::config::load(&base, None, &sets).unwrap();
        let mut method = Illum::new(config.clone(), &device).unwrap();
        match name {
            "baseline" => {
                assert!(!config.ablation.light_volume && config.ablation.shadow == Some(false));
            }
            _ => assert!(
                method.trainer.stage2.is_some(),
                "without two stages, stage 2 starts at step 0"
            ),
        }
        for _ in 0..config.iterations {
            assert!(method.step().unwrap().loss.is_finite(), "{name}");
        }
        let scores = method.trainer.evaluate(None).unwrap();
        assert!(scores.psnr.is_finite(), "{name}: {scores:?}");
        if name == "baseline" {
            let truth = scores
                .truth
                .as_ref()
                .expect("the synthetic capture's truth scores");
            assert!(truth.albedo_psnr.is_none() && truth.shadow_error_without_ao.is_none());
        }
    }
    assert_eq!(
        Illum::overrides(&IllumArgs {
            no_probe_smoothness: true,
            ..IllumArgs::default()
        }),
        vec!["weights.probe=0.0".to_owned()]
    );
}

#[test]
fn a_schedule_without_stage_two_is_refused_by_name() {
    let config = IllumConfig {
        iterations: 10,
        ..tiny()
    };
    let mut bad = config.clone();
    bad.stage1.steps = 10;
    let error = bad.validate().expect_err("refused").to_string();
    assert!(error.contains("stage1.steps"), "{error}");
    let mut bad = config.clone();
    bad.light.degree = 4;
    let error = bad.validate().expect_err("refused").to_string();
    assert!(error.contains("light.degree"), "{error}");
    // Holding the probes needs the shared environment, and must end before the run does.
    let mut bad = config.clone();
    bad.light.shared_environment = false;
    bad.light.probes_from_step = 5;
    let error = bad.validate().expect_err("refused").to_string();
    assert!(error.contains("light.shared_environment"), "{error}");
    let mut bad = config;
    bad.light.shared_environment = true;
    bad.light.probes_from_step = 10;
    let error = bad.validate().expect_err("refused").to_string();
    assert!(error.contains("light.probes_from_step"), "{error}");
    bad.light.probes_from_step = 9;
    bad.validate().expect("the probes learn at the last step");
}

/// GauHuman's distance-to-mesh prune (on by default under KL density control): the refined
/// canonical mesh keeps its own vertices and drops a point a metre off it, at
/// `mesh_prune_distance · H / 1.7`; distance 0 or another strategy builds none; and in a run,
/// a Gaussian moved a metre off the body is the one the next decision prunes off the mesh.
#[test]
fn the_human_is_pruned_where_it_leaves_the_refined_mesh() {
    let device = Device::flex();
    let config = tiny();
    let mut method = Illum::new(config.clone(), &device).unwrap();
    let canonical = method.trainer.canonical_vertices();
    let surface = method
        .trainer
        .surface_prune(&canonical)
        .expect("on by default");
    let height = method.trainer.mesh.height;
    assert!((surface.max_distance - 0.05 * height / 1.7).abs() < 1e-12);
    assert!(canonical.iter().all(|&v| !surface.is_off(v)));
    assert!(surface.is_off([canonical[0][0], canonical[0][1], canonical[0][2] + 1.0]));
    for (key, value) in [
        ("stage2.mesh_prune_distance", "0"),
        ("stage2.densify.strategy", "\"adc\""),
    ] {
        let set = [format!("{key}={value}")];
        let off: IllumConfig = splatzoo_train::config::load(&config, None, &set).unwrap();
        let other = Illum::new(off, &device).unwrap();
        assert!(other.trainer.surface_prune(&canonical).is_none(), "{key}");
    }
    let mut bad = config.clone();
    bad.stage2.mesh_prune_distance = -1.0;
    let error = bad.validate().expect_err("refused").to_string();
    assert!(error.contains("stage2.mesh_prune_distance"), "{error}");

    while method.trainer.stage2.is_none() {
        method.step().unwrap();
    }
    let stage2 = method.trainer.stage2.as_mut().unwrap();
    let n = stage2.human.set.len();
    let mut means = splatzoo_train::host_f32(&stage2.human.set.means);
    means[2] += 1.0;
    stage2.human.set.means = Tensor::from_data(TensorData::new(means, [n, 3]), &device);
    let note = loop {
        let report = method.step().unwrap();
        if let Some(note) = report.note.filter(|n| n.starts_with("human density")) {
            break note;
        }
        assert!(method.steps() < config.iterations, "no density decision");
    };
    assert!(note.contains("(1 off the mesh)"), "{note}");
}

/// F_vis's BCE on fresh labels of every training pose (seeds no step draws).
fn fresh_visibility_loss(method: &Illum) -> f64 {
    let t = &method.trainer;
    let mut total = 0.0;
    for &k in &t.train {
        let frame = t.capture.frames[k].frame;
        let pose = t.frame_pose(frame, false);
        let labels = t.visibility_labels(&pose, 256, 0xFE5E ^ frame as u64);
        let count = labels.open.len();
        let flat = |v: &[[f64; 3]]| -> Vec<f32> { v.iter().flatten().map(|&x| x as f32).collect() };
        let device = &t.device;
        let points =
            Tensor::<2>::from_data(TensorData::new(flat(&labels.points), [count, 3]), device);
        let world = Tensor::<2>::from_data(
            TensorData::new(flat(&labels.directions), [count, 3]),
            device,
        );
        let local = world.matmul(pose.root.clone()).reshape([count, 1, 3]);
        let open = Tensor::<2>::from_data(TensorData::new(labels.open, [count, 1]), device);
        let logits = t.visibility.valid().logits(points, local, pose.pose_vector);
        total += bce_with_logits(logits, open).into_scalar::<f32>() as f64;
    }
    total / t.train.len() as f64
}

/// `visibility.warmup`: F_vis's own steps run once, at the hand-over, on the training poses,
/// and lower its loss on fresh labels of those poses; the image steps of stage 2 are the same
/// in number either way, and a run without it leaves F_vis as drawn until stage 2's first step.
#[test]
fn fvis_warms_up_at_the_hand_over_on_the_training_poses() {
    let device = Device::flex();
    let mut config = tiny();
    config.visibility.warmup = 0;
    let mut method = Illum::new(config.clone(), &device).unwrap();
    let start = with_step(&method);
    for _ in 0..config.stage1.steps {
        method.step().unwrap();
    }
    let trainer = &mut method.trainer;
    trainer.stage2 = Some(trainer.hand_over());
    assert_eq!(
        trainer.visibility_warmup(),
        None,
        "no warm-up was asked for"
    );
    let before = fresh_visibility_loss(&method);
    let trainer = &mut method.trainer;
    trainer.config.visibility.warmup = 60;
    let (first, last) = trainer.visibility_warmup().expect("60 warm-up steps");
    let after = fresh_visibility_loss(&method);
    println!("warm-up BCE {first:.4} → {last:.4}; fresh labels {before:.4} → {after:.4}");
    assert!(last < first, "the warm-up's BCE went {first} → {last}");
    assert!(
        after < 0.9 * before,
        "fresh labels of the training poses: BCE {before} → {after}"
    );

    // Through the harness: F_vis is untouched through stage 1 either way, and the warm-up
    // happens inside the hand-over step.
    config.visibility.warmup = 60;
    let mut warmed = Illum::resume(config.clone(), &start, &device).unwrap();
    let mut plain = Illum::resume(tiny_without_warmup(&config), &start, &device).unwrap();
    for _ in 0..config.stage1.steps {
        warmed.step().unwrap();
        plain.step().unwrap();
    }
    let weights = |m: &Illum| m.trainer.visibility.head.weight.val().into_data();
    assert_eq!(weights(&warmed), weights(&plain), "F_vis moved in stage 1");
    let note = warmed.step().unwrap().note.unwrap_or_default();
    plain.step().unwrap();
    assert!(note.contains("F_vis warmed up for 60 steps"), "{note}");
    let (warmed, plain) = (
        fresh_visibility_loss(&warmed),
        fresh_visibility_loss(&plain),
    );
    assert!(
        warmed < 0.9 * plain,
        "after the hand-over step: BCE {warmed} warmed up, {plain} not"
    );
}

fn tiny_without_warmup(config: &IllumConfig) -> IllumConfig {
    let mut config = config.clone();
    config.visibility.warmup = 0;
    config
}
