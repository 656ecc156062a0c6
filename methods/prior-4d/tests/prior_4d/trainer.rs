//! The four stages end to end on a tiny capture: finite losses through stage D, stage C's plane
//! and σ₀, the scene's geometry untouched by stage D.

use burn::tensor::Device;
use splatzoo_prior_4d::Prior4d;
use splatzoo_prior_4d::config::Prior4dConfig;
use splatzoo_train::harness::Method;
use splatzoo_train::host_f32;

/// A run small enough for a test: 80×60, 8 acting frames, 40 + 30 + 30 steps, no keypoint fit.
pub fn tiny_config() -> Prior4dConfig {
    let mut c = Prior4dConfig::default();
    c.data.width = 80;
    c.data.height = 60;
    c.data.acting_frames = 8;
    c.data.scene_views = 12;
    c.data.scan_views = 8;
    c.data.supersample = 1;
    c.scene.steps = 40;
    c.scene.densify.start = 10;
    c.scene.densify.stop = 30;
    c.scene.densify.every = 10;
    c.avatar.steps = 30;
    c.avatar.subdivisions = 0;
    c.avatar.holdout_every = 4;
    c.plane.min_opacity = 0.05;
    c.joint.eval_stride = 4;
    c.iterations = 100;
    // Stage C's keypoint fit has its own tests (`keypoints`); off here to keep each tiny run
    // short.
    c.body_fit.keypoints = false;
    c
}

/// [`tiny_config`] cut to two scene steps (no density control), two avatar steps, then stage
/// C and stage D to `iterations`.
pub fn into_stage_d(iterations: usize) -> Prior4dConfig {
    let mut c = tiny_config();
    c.scene.steps = 2;
    c.scene.densify.strategy = splatzoo_train::densify::Strategy::None;
    c.avatar.steps = 2;
    c.iterations = iterations;
    c
}

fn finite(name: &str, values: &[f32]) {
    if let Some(k) = values.iter().position(|v| !v.is_finite()) {
        panic!("{name}[{k}] = {}", values[k]);
    }
}

#[test]
fn four_stages_run_with_finite_losses() {
    let config = tiny_config();
    let device = Device::flex();
    let mut method = Prior4d::new(config.clone(), &device).expect("a tiny run");
    while method.steps() < config.iterations {
        let report = method.step().expect("a step");
        assert!(
            report.loss.is_finite(),
            "step {}: loss {}",
            method.steps(),
            report.loss
        );
        if let Some(joint) = &method.joint {
            let step = method.steps();
            finite(&format!("step {step} log σ"), &host_f32(&joint.log_sigma));
            finite(
                &format!("step {step} camera rotation"),
                &host_f32(&joint.camera_rotation),
            );
            finite(
                &format!("step {step} camera translation"),
                &host_f32(&joint.camera_translation),
            );
            let set = joint.avatar.canonical_set();
            finite(&format!("step {step} avatar means"), &host_f32(&set.means));
            finite(
                &format!("step {step} avatar scales"),
                &host_f32(&set.log_scales),
            );
            finite(
                &format!("step {step} avatar colours"),
                &host_f32(&set.sh_dc),
            );
            finite(
                &format!("step {step} betas"),
                &host_f32(joint.avatar.betas()),
            );
            finite(
                &format!("step {step} pose deltas"),
                &host_f32(&joint.avatar.poses.deltas),
            );
            finite(
                &format!("step {step} translation deltas"),
                &host_f32(&joint.avatar.poses.translation_deltas),
            );
            finite(
                &format!("step {step} scene colours"),
                &host_f32(&joint.scene.set.sh_dc),
            );
        }
    }
    // Stage D moved the scene's SH only: its geometry is stage A's, bit for bit.
    let joint = method.joint.as_ref().expect("stage D ran");
    let (a, d) = (&method.scene.node.set, &joint.scene.set);
    assert_eq!(host_f32(&a.means), host_f32(&d.means));
    assert_eq!(host_f32(&a.quats), host_f32(&d.quats));
    assert_eq!(host_f32(&a.log_scales), host_f32(&d.log_scales));
    assert_eq!(host_f32(&a.opacity_logits), host_f32(&d.opacity_logits));
    assert_ne!(
        host_f32(&a.sh_dc),
        host_f32(&d.sh_dc),
        "the scene's colours adapt"
    );
    // Stage C found the floor and a scale near the truth.
    let plane = joint.plane();
    assert!(plane.normal[1] > 0.99, "floor normal {:?}", plane.normal);
    let sigma_star = method.sigma_star().expect("the synthetic capture's truth");
    assert!(
        (joint.init.sigma0 / sigma_star - 1.0).abs() < 0.1,
        "σ₀ {} against σ* {sigma_star}",
        joint.init.sigma0
    );
}

/// Camera refinement is a data rule: on for the tiny capture's SfM-estimated acting cameras,
/// off when both camera-noise knobs are 0 (a calibrated rig) — the per-frame corrections stay
/// exactly zero through stage D — and `joint.camera_refinement` forces it either way. The
/// decision is kept in the run's configuration and its module list.
#[test]
fn acting_cameras_are_refined_only_where_they_are_estimated() {
    let device = Device::flex();
    let short = |change: &dyn Fn(&mut Prior4dConfig)| {
        let mut c = into_stage_d(7);
        change(&mut c);
        Prior4d::new(c, &device).expect("a tiny run")
    };
    let choice = |m: &Prior4d| {
        m.modules()
            .into_iter()
            .find(|c| c.module == "acting-camera refinement")
            .expect("listed")
    };
    let estimated = short(&|_| {});
    assert_eq!(estimated.config.joint.camera_refinement, Some(true));
    let listed = choice(&estimated);
    assert!(listed.enabled && listed.forced_by.is_none(), "{listed:?}");

    let calibrated = |c: &mut Prior4dConfig| {
        c.data.camera_rotation_noise_degrees = 0.0;
        c.data.camera_translation_noise = 0.0;
    };
    let mut exact = short(&calibrated);
    assert_eq!(exact.config.joint.camera_refinement, Some(false));
    let listed = choice(&exact);
    assert!(
        !listed.enabled && listed.reason.contains("calibrated"),
        "{listed:?}"
    );
    while exact.steps() < exact.config.iterations {
        assert!(exact.step().expect("a step").loss.is_finite());
    }
    let joint = exact.joint.as_ref().expect("stage D ran");
    assert!(host_f32(&joint.camera_rotation).iter().all(|v| *v == 0.0));
    assert!(
        host_f32(&joint.camera_translation)
            .iter()
            .all(|v| *v == 0.0)
    );

    let forced = short(&|c| {
        calibrated(c);
        c.joint.camera_refinement = Some(true);
    });
    let listed = choice(&forced);
    assert!(listed.enabled, "{listed:?}");
    assert_eq!(listed.forced_by.as_deref(), Some("joint.camera_refinement"));
}
