//! Eq. 7's Monte-Carlo shading: a unit white light returns the albedo under the midpoint rule
//! (and R3DG's +3 % under its own), the diffuse sum converges to the analytic irradiance
//! `Σ Â_l c_lm Y_lm(n)`, the Burn ops match the f64 reference in values and gradients,
//! visibility 0 is black, and the sRGB curves invert each other and hit known values.

use std::f64::consts::PI;

use crate::brdf::{
    around, assert_gradient, central_difference, dot, f32_round, random_unit, tensor,
};
use crate::{Rng, fresh_seed, values};
use burn::tensor::{Device, Tensor};
use splatzoo_illum::pbr::{
    SRGB_ENCODED_KNEE, SRGB_LINEAR_KNEE, ShadeInputs, ShadePoint, Shading, face_forward,
    linear_to_srgb, linear_to_srgb_reference, shade, shade_reference, srgb_to_linear,
    srgb_to_linear_reference,
};
use splatzoo_illum::sampling::{
    HemisphereRule, fibonacci_hemisphere, fibonacci_hemisphere_reference,
};
use splatzoo_rasterizer::sh::{irradiance_f64, sh_basis_f64};

const DIFFUSE_ONLY: Shading = Shading { specular: false };

/// `n` Gaussians, all inputs f32-exact.
#[derive(Clone)]
struct Scene {
    normals: Vec<[f64; 3]>,
    views: Vec<[f64; 3]>,
    albedo: Vec<[f64; 3]>,
    metallic: Vec<f64>,
    roughness: Vec<f64>,
    /// `[K]` coefficient triples per Gaussian.
    sh: Vec<Vec<[f64; 3]>>,
    offsets: Vec<f64>,
}

impl Scene {
    /// Random normals (the first two ±z), views on either side at |n·ω_o| ≥ 0.05, and SH of
    /// `k` coefficients with DC radiance `dc` and the others uniform in `±rest`.
    fn random(rng: &mut Rng, n: usize, k: usize, dc: (f64, f64), rest: f64) -> Self {
        let round = |v: [f64; 3]| v.map(f32_round);
        let mut normals: Vec<[f64; 3]> = vec![[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]];
        normals.extend((2..n).map(|_| random_unit(rng)));
        normals.truncate(n);
        let mut views = Vec::with_capacity(n);
        for m in &normals {
            let cos = rng.range(0.05, 1.0) * if rng.range(0.0, 1.0) < 0.3 { -1.0 } else { 1.0 };
            views.push(round(around(*m, cos, rng.range(0.0, 2.0 * PI))));
        }
        let mut draw = |lo: f64, hi: f64| f32_round(rng.range(lo, hi));
        // c_00 = L/Y_00 = L·√(4π) for a DC radiance L.
        let sh: Vec<Vec<[f64; 3]>> = (0..n)
            .map(|_| {
                (0..k)
                    .map(|j| {
                        std::array::from_fn(|_| match j {
                            0 => f32_round(draw(dc.0, dc.1) * (4.0 * PI).sqrt()),
                            _ => draw(-rest, rest),
                        })
                    })
                    .collect()
            })
            .collect();
        Self {
            normals: normals.into_iter().map(round).collect(),
            views,
            albedo: (0..n)
                .map(|_| std::array::from_fn(|_| draw(0.05, 0.95)))
                .collect(),
            metallic: (0..n).map(|_| draw(0.0, 1.0)).collect(),
            roughness: (0..n).map(|_| draw(0.3, 1.0)).collect(),
            sh,
            offsets: (0..n).map(|_| draw(0.0, 2.0 * PI)).collect(),
        }
    }

    fn len(&self) -> usize {
        self.normals.len()
    }

