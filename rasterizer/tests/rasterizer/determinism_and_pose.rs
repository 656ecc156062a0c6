//! The CPU path is bit-for-bit deterministic across runs and thread counts, and a camera-pose
//! gradient flows when splats are moved into a refined camera frame with ordinary Burn ops.

use crate::common::*;
use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_rasterizer::cpu;
use splatzoo_rasterizer::testing::{SceneSpec, random_scene};
use splatzoo_rasterizer::{ColorMode, Splats, rasterize};

#[test]
fn cpu_path_is_deterministic_across_thread_counts() {
    let (host, settings) = random_scene(
        5,
        &SceneSpec::new(3000, 211, 130, ColorMode::Sh { degree: 3 }),
    );
    let scene = host.to_real::<f32>();
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let fwd = cpu::forward(&scene.splats(), &scene.background, &settings);
            let grad_image: Vec<f32> = fwd.image.iter().map(|v| v.sin()).collect();
            let g = cpu::backward(
                &scene.splats(),
                &scene.background,
                &settings,
                &fwd.projected,
                &fwd.final_transmittance,
                &fwd.contributors,
                &grad_image,
            );
            (fwd.image, g.splats.means, g.splats.colors, g.background)
        })
    };
    let first = run(1);
    assert!(
        first.0.iter().any(|&v| v != first.0[0]),
        "image must not be flat"
    );
    for threads in [1, 2, 3, 7] {
        let again = run(threads);
        assert!(
            first.0 == again.0 && first.1 == again.1 && first.2 == again.2 && first.3 == again.3,
            "{threads} threads gave a different result"
        );
    }
}

/// Splats expressed in a refined camera frame: x' = exp([ω]×) x + δ, as a camera-refinement
/// module would, using first-order rotation (I + [ω]×) for brevity.
fn refined(splats: &Splats, omega: &Tensor<1>, delta: &Tensor<1>) -> Splats {
    let n = splats.len();
    let w: Vec<Tensor<1>> = (0..3).map(|i| omega.clone().slice(i..i + 1)).collect();
    let m = splats.means.clone();
    let col = |j: usize| m.clone().slice([0..n, j..j + 1]);
    // ω × x
    let cross = Tensor::cat(
        vec![
            col(2) * w[1].clone().reshape([1, 1]) - col(1) * w[2].clone().reshape([1, 1]),
            col(0) * w[2].clone().reshape([1, 1]) - col(2) * w[0].clone().reshape([1, 1]),
            col(1) * w[0].clone().reshape([1, 1]) - col(0) * w[1].clone().reshape([1, 1]),
        ],
        1,
    );
    Splats {
        means: m + cross + delta.clone().reshape([1, 3]),
        ..splats.clone()
    }
}

#[test]
fn camera_pose_gradient_flows_through_burn_ops() {
    let device = Device::flex().autodiff();
    let (host, settings) =
        random_scene(8, &SceneSpec::new(60, 48, 36, ColorMode::Sh { degree: 1 }));
    let (splats, bg) = host.tensors(&device);
    let target = values(rasterize(&splats, bg.clone(), &settings).unwrap().color);
    let target = Tensor::<3>::from_data(TensorData::new(target, [36, 48, 3]), &device);
    let loss_at = |omega: [f32; 3], delta: [f32; 3]| {
        let omega = Tensor::<1>::from_floats(omega, &device).require_grad();
        let delta = Tensor::<1>::from_floats(delta, &device).require_grad();
        let r = rasterize(&refined(&splats, &omega, &delta), bg.clone(), &settings).unwrap();
        let loss = (r.color - target.clone()).powi_scalar(2).sum();
        (loss, omega, delta)
    };
    let (loss, omega, delta) = loss_at([0.01, -0.02, 0.015], [0.03, -0.02, 0.01]);
    let grads = loss.backward();
    let g_delta = values(delta.grad(&grads).expect("pose translation gradient"));
    let g_omega = values(omega.grad(&grads).expect("pose rotation gradient"));
    assert!(g_delta.iter().chain(&g_omega).all(|v| v.is_finite()));
    assert!(
        g_delta.iter().map(|v| v.abs()).sum::<f32>() > 1e-3,
        "translation gradient is zero"
    );
    assert!(
        g_omega.iter().map(|v| v.abs()).sum::<f32>() > 1e-3,
        "rotation gradient is zero"
    );
    // The gradient agrees in direction with a finite difference along itself.
    let h = 2e-3;
    let norm = g_delta.iter().map(|v| v * v).sum::<f32>().sqrt();
    let step: Vec<f32> = g_delta.iter().map(|v| v / norm * h).collect();
    let eval = |sign: f32| {
        let d = [
            0.03 + sign * step[0],
            -0.02 + sign * step[1],
            0.01 + sign * step[2],
        ];
        values(loss_at([0.01, -0.02, 0.015], d).0)[0]
    };
    let fd = (eval(1.0) - eval(-1.0)) / (2.0 * h);
    assert!(
        (fd - norm).abs() < 0.1 * norm,
        "directional derivative {fd} vs gradient norm {norm}"
    );
}

#[test]
fn screen_gradient_norm_is_the_norm_of_the_offset_gradient() {
    let device = Device::flex().autodiff();
    let (mut host, settings) =
        random_scene(9, &SceneSpec::new(30, 40, 30, ColorMode::Sh { degree: 0 }));
    // Splat 0 behind the camera: culled, so its statistic must be 0.
    host.means[..3].copy_from_slice(&[0.4, -0.3, -6.0]);
    let l = leaves(&host, &device);
    let r = render(&l, &settings);
    let grads = r.color.clone().powi_scalar(2).sum().backward();
    let norm = values(
        r.screen_gradient_norm(&grads)
            .expect("statistic under autodiff"),
    );
    let offsets = values(r.screen_offsets.grad(&grads).unwrap());
    let radii = values(r.radii.clone());
    assert_eq!(radii[0], 0.0);
    assert_eq!(norm[0], 0.0, "culled splat");
    for (i, g) in offsets.chunks(2).enumerate() {
        let expected = (g[0] * g[0] + g[1] * g[1]).sqrt();
        assert!((norm[i] - expected).abs() <= 1e-6 * expected.max(1.0));
    }
    assert!(
        norm.iter().zip(&radii).any(|(n, r)| *r > 0.0 && *n > 0.0),
        "visible splats move the loss"
    );
}
