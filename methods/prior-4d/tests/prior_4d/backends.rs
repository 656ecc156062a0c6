//! Prior-4D's whole stage-D step is backend-generic: from one Flex checkpoint one step into
//! stage D (so the pose-offset network's weights and every Adam moment are shared), three more
//! steps — scene SH rendered as features, the avatar with its pose-dependent offsets, σ, the
//! acting cameras; photometric, normal, contact and Huber terms — on NdArray and on wgpu
//! (lavapipe in CI) give Flex's evaluation render and global scale.

use crate::trainer::into_stage_d;
use crate::values;
use burn::tensor::Device;
use splatzoo_prior_4d::Prior4d;
use splatzoo_prior_4d::config::Prior4dConfig;
use splatzoo_train::backend::Backend;
use splatzoo_train::checkpoint::Checkpoint;
use splatzoo_train::harness::Method;

const TIMED_STEPS: usize = 3;

/// Stage D's first step on Flex: the shared start and its configuration.
fn start() -> (Prior4dConfig, Checkpoint) {
    let mut config = into_stage_d(0);
    config.iterations = config.joint_start() + 1 + TIMED_STEPS;
    let mut method = Prior4d::new(config.clone(), &Device::flex()).expect("a tiny run");
    while method.steps() <= config.joint_start() {
        method.step().expect("a step");
    }
    let mut checkpoint = method.checkpoint();
    checkpoint.put_meta("step", method.steps());
    (config, checkpoint)
}

/// The evaluation view of frame 0 and σ after the remaining steps on `backend`.
fn finish(backend: Backend, config: &Prior4dConfig, start: &Checkpoint) -> (Vec<f32>, f64) {
    let config = Prior4dConfig {
        backend,
        ..config.clone()
    };
    let mut method = Prior4d::resume(config.clone(), start, &backend.device())
        .unwrap_or_else(|e| panic!("{backend:?}: {e}"));
    while method.steps() < config.iterations {
        let report = method.step().expect("a step");
        assert!(report.loss.is_finite(), "{backend:?}: loss {}", report.loss);
    }
    let joint = method.joint.as_ref().expect("stage D");
    let scene = joint.scene_splats(&method.capture);
    let layers = joint
        .render_eval(&method.capture, &scene, 0, true)
        .expect("the evaluation render");
    (values(layers.color), joint.sigma())
}

fn matches_flex(backend: Backend) {
    let (config, start) = start();
    let (reference, sigma) = finish(Backend::Flex, &config, &start);
    let (image, other_sigma) = finish(backend, &config, &start);
    let mse = reference
        .iter()
        .zip(&image)
        .map(|(a, b)| f64::from(a - b).powi(2))
        .sum::<f64>()
        / reference.len() as f64;
    let psnr = -10.0 * mse.max(1e-20).log10();
    println!(
        "{backend:?} vs flex after {TIMED_STEPS} stage-D steps: {psnr:.1} dB, σ {other_sigma} vs {sigma}"
    );
    assert!(psnr > 40.0, "{backend:?} vs flex: {psnr:.1} dB");
    assert!(
        (other_sigma - sigma).abs() < 1e-4 * sigma,
        "{backend:?}: σ {other_sigma} vs flex {sigma}"
    );
}

#[test]
fn stage_d_runs_alike_on_the_cpu_backends() {
    matches_flex(Backend::Ndarray);
}

#[test]
fn stage_d_runs_alike_on_wgpu() {
    matches_flex(Backend::Wgpu);
}
