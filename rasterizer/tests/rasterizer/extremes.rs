//! Numerical stability at the extremes: every output and every gradient stays finite, and the
//! documented behaviour (culling, validation errors) holds.

use crate::common::*;
use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_rasterizer::testing::{HostScene, SceneSpec, default_camera, random_scene};
use splatzoo_rasterizer::{ColorMode, RasterError, RasterMode, RasterSettings, Render, rasterize};

fn device() -> Device {
    Device::flex().autodiff()
}

fn base(n: usize) -> (HostScene, RasterSettings) {
    random_scene(99, &SceneSpec::new(n, 40, 24, ColorMode::Sh { degree: 2 }))
}

/// Renders, backpropagates a loss touching every output, and checks everything is finite.
fn render_finite(
    scene: &HostScene,
    settings: &RasterSettings,
) -> (Render, Vec<(&'static str, Vec<f32>)>) {
    let device = device();
    let l = leaves(scene, &device);
    let r = render(&l, settings);
    let loss = r.color.clone().sum() + r.alpha.clone().sum() + r.depth.clone().sum() * 0.01;
    let grads = loss.backward();
    for (name, t) in [
        ("color", values(r.color.clone())),
        ("alpha", values(r.alpha.clone())),
        ("depth", values(r.depth.clone())),
        ("radii", values(r.radii.clone())),
    ] {
        assert!(t.iter().all(|v| v.is_finite()), "{name} output not finite");
    }
    let g = l.grads(&grads);
    for (name, values) in &g {
        assert!(
            values.iter().all(|v| v.is_finite()),
            "gradient of {name} not finite: {values:?}"
        );
    }
    (r, g)
}

fn set_all(buffer: &mut [f32], value: f32) {
    buffer.iter_mut().for_each(|v| *v = value);
}

#[test]
fn tiny_and_huge_scales_stay_finite() {
    for scale in [1e-8f32, 1e4] {
        for mode in [RasterMode::Classic, RasterMode::AntiAliased] {
            let (mut scene, mut settings) = base(8);
            settings.mode = mode;
            set_all(&mut scene.log_scales, scale.ln());
            let (r, _) = render_finite(&scene, &settings);
            let radii = values(r.radii);
            assert!(
                radii.iter().any(|&v| v > 0.0),
                "scale {scale}: some splat should be visible"
            );
        }
    }
}

#[test]
fn zero_and_huge_quaternions() {
    let (mut scene, settings) = base(8);
    set_all(&mut scene.quats, 0.0);
    let (zero, _) = render_finite(&scene, &settings);
    // A zero quaternion is the identity rotation.
    for q in scene.quats.chunks_mut(4) {
        q[0] = 1.0;
    }
    let (identity, _) = render_finite(&scene, &settings);
    assert_eq!(values(zero.color), values(identity.color.clone()));
    // Scaling a quaternion by 1e30 changes nothing.
    set_all(&mut scene.quats, 0.0);
    for q in scene.quats.chunks_mut(4) {
        q[0] = 1e30;
    }
    let (huge, _) = render_finite(&scene, &settings);
    assert!(relative_error(&values(huge.color), &values(identity.color)) < 1e-6);
}

#[test]
fn saturated_opacity_logits() {
    for logit in [-60.0f32, 60.0] {
        let (mut scene, settings) = base(8);
        set_all(&mut scene.opacity_logits, logit);
        let (r, _) = render_finite(&scene, &settings);
        let alpha = values(r.alpha);
        if logit < 0.0 {
            assert!(
                alpha.iter().all(|&a| a == 0.0),
                "opacity ~0 must leave the image empty"
            );
        } else {
            assert!(alpha.iter().any(|&a| a > 0.9));
        }
    }
}

#[test]
fn splats_behind_on_near_plane_and_far_outside_are_culled() {
    let (mut scene, settings) = base(4);
    let cam = settings.camera;
    let r = cam.world_to_camera;
    // World point at camera-space (0, 0, z): p = Rᵀ (z e3 - t).
    let world_at = |x: f32, y: f32, z: f32| -> [f32; 3] {
        let c = [x - r[0][3], y - r[1][3], z - r[2][3]];
        [0, 1, 2].map(|j| r[0][j] * c[0] + r[1][j] * c[1] + r[2][j] * c[2])
    };
    let points = [
        world_at(0.0, 0.0, -2.0),     // behind
        world_at(0.0, 0.0, cam.near), // on the near plane
        world_at(1e6, 0.0, 3.0),      // far outside the frustum
        world_at(0.0, 0.0, 1e5),      // beyond the far plane
    ];
    for (i, p) in points.iter().enumerate() {
        scene.means[3 * i..3 * i + 3].copy_from_slice(p);
    }
    let (out, _) = render_finite(&scene, &settings);
    let radii = values(out.radii);
    // The near-plane splat lands a rounding error either side of the plane: it only has to stay
    // finite (checked above); the others must be culled.
    assert_eq!(
        [radii[0], radii[2], radii[3]],
        [0.0; 3],
        "culled: {radii:?}"
    );
    scene.means[3..6].copy_from_slice(&world_at(0.0, 0.0, 0.5 * cam.near));
    let (out, grads) = render_finite(&scene, &settings);
    assert_eq!(values(out.radii), vec![0.0; 4], "all culled");
    assert!(values(out.alpha).iter().all(|&a| a == 0.0));
    // All culled: the image is the background.
    let color = values(out.color);
    for px in color.chunks(3) {
        for (a, b) in px.iter().zip(&scene.background) {
            assert!((a - b).abs() < 1e-6);
        }
    }
    for (name, g) in grads {
        if name != "background" {
            assert!(
                g.iter().all(|&v| v == 0.0),
                "culled splats get zero {name} gradient"
            );
        }
    }
}

#[test]
fn zero_splats_render_the_background() {
    let (scene, settings) = base(0);
    let device = Device::flex();
    let (splats, bg) = scene.tensors(&device);
    let r = rasterize(&splats, bg, &settings).unwrap();
    let color = values(r.color);
    assert_eq!(color.len(), 40 * 24 * 3);
    for px in color.chunks(3) {
        assert_eq!(px, scene.background.as_slice());
    }
}

#[test]
fn one_splat_covering_the_whole_image() {
    let (mut scene, settings) = base(1);
    scene.means.copy_from_slice(&[0.0, 0.0, 0.0]);
    set_all(&mut scene.log_scales, 20.0f32.ln());
    let (r, _) = render_finite(&scene, &settings);
    assert!(
        values(r.alpha).iter().all(|&a| a > 0.05),
        "every pixel covered"
    );
}

#[test]
fn tiny_and_odd_image_sizes() {
    for (w, h) in [(1, 1), (1, 17), (17, 1), (31, 33), (16, 16)] {
        let (scene, mut settings) = base(16);
        settings.camera = default_camera(w, h);
        let (r, _) = render_finite(&scene, &settings);
        assert_eq!(r.color.dims(), [h as usize, w as usize, 3]);
    }
}

#[test]
fn non_finite_splats_are_culled_not_spread() {
    let (mut scene, settings) = base(6);
    scene.means[0] = f32::NAN;
    scene.quats[5] = f32::INFINITY;
    scene.log_scales[6] = f32::NEG_INFINITY;
    scene.opacity_logits[3] = f32::NAN;
    scene.colors[scene.coeffs * 3 * 4] = f32::NAN;
    scene.means[15..18].copy_from_slice(&[0.0, 0.0, 0.0]);
    let (r, _) = render_finite(&scene, &settings);
    let radii = values(r.radii);
    assert_eq!(&radii[..5], &[0.0; 5], "splats 0-4 hold non-finite values");
    // The poisoned splats contribute nothing: the image is that of splat 5 alone.
    let mut alone = scene.clone();
    alone.count = 1;
    alone.means = scene.means[15..18].to_vec();
    alone.quats = scene.quats[20..24].to_vec();
    alone.log_scales = scene.log_scales[15..18].to_vec();
    alone.opacity_logits = scene.opacity_logits[5..6].to_vec();
    let k = scene.coeffs * 3;
    alone.colors = scene.colors[5 * k..6 * k].to_vec();
    let (single, _) = render_finite(&alone, &settings);
    assert!(values(single.radii)[0] > 0.0, "splat 5 is visible");
    assert_eq!(values(r.color), values(single.color));
}

#[test]
fn bad_inputs_are_clear_errors() {
    let (scene, settings) = base(3);
    let device = Device::flex();
    let (splats, bg) = scene.tensors(&device);

    let mut bad = settings;
    bad.camera.fx = f32::NAN;
    let err = rasterize(&splats, bg.clone(), &bad).unwrap_err();
    assert!(
        matches!(err, RasterError::Camera(_)) && err.to_string().contains("fx"),
        "{err}"
    );

    let mut wrong = splats.clone();
    wrong.quats = Tensor::<2>::zeros([3, 3], &device);
    let err = rasterize(&wrong, bg.clone(), &settings).unwrap_err();
    assert!(
        err.to_string().contains("quats") && err.to_string().contains("[3, 4]"),
        "{err}"
    );

    let nan_bg = Tensor::<1>::from_data(TensorData::new(vec![0.0f32, f32::NAN, 0.0], [3]), &device);
    let err = rasterize(&splats, nan_bg, &settings).unwrap_err();
    assert!(err.to_string().contains("background"), "{err}");

    let mut sh4 = settings;
    sh4.color = ColorMode::Sh { degree: 3 };
    let err = rasterize(&splats, bg, &sh4).unwrap_err();
    assert!(
        err.to_string().contains("colors") && err.to_string().contains("16"),
        "{err}"
    );
}