    /// The f64 inputs of Gaussian `i` over `directions`.
    fn point<'a>(
        &'a self,
        i: usize,
        directions: &'a [[f64; 3]],
        visibility: Option<&'a [f64]>,
    ) -> ShadePoint<'a> {
        ShadePoint {
            normal: self.normals[i],
            view_dir: self.views[i],
            albedo: self.albedo[i],
            metallic: self.metallic[i],
            roughness: self.roughness[i],
            radiance_sh: &self.sh[i],
            directions,
            visibility,
        }
    }

    /// The Burn inputs on `device`, sampled by [`fibonacci_hemisphere`] about the normals
    /// facing the view (or the given `directions` `[N·S]` rows).
    fn inputs(
        &self,
        device: &Device,
        (count, rule): (usize, HemisphereRule),
        directions: Option<&[[f64; 3]]>,
        visibility: Option<&[f64]>,
    ) -> ShadeInputs {
        let n = self.len();
        let rows = |v: &[[f64; 3]]| tensor(&v.concat(), [v.len(), 3], device);
        let (normals, view_dirs) = (rows(&self.normals), rows(&self.views));
        let directions = match directions {
            Some(d) => tensor(&d.concat(), [n, count, 3], device),
            None => fibonacci_hemisphere(
                face_forward(normals.clone(), view_dirs.clone()),
                count,
                rule,
                Some(tensor(&self.offsets, [n], device)),
            ),
        };
        let k = self.sh[0].len();
        ShadeInputs {
            normals,
            view_dirs,
            albedo: rows(&self.albedo),
            metallic: tensor(&self.metallic, [n, 1], device),
            roughness: tensor(&self.roughness, [n, 1], device),
            radiance_sh: tensor(&self.sh.concat().concat(), [n, k, 3], device),
            directions,
            visibility: visibility.map(|v| tensor(v, [n, count], device)),
        }
    }
}

/// Rows `[N·S]` of a `[N, S, 3]` tensor.
fn rows_of(t: Tensor<3>) -> Vec<[f64; 3]> {
    values(t)
        .chunks(3)
        .map(|c| [c[0], c[1], c[2]].map(f64::from))
        .collect()
}

fn assert_close(seed: u64, what: &str, got: f64, want: f64, relative: f64) {
    assert!(
        (got - want).abs() <= relative * want.abs() + 1e-6,
        "seed {seed}: {what}: {got} vs {want}"
    );
}

#[test]
fn unit_white_light_returns_the_albedo() {
    let seed = fresh_seed();
    let mut rng = Rng(seed);
    let mut scene = Scene::random(&mut rng, 6, 9, (1.0, 1.0), 0.0);
    scene.metallic.fill(0.0);
    let count = 8 + (rng.next_u64() % 57) as usize;
    let device = Device::flex();
    for rule in [HemisphereRule::Midpoint, HemisphereRule::R3dg] {
        // 2·mean z_j: exactly 1 for the midpoint rule.
        let factor = 2.0 * (0..count).map(|j| rule.cos_theta(j, count)).sum::<f64>() / count as f64;
        let got = values(shade(
            scene.inputs(&device, (count, rule), None, None),
            &DIFFUSE_ONLY,
        ));
        for i in 0..scene.len() {
            let n = scene.normals[i].map(|v| v * dot(scene.normals[i], scene.views[i]).signum());
            let directions = fibonacci_hemisphere_reference(n, count, rule, scene.offsets[i]);
            let reference = shade_reference(&scene.point(i, &directions, None), &DIFFUSE_ONLY);
            for ch in 0..3 {
                let want = factor * scene.albedo[i][ch];
                assert_close(
                    seed,
                    &format!("{rule:?} f64 c'[{i}]"),
                    reference[ch],
                    want,
                    1e-6,
                );
                let burn = f64::from(got[3 * i + ch]);
                assert_close(seed, &format!("{rule:?} Burn c'[{i}]"), burn, want, 1e-4);
            }
        }
    }
    let sin10 = 10f64.to_radians().sin();
    let directions =
        fibonacci_hemisphere_reference([0.0, 0.0, 1.0], 1024, HemisphereRule::R3dg, 0.0);
    let up = ShadePoint {
        normal: [0.0, 0.0, 1.0],
        view_dir: [0.0, 0.0, 1.0],
        ..scene.point(0, &directions, None)
    };
    let white = shade_reference(&up, &DIFFUSE_ONLY);
    let bias = white[0] / scene.albedo[0][0];
    assert!(
        (bias - (1.0 + sin10 * sin10)).abs() < 1e-3,
        "R3DG's bias at N = 1024: {bias}"
    );
}

