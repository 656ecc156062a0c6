//! The whole AAGaussian step on every backend: three steps of the trainer from the same seed on
//! NdArray and on wgpu (lavapipe without a GPU) render the avatar as Flex's does.

use crate::common::tiny_portrait;
use burn::tensor::Device;
use splatzoo_aagaussian::Aag;
use splatzoo_aagaussian::config::AagConfig;
use splatzoo_aagaussian::data::PortraitConfig;
use splatzoo_aagaussian::trainer::render_views;
use splatzoo_train::backend::Backend;
use splatzoo_train::harness::Method;
use splatzoo_train::host_f32;

/// The avatar's render from one held-out camera after three steps on `device`.
fn three_steps(backend: Backend) -> Vec<f32> {
    let device: Device = backend.device();
    let config = AagConfig {
        backend,
        gaussians: 500,
        batch: 2,
        render_size: 16,
        data: PortraitConfig {
            eval_size: 32,
            ..tiny_portrait(16)
        },
        ..AagConfig::default()
    };
    let mut method = Aag::new(config, &device).expect("assembles");
    for _ in 0..3 {
        method.step().expect("a step");
    }
    let trainer = &method.trainer;
    let splats = trainer.node.set.splats();
    let render = render_views(&splats, &trainer.capture.eval_cameras[..1])
        .expect("renders")
        .remove(0);
    host_f32(&render.color)
}

fn matches_flex(backend: Backend) {
    let reference = three_steps(Backend::Flex);
    let other = three_steps(backend);
    let mse = reference
        .iter()
        .zip(&other)
        .map(|(a, b)| f64::from(a - b).powi(2))
        .sum::<f64>()
        / reference.len() as f64;
    let psnr = -10.0 * mse.max(1e-20).log10();
    println!("{backend:?} vs flex after three steps: {psnr:.1} dB");
    assert!(
        psnr > 40.0,
        "{backend:?} vs flex after three steps: {psnr:.1} dB"
    );
}

#[test]
fn aag_steps_alike_on_ndarray() {
    matches_flex(Backend::Ndarray);
}

#[test]
fn aag_steps_alike_on_wgpu() {
    matches_flex(Backend::Wgpu);
}
