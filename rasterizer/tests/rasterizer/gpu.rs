//! The CubeCL kernels on wgpu (the default, fused backend) against the CPU path: forward
//! images, every input's gradient, and the extremes. Without a GPU this runs on Mesa's lavapipe
//! Vulkan driver, slowly but for real.

use crate::common::*;
use burn::tensor::Device;
use splatzoo_rasterizer::testing::{HostScene, SceneSpec, default_camera, random_scene};
use splatzoo_rasterizer::{ColorMode, RasterMode, RasterSettings, rasterize};

fn gpu() -> Device {
    Device::wgpu(Default::default())
}

fn forward_values(
    scene: &HostScene,
    settings: &RasterSettings,
    device: &Device,
) -> (Vec<f32>, Vec<f32>) {
    let (splats, bg) = scene.tensors(device);
    let r = rasterize(&splats, bg, settings).unwrap();
    (values(packed(&r)), values(r.radii))
}

#[test]
fn forward_matches_cpu() {
    for (seed, color, mode, n, w, h) in [
        (
            31,
            ColorMode::Sh { degree: 3 },
            RasterMode::Classic,
            300,
            70,
            45,
        ),
        (
            32,
            ColorMode::Sh { degree: 0 },
            RasterMode::AntiAliased,
            50,
            16,
            16,
        ),
        (33, ColorMode::Features, RasterMode::Classic, 120, 33, 47),
        (
            34,
            ColorMode::Sh { degree: 2 },
            RasterMode::Classic,
            0,
            20,
            20,
        ),
        (
            35,
            ColorMode::Sh { degree: 1 },
            RasterMode::Classic,
            40,
            1,
            1,
        ),
    ] {
        let (scene, mut settings) = random_scene(seed, &SceneSpec::new(n, w, h, color));
        settings.mode = mode;
        let (cpu, cpu_radii) = forward_values(&scene, &settings, &Device::flex());
        let (gpu, gpu_radii) = forward_values(&scene, &settings, &gpu());
        assert_eq!(cpu.len(), gpu.len());
        let err = relative_error(&gpu, &cpu);
        let mean = gpu
            .iter()
            .zip(&cpu)
            .map(|(a, b)| (a - b).abs())
            .sum::<f32>()
            / cpu.len().max(1) as f32;
        assert!(
            err < 1e-2 && mean < 1e-4,
            "seed {seed}: max relative {err}, mean {mean}"
        );
        assert_eq!(cpu_radii, gpu_radii, "seed {seed}: radii");
    }
}

#[test]
fn gradients_match_cpu() {
    for (seed, color, mode) in [
        (41, ColorMode::Sh { degree: 3 }, RasterMode::Classic),
        (42, ColorMode::Sh { degree: 1 }, RasterMode::AntiAliased),
        (43, ColorMode::Features, RasterMode::Classic),
    ] {
        let (scene, settings, weights) = smooth_scene(seed, 60, (37, 29), color, mode);
        let run = |device: Device| {
            let device = device.autodiff();
            let weights = weight_tensor(&weights, &settings, &device);
            let l = leaves(&scene, &device);
            let r = render(&l, &settings);
            let grads = (packed(&r) * weights).sum().backward();
            let offsets = values(
                r.screen_offsets
                    .grad(&grads)
                    .expect("screen-offset gradient"),
            );
            let mut all = l.grads(&grads);
            all.push(("screen_offsets", offsets));
            all
        };
        let cpu = run(Device::flex());
        let gpu = run(gpu());
        for ((field, g), (_, c)) in gpu.iter().zip(&cpu) {
            let err = relative_error(g, c);
            assert!(
                err < 2e-3,
                "seed {seed} {mode:?}: d/d{field} relative error {err}"
            );
        }
    }
}

#[test]
fn extremes_stay_finite_on_gpu() {
    let device = gpu().autodiff();
    let (mut scene, settings) =
        random_scene(51, &SceneSpec::new(8, 21, 13, ColorMode::Sh { degree: 1 }));
    scene.log_scales[..12]
        .iter_mut()
        .for_each(|v| *v = 1e-8f32.ln());
    scene.log_scales[12..]
        .iter_mut()
        .for_each(|v| *v = 1e4f32.ln());
    scene.quats[..4].iter_mut().for_each(|v| *v = 0.0);
    scene.quats[4..8].iter_mut().for_each(|v| *v = 1e30);
    scene.opacity_logits[0] = 60.0;
    scene.opacity_logits[1] = -60.0;
    scene.means[9] = f32::NAN;
    let mut settings = settings;
    settings.camera = default_camera(21, 13);
    let l = leaves(&scene, &device);
    let r = render(&l, &settings);
    let grads = (r.color.clone().sum() + r.alpha.clone().sum() + r.depth.clone().sum()).backward();
    for (name, v) in [
        ("color", values(r.color)),
        ("alpha", values(r.alpha)),
        ("depth", values(r.depth)),
    ] {
        assert!(v.iter().all(|x| x.is_finite()), "{name}");
    }
    assert_eq!(values(r.radii)[3], 0.0, "the NaN splat is culled");
    for (name, g) in l.grads(&grads) {
        assert!(g.iter().all(|x| x.is_finite()), "gradient of {name}");
    }
}

#[test]
fn gpu_path_is_deterministic() {
    // Atomics only count and scatter intersections; the per-tile sort on unique (depth, splat)
    // keys and fixed-order reductions make the result independent of their order.
    let (scene, settings, weights) = smooth_scene(
        61,
        400,
        (64, 48),
        ColorMode::Sh { degree: 2 },
        RasterMode::Classic,
    );
    let run = || {
        let device = gpu().autodiff();
        let l = leaves(&scene, &device);
        let r = render(&l, &settings);
        let image = packed(&r);
        let grads = (image.clone() * weight_tensor(&weights, &settings, &device))
            .sum()
            .backward();
        (values(image), l.grads(&grads))
    };
    let (image, grads) = run();
    for _ in 0..2 {
        let (again, again_grads) = run();
        assert!(image == again, "image differs between runs");
        for ((name, a), (_, b)) in grads.iter().zip(&again_grads) {
            assert!(a == b, "gradient of {name} differs between runs");
        }
    }
}