#[test]
fn monte_carlo_diffuse_approaches_the_analytic_irradiance() {
    let seed = fresh_seed();
    let mut rng = Rng(seed);
    let device = Device::flex();
    let count = 1024;
    for (degree, rest) in [(2u32, 0.1), (3, 0.05)] {
        let k = ((degree + 1) * (degree + 1)) as usize;
        let mut scene = Scene::random(&mut rng, 6, k, (1.0, 2.0), rest);
        scene.metallic.fill(0.0);
        let got = values(shade(
            scene.inputs(&device, (count, HemisphereRule::Midpoint), None, None),
            &DIFFUSE_ONLY,
        ));
        for i in 0..scene.len() {
            let n = scene.normals[i].map(|v| v * dot(scene.normals[i], scene.views[i]).signum());
            let offset = scene.offsets[i];
            let directions =
                fibonacci_hemisphere_reference(n, count, HemisphereRule::Midpoint, offset);
            for d in &directions {
                let basis = sh_basis_f64(degree, *d);
                let lowest = (0..3)
                    .map(|ch| {
                        scene.sh[i]
                            .iter()
                            .zip(&basis)
                            .map(|(c, y)| c[ch] * y)
                            .sum::<f64>()
                    })
                    .fold(f64::INFINITY, f64::min);
                assert!(
                    lowest > 0.0,
                    "seed {seed}: the test's radiance must stay positive"
                );
            }
            let reference = shade_reference(&scene.point(i, &directions, None), &DIFFUSE_ONLY);
            let irradiance = irradiance_f64(&scene.sh[i], degree, n);
            for ch in 0..3 {
                let want = scene.albedo[i][ch] / PI * irradiance[ch];
                let what = format!("degree {degree}, Gaussian {i}");
                assert_close(seed, &format!("{what}, f64"), reference[ch], want, 1e-2);
                assert_close(
                    seed,
                    &format!("{what}, Burn"),
                    f64::from(got[3 * i + ch]),
                    want,
                    1e-2,
                );
            }
        }
    }
}

#[test]
fn burn_shading_matches_the_reference() {
    let seed = fresh_seed();
    let mut rng = Rng(seed);
    let device = Device::flex();
    // Strong higher bands, so the clamp of the radiance at 0 is exercised.
    let scene = Scene::random(&mut rng, 6, 9, (0.2, 1.0), 0.5);
    let sampling = (16, HemisphereRule::Midpoint);
    let visibility: Vec<f64> = (0..6 * 16)
        .map(|_| f32_round(rng.range(0.0, 1.0)))
        .collect();
    let directions = rows_of(scene.inputs(&device, sampling, None, None).directions);
    for shading in [Shading::default(), DIFFUSE_ONLY] {
        let inputs = scene.inputs(
            &device,
            sampling,
            Some(&directions[..]),
            Some(&visibility[..]),
        );
        let got = values(shade(inputs, &shading));
        for i in 0..scene.len() {
            let window = 16 * i..16 * (i + 1);
            let point = scene.point(i, &directions[window.clone()], Some(&visibility[window]));
            let want = shade_reference(&point, &shading);
            for ch in 0..3 {
                let what = format!("{shading:?} c'[{i}, {ch}]");
                assert_close(seed, &what, f64::from(got[3 * i + ch]), want[ch], 1e-3);
            }
        }
    }
}

