//! What a scene gets: the static trainer's view-dependent colour is limited to what its
//! training views support (a few-view scene gets SH degree 0 unless forced), `data.train_views`
//! keeps a few views and initialises from them alone, and the decisions are reported; the
//! avatar refines its body track only where the track is an estimate.

use burn::tensor::Device;
use splatzoo_train::harness::Method;
use splatzoo_train::static_scene::{StaticConfig, StaticTrainer, supported_sh_degree};

#[test]
fn sh_degree_d_needs_as_many_views_as_its_coefficients() {
    let expected = [
        (0, 0),
        (1, 0),
        (3, 0),
        (4, 1),
        (8, 1),
        (9, 2),
        (15, 2),
        (16, 3),
        (42, 3),
        (1000, 3),
    ];
    for (views, degree) in expected {
        assert_eq!(supported_sh_degree(views), degree, "{views} views");
        assert!(((degree + 1) as usize).pow(2) <= views.max(1));
    }
}

fn config(train_views: Option<usize>, forced: Option<bool>) -> StaticConfig {
    let mut c = StaticConfig {
        iterations: 10,
        view_dependence: forced,
        ..Default::default()
    };
    c.data.size = 24;
    c.data.init_stride = 3;
    c.data.train_views = train_views;
    c
}

#[test]
fn a_few_view_scene_gets_no_view_dependent_colour_unless_forced() {
    let device = Device::flex();
    let mut full = StaticTrainer::new(config(None, None), &device).unwrap();
    let mut few = StaticTrainer::new(config(Some(3), None), &device).unwrap();
    let mut forced = StaticTrainer::new(config(Some(3), Some(true)), &device).unwrap();
    let mut off = StaticTrainer::new(config(None, Some(false)), &device).unwrap();
    assert_eq!(full.views.train.len(), 42);
    assert_eq!(few.views.train.len(), 3);
    assert_eq!(
        few.views.test.len(),
        full.views.test.len(),
        "the held-out set is kept"
    );
    // Evenly spread: the middle of each third of the 42 training views.
    let names: Vec<&str> = few.views.train.iter().map(|v| v.name.as_str()).collect();
    assert_eq!(names, ["view_009", "view_025", "view_041"]);
    assert!(
        few.graph.gaussians() * 5 < full.graph.gaussians(),
        "initialised from 3 views' depth alone: {} vs {}",
        few.graph.gaussians(),
        full.graph.gaussians()
    );
    let module = |t: &StaticTrainer| t.modules().remove(0);
    let (a, b, c, d) = (module(&full), module(&few), module(&forced), module(&off));
    assert!(a.enabled && a.forced_by.is_none(), "{a:?}");
    assert!(!b.enabled && b.forced_by.is_none(), "{b:?}");
    assert!(
        b.reason
            .contains("3 training views support SH degree 0 of 3"),
        "{b:?}"
    );
    assert!(
        c.enabled && c.forced_by.as_deref() == Some("view_dependence"),
        "{c:?}"
    );
    assert!(c.reason.contains("from the data alone"), "{c:?}");
    assert!(!d.enabled && d.forced_by.is_some(), "{d:?}");
    assert!(
        few.decisions()
            .iter()
            .any(|l| l.contains("training on 3 of 42"))
    );
    for (trainer, degree) in [
        (&mut full, 3),
        (&mut few, 0),
        (&mut forced, 3),
        (&mut off, 0),
    ] {
        trainer.step = 100_000;
        assert_eq!(trainer.sh_degree(), degree);
        assert!(trainer.step().unwrap().loss.is_finite());
    }
    let error = StaticTrainer::new(config(Some(0), None), &device)
        .err()
        .expect("refused")
        .to_string();
    assert!(error.contains("data.train_views"), "{error}");
}

fn small_avatar(
    noise: splatzoo_datasets::synth::prior::PriorNoise,
    forced: Option<bool>,
) -> splatzoo_train::avatar::AvatarConfig {
    let mut c = crate::extremes::small_avatar();
    c.data.noise = noise;
    c.pose_refinement = forced;
    c
}

/// Pose refinement is a data rule: the synthetic tracker's noisy track is refined; a track
/// that is the true motion is kept as given (its deltas never move through training steps);
/// `pose_refinement = true` forces it back on (and the deltas move).
#[test]
fn only_an_estimated_body_track_is_refined_unless_forced() {
    use splatzoo_datasets::synth::prior::PriorNoise;
    use splatzoo_train::avatar::AvatarTrainer;
    use splatzoo_train::host_f32;
    let device = Device::flex();
    let refinement = |t: &AvatarTrainer| t.modules().remove(1);
    let deltas = |t: &AvatarTrainer| {
        let mut all = host_f32(&t.node.poses.deltas);
        all.extend(host_f32(&t.node.poses.translation_deltas));
        all
    };
    let noisy = AvatarTrainer::new(small_avatar(PriorNoise::default(), None), &device).unwrap();
    let chosen = refinement(&noisy);
    assert!(chosen.enabled && chosen.forced_by.is_none(), "{chosen:?}");
    assert!(chosen.reason.contains("estimate"), "{chosen:?}");
    assert_eq!(noisy.config.pose_refinement, Some(true));

    for (forced, moves) in [(None, false), (Some(true), true)] {
        let mut exact =
            AvatarTrainer::new(small_avatar(PriorNoise::none(), forced), &device).unwrap();
        let chosen = refinement(&exact);
        assert_eq!(chosen.enabled, moves, "{chosen:?}");
        assert_eq!(chosen.forced_by.is_some(), forced.is_some(), "{chosen:?}");
        assert_eq!(exact.config.node.refine_rotations, moves);
        let before = deltas(&exact);
        while exact.step < 4 {
            assert!(exact.step().unwrap().loss.is_finite());
        }
        assert_eq!(
            deltas(&exact) != before,
            moves,
            "forced {forced:?}: the deltas should {}move",
            if moves { "" } else { "not " }
        );
    }
}
