//! The CPU backends (NdArray, Flex) against the dense reference: forward images and every
//! input's gradient, on fresh random scenes.

use crate::common::*;
use burn::tensor::Device;
use splatzoo_rasterizer::testing::{SceneSpec, random_scene};
use splatzoo_rasterizer::{ColorMode, RasterMode, reference};

#[allow(deprecated)] // NdArray is deprecated upstream; we still serve it.
fn devices() -> Vec<(&'static str, Device)> {
    vec![("flex", Device::flex()), ("ndarray", Device::ndarray())]
}

#[test]
fn forward_matches_reference_with_inria_cutoffs() {
    for (name, device) in devices() {
        for (seed, color) in [(11, ColorMode::Sh { degree: 3 }), (12, ColorMode::Features)] {
            let (scene, settings) = random_scene(seed, &SceneSpec::new(40, 37, 29, color));
            let (splats, bg) = scene.tensors(&device);
            let op =
                packed(&splatzoo_rasterizer::rasterize(&splats, bg.clone(), &settings).unwrap());
            let expected = values(reference::render(&splats, bg, &settings));
            let actual = values(op);
            let err = relative_error(&actual, &expected);
            // Alpha thresholds may flip on rounding, a few 1/255-sized changes at most.
            assert!(err < 1e-2, "{name} seed {seed}: relative error {err}");
            let mean: f32 = actual
                .iter()
                .zip(&expected)
                .map(|(a, b)| (a - b).abs())
                .sum::<f32>()
                / actual.len() as f32;
            assert!(mean < 1e-4, "{name} seed {seed}: mean abs error {mean}");
        }
    }
}

#[test]
fn forward_and_gradients_match_reference_autodiff() {
    for (name, device) in devices() {
        let device = device.autodiff();
        for (seed, color, mode) in [
            (21, ColorMode::Sh { degree: 3 }, RasterMode::Classic),
            (22, ColorMode::Sh { degree: 1 }, RasterMode::AntiAliased),
            (23, ColorMode::Features, RasterMode::Classic),
        ] {
            let (scene, settings, weights) = smooth_scene(seed, 25, (33, 21), color, mode);
            let weights = weight_tensor(&weights, &settings, &device);

            let ours = leaves(&scene, &device);
            let image = packed(&render(&ours, &settings));
            let ours_grads = (image.clone() * weights.clone()).sum().backward();

            let theirs = leaves(&scene, &device);
            let ref_image = reference::render(&theirs.splats, theirs.background.clone(), &settings);
            let ref_grads = (ref_image.clone() * weights).sum().backward();

            let err = relative_error(&values(image), &values(ref_image));
            assert!(
                err < 1e-4,
                "{name} seed {seed}: forward relative error {err}"
            );
            for ((field, a), (_, b)) in ours
                .grads(&ours_grads)
                .into_iter()
                .zip(theirs.grads(&ref_grads))
            {
                let err = relative_error(&a, &b);
                assert!(
                    err < 3e-3,
                    "{name} seed {seed} {mode:?}: d/d{field} relative error {err}"
                );
                assert!(
                    a.iter().all(|v| v.is_finite()),
                    "{name}: {field} gradient not finite"
                );
            }
        }
    }
}
