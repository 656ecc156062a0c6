//! APF-GS at the extremes, through the engine's shared check: the first S2 step (residual
//! field, gate and accessories on) with the pose prior off by about π on every joint, a coarse
//! mask covering every pixel, one frame, a 1×1 image, a single background point and a
//! zero-opacity human: each a finite step with finite state, or a refusal naming the knob.

use crate::trainer::small;
use burn::tensor::Device;
use splatzoo_apf_gs::config::ApfConfig;
use splatzoo_apf_gs::data::CoarseMask;
use splatzoo_apf_gs::trainer::ApfTrainer;
use splatzoo_train::harness::extremes::{StepOutcome, after_steps, assert_stable};

/// One warm-up step, then the first S2 step.
fn through_s2(config: ApfConfig) -> Result<StepOutcome, String> {
    let mut config = config;
    config.warmup = 1;
    after_steps::<ApfTrainer>(config, &Device::flex(), 2)
}

#[test]
fn apf_steps_at_the_extremes_or_refuses_by_name() {
    type Change = fn(&mut ApfConfig);
    // (case, change, must it run rather than be refused)
    let cases: [(&str, Change, bool); 4] = [
        (
            "pose prior off by ~π on every joint",
            |c| {
                c.data.noise.pose_bias = std::f64::consts::PI;
                c.data.noise.pose_noise = std::f64::consts::PI;
            },
            true,
        ),
        (
            "every pixel in the coarse mask",
            |c| {
                c.data.coarse = CoarseMask::Dilated;
                c.data.coarse_dilation = 10_000;
            },
            true,
        ),
        (
            "one background point",
            |c| c.data.background_points = 1,
            false,
        ),
        ("one frame", |c| c.data.frames = 1, false),
    ];
    for (what, change, must_run) in cases {
        let mut config = small();
        change(&mut config);
        let outcome = assert_stable(what, through_s2(config));
        assert!(
            !must_run || matches!(outcome, StepOutcome::Finite { .. }),
            "{what}: {outcome:?}"
        );
    }
    // Sizes and opacities the method cannot use are refused by name.
    let mut pixel = small();
    pixel.data.width = 1;
    pixel.data.height = 1;
    if let StepOutcome::Refused(message) = assert_stable("1×1 image", through_s2(pixel)) {
        assert!(message.contains("width"), "{message}");
    }
    let mut clear = small();
    clear.human.initial_opacity = 0.0;
    match assert_stable("zero opacity", through_s2(clear)) {
        StepOutcome::Refused(message) => {
            assert!(message.contains("initial_opacity"), "{message}")
        }
        other => panic!("zero opacity: expected a refusal, got {other:?}"),
    }
}