#[test]
fn visibility_scales_the_light() {
    let seed = fresh_seed();
    let mut rng = Rng(seed);
    let device = Device::flex();
    let scene = Scene::random(&mut rng, 5, 4, (0.5, 1.0), 0.2);
    let sampling = (12, HemisphereRule::R3dg);
    let shaded = |v: Option<&[f64]>| {
        values(shade(
            scene.inputs(&device, sampling, None, v),
            &Shading::default(),
        ))
    };
    let black = shaded(Some(&[0.0; 5 * 12][..]));
    assert!(
        black.iter().all(|&c| c == 0.0),
        "seed {seed}: V = 0 gives {black:?}"
    );
    let (open, lit) = (shaded(Some(&[1.0; 5 * 12][..])), shaded(None));
    for (a, b) in open.iter().zip(&lit) {
        assert!(
            (a - b).abs() <= 1e-6 * b.abs(),
            "seed {seed}: V = 1 gives {a}, none {b}"
        );
    }
    let empty = ShadeInputs {
        normals: Tensor::zeros([0, 3], &device),
        view_dirs: Tensor::zeros([0, 3], &device),
        albedo: Tensor::zeros([0, 3], &device),
        metallic: Tensor::zeros([0, 1], &device),
        roughness: Tensor::zeros([0, 1], &device),
        radiance_sh: Tensor::zeros([0, 9, 3], &device),
        directions: Tensor::zeros([0, 8, 3], &device),
        visibility: None,
    };
    assert_eq!(
        shade(empty, &Shading::default()).dims(),
        [0, 3],
        "0 Gaussians"
    );
}

#[test]
fn shading_gradients_match_finite_differences() {
    let seed = fresh_seed();
    let mut rng = Rng(seed);
    let (n, s, k) = (3, 8, 4);
    let mut scene = Scene::random(&mut rng, n, k, (1.0, 1.5), 0.1);
    for (i, view) in scene.views.iter_mut().enumerate() {
        let cos = rng.range(0.2, 0.9);
        *view = around(scene.normals[i], cos, rng.range(0.0, 2.0 * PI)).map(f32_round);
    }
    let visibility: Vec<f64> = (0..n * s).map(|_| f32_round(rng.range(0.2, 1.0))).collect();
    let weights: Vec<f64> = (0..n * 3).map(|_| f32_round(rng.gauss())).collect();
    let device = Device::flex().autodiff();
    let sampling = (s, HemisphereRule::Midpoint);
    let directions = rows_of(scene.inputs(&device, sampling, None, None).directions);
    // Flattened f64 inputs: normals, albedo, metallic, roughness, SH.
    let flat = |sc: &Scene| -> Vec<f64> {
        [
            sc.normals.concat(),
            sc.albedo.concat(),
            sc.metallic.clone(),
            sc.roughness.clone(),
            sc.sh.concat().concat(),
        ]
        .concat()
    };
    let sizes = [3 * n, 3 * n, n, n, 3 * n * k];
    let unflatten = |p: &[f64]| -> Scene {
        let mut sc = scene.clone();
        let mut rest = p;
        let mut take = |len: usize| {
            let (head, tail) = rest.split_at(len);
            rest = tail;
            head.to_vec()
        };
        let triples = |v: Vec<f64>| v.chunks(3).map(|c| [c[0], c[1], c[2]]).collect::<Vec<_>>();
        sc.normals = triples(take(sizes[0]));
        sc.albedo = triples(take(sizes[1]));
        sc.metallic = take(sizes[2]);
        sc.roughness = take(sizes[3]);
        sc.sh = triples(take(sizes[4]))
            .chunks(k)
            .map(<[_]>::to_vec)
            .collect();
        sc
    };
    let loss = |p: &[f64]| {
        let sc = unflatten(p);
        (0..n)
            .map(|i| {
                let window = s * i..s * (i + 1);
                let point = sc.point(i, &directions[window.clone()], Some(&visibility[window]));
                let c = shade_reference(&point, &Shading::default());
                (0..3).map(|ch| weights[3 * i + ch] * c[ch]).sum::<f64>()
            })
            .sum::<f64>()
    };
    let want = central_difference(loss, &flat(&scene), 1e-6);

    let inputs = scene.inputs(
        &device,
        sampling,
        Some(&directions[..]),
        Some(&visibility[..]),
    );
    let leaves = ShadeInputs {
        normals: inputs.normals.require_grad(),
        albedo: inputs.albedo.require_grad(),
        metallic: inputs.metallic.require_grad(),
        roughness: inputs.roughness.require_grad(),
        radiance_sh: inputs.radiance_sh.require_grad(),
        ..inputs
    };
    let colour = shade(leaves.clone(), &Shading::default());
    let grads = (colour * tensor(&weights, [n, 3], &device))
        .sum()
        .backward();
    let got = [
        ("normals", leaves.normals.grad(&grads).map(values)),
        ("albedo", leaves.albedo.grad(&grads).map(values)),
        ("metallic", leaves.metallic.grad(&grads).map(values)),
        ("roughness", leaves.roughness.grad(&grads).map(values)),
        ("radiance SH", leaves.radiance_sh.grad(&grads).map(values)),
    ];
    let mut start = 0;
    for ((name, grad), size) in got.into_iter().zip(sizes) {
        let grad = grad.expect("every input gets a gradient");
        assert_gradient(seed, name, &grad, &want[start..start + size]);
        start += size;
    }
}

