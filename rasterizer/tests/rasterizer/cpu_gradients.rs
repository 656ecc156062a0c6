//! The CPU kernels' backward against central finite differences of their own forward, in f64,
//! on fresh random scenes (both footprint modes, SH degrees 0–3 and free features).

use rand::{Rng, SeedableRng, rngs::StdRng};
use splatzoo_rasterizer::cpu;
use splatzoo_rasterizer::testing::{RealScene, SceneSpec, random_scene};
use splatzoo_rasterizer::{ColorMode, RasterMode, RasterSettings};

/// Settings under which the image is a smooth function of the inputs: no alpha threshold and a
/// cut-off so far out that it changes nothing.
fn smooth(mut settings: RasterSettings, mode: RasterMode) -> RasterSettings {
    settings.alpha_min = 0.0;
    settings.clip_sigmas = 9.0;
    settings.mode = mode;
    settings
}

fn loss(scene: &RealScene<f64>, settings: &RasterSettings, weights: &[f64]) -> f64 {
    let out = cpu::forward(&scene.splats(), &scene.background, settings);
    out.image.iter().zip(weights).map(|(a, b)| a * b).sum()
}

fn check(seed: u64, color: ColorMode, mode: RasterMode) {
    let mut spec = SceneSpec::new(10, 23, 19, color);
    spec.opacity_range = (0.1, 0.6);
    let (host, settings) = random_scene(seed, &spec);
    let settings = smooth(settings, mode);
    let mut scene = host.to_real::<f64>();
    // Non-zero screen offsets exercise that input too.
    let mut rng = StdRng::seed_from_u64(seed ^ 0xabc);
    for v in scene.screen_offsets.iter_mut() {
        *v = rng.random_range(-0.5..0.5);
    }
    let out_len = (settings.camera.width * settings.camera.height) as usize * (scene.channels + 2);
    let weights: Vec<f64> = (0..out_len).map(|_| rng.random_range(-1.0..1.0)).collect();

    let fwd = cpu::forward(&scene.splats(), &scene.background, &settings);
    assert!(
        fwd.projected
            .chunks(cpu::proj_stride(scene.channels))
            .any(|r| r[cpu::PROJ_RADIUS] > 0.0),
        "scene must have visible splats"
    );
    let grads = cpu::backward(
        &scene.splats(),
        &scene.background,
        &settings,
        &fwd.projected,
        &fwd.final_transmittance,
        &fwd.contributors,
        &weights,
    );
    let analytic: [(&str, Vec<f64>); 7] = [
        ("means", grads.splats.means),
        ("quats", grads.splats.quats),
        ("log_scales", grads.splats.log_scales),
        ("opacity_logits", grads.splats.opacity_logits),
        ("colors", grads.splats.colors),
        ("background", grads.background),
        ("screen_offsets", grads.splats.screen_offsets),
    ];
    let h = 1e-6;
    let mut worst = 0.0f64;
    for (b, (name, expected)) in analytic.iter().enumerate() {
        for (i, &analytic_i) in expected.iter().enumerate() {
            let original = scene.buffers_mut()[b].1[i];
            scene.buffers_mut()[b].1[i] = original + h;
            let up = loss(&scene, &settings, &weights);
            scene.buffers_mut()[b].1[i] = original - h;
            let down = loss(&scene, &settings, &weights);
            scene.buffers_mut()[b].1[i] = original;
            let fd = (up - down) / (2.0 * h);
            let err = (fd - analytic_i).abs() / (1.0 + fd.abs());
            worst = worst.max(err);
            assert!(
                err < 1e-5,
                "seed {seed} {color:?} {mode:?}: d loss / d {name}[{i}] analytic {} vs finite difference {fd}",
                expected[i]
            );
        }
    }
    assert!(worst.is_finite());
}

#[test]
fn gradients_match_finite_differences_classic_sh() {
    for (seed, degree) in [(1, 0), (2, 1), (3, 2), (4, 3)] {
        check(seed, ColorMode::Sh { degree }, RasterMode::Classic);
    }
}

#[test]
fn gradients_match_finite_differences_antialiased() {
    for (seed, degree) in [(5, 3), (6, 1)] {
        check(seed, ColorMode::Sh { degree }, RasterMode::AntiAliased);
    }
}

#[test]
fn gradients_match_finite_differences_features() {
    for seed in [7, 8] {
        check(seed, ColorMode::Features, RasterMode::Classic);
        check(seed + 100, ColorMode::Features, RasterMode::AntiAliased);
    }
}
