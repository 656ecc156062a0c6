//! NLF-GS at the extremes, through the engine's shared check: a whole training step (encoder,
//! decoder, splat render, loss, Adam) at the smallest input the encoder takes (32²), with one
//! training identity, one Gaussian per face and the paper's four; the sizes it cannot take
//! refused by name.

use burn::tensor::Device;
use splatzoo_nlf_gs::config::NlfTrainConfig;
use splatzoo_nlf_gs::trainer::NlfTrainer;
use splatzoo_train::harness::extremes::{StepOutcome, assert_stable, one_step};

fn tiny() -> NlfTrainConfig {
    let mut c = NlfTrainConfig {
        size: 32,
        train_subjects: 1,
        test_subjects: 1,
        iterations: 2,
        onnx: false,
        ..NlfTrainConfig::default()
    };
    c.network.fpn_channels = 8;
    c.network.gaussians_per_face = 1;
    c
}

fn step(what: &str, config: NlfTrainConfig) -> StepOutcome {
    assert_stable(what, one_step::<NlfTrainer>(config, &Device::flex()))
}

#[test]
fn a_whole_step_at_the_extremes_is_finite_or_refused_by_name() {
    let outcome = step("32², one identity, one Gaussian a face", tiny());
    assert!(matches!(outcome, StepOutcome::Finite { .. }), "{outcome:?}");
    let mut four = tiny();
    four.network.gaussians_per_face = 4;
    let outcome = step("four Gaussians a face", four);
    assert!(matches!(outcome, StepOutcome::Finite { .. }), "{outcome:?}");
    type Change = fn(&mut NlfTrainConfig);
    let refused: [(&str, Change, &str); 3] = [
        ("a 31² image", |c| c.size = 31, "size"),
        (
            "no Gaussian a face",
            |c| c.network.gaussians_per_face = 0,
            "gaussians_per_face",
        ),
        (
            "no training identity",
            |c| c.train_subjects = 0,
            "train_subjects",
        ),
    ];
    for (what, change, key) in refused {
        let mut config = tiny();
        change(&mut config);
        match step(what, config) {
            StepOutcome::Refused(message) => assert!(message.contains(key), "{what}: {message}"),
            other => panic!("{what}: expected a refusal, got {other:?}"),
        }
    }
}