#[test]
fn srgb_curves_invert_each_other_and_hit_known_values() {
    let seed = fresh_seed();
    let mut rng = Rng(seed);
    for (linear, encoded) in [
        (0.0, 0.0),
        (1.0, 1.0),
        (0.5, 0.735_356_983),
        (SRGB_LINEAR_KNEE, 0.040_449_936),
    ] {
        let got = linear_to_srgb_reference(linear);
        assert!(
            (got - encoded).abs() < 1e-9,
            "sRGB({linear}) = {got}, want {encoded}"
        );
        let back = srgb_to_linear_reference(encoded);
        assert!(
            (back - linear).abs() < 1e-9,
            "sRGB⁻¹({encoded}) = {back}, want {linear}"
        );
    }
    let (below, above) = (
        SRGB_LINEAR_KNEE * (1.0 - 1e-12),
        SRGB_LINEAR_KNEE * (1.0 + 1e-12),
    );
    let jump = linear_to_srgb_reference(above) - linear_to_srgb_reference(below);
    assert!(jump.abs() < 1e-6, "the curve jumps by {jump} at the knee");
    let (below, above) = (
        SRGB_ENCODED_KNEE * (1.0 - 1e-12),
        SRGB_ENCODED_KNEE * (1.0 + 1e-12),
    );
    let jump = srgb_to_linear_reference(above) - srgb_to_linear_reference(below);
    assert!(jump.abs() < 1e-6, "the inverse jumps by {jump} at the knee");

    let mut xs: Vec<f64> = vec![0.0, 1e-4, SRGB_LINEAR_KNEE, 0.5, 1.0];
    xs.extend((0..40).map(|_| f32_round(rng.range(-0.1, 1.5))));
    let device = Device::flex().autodiff();
    let x = tensor(&xs, [xs.len()], &device).require_grad();
    let encoded = linear_to_srgb(x.clone());
    let round_trip = values(srgb_to_linear(encoded.clone()));
    for ((&x0, &e), &r) in xs.iter().zip(&values(encoded.clone())).zip(&round_trip) {
        let want = linear_to_srgb_reference(x0);
        assert!(
            (f64::from(e) - want).abs() < 1e-5,
            "seed {seed}: sRGB({x0}) = {e}, want {want}"
        );
        let roundtrip_ref = srgb_to_linear_reference(want);
        assert!(
            (roundtrip_ref - x0).abs() < 1e-8,
            "seed {seed}: f64 round trip of {x0}"
        );
        assert!(
            (f64::from(r) - x0).abs() < 1e-5,
            "seed {seed}: round trip of {x0} gives {r}"
        );
    }
    let grads = encoded.sum().backward();
    let slope = values(x.grad(&grads).expect("x gets a gradient"));
    assert!(
        slope.iter().all(|v| v.is_finite()),
        "seed {seed}: d sRGB/dx = {slope:?}"
    );
    assert!(
        (slope[0] - 12.92).abs() < 1e-4,
        "d sRGB/dx at 0 = {}",
        slope[0]
    );
}
