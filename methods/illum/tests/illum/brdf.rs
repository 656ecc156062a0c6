//! The BRDF of Eq. 4–5: the Burn ops against the f64 reference (values and gradients), GGX's
//! normalisation, Fresnel at normal incidence, reciprocity, the white furnace (which fails
//! without Cook–Torrance's 4), and finite values and gradients at the extremes.

use std::f64::consts::PI;

use crate::{Rng, fresh_seed, values};
use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_illum::brdf::{
    DIELECTRIC_F0, MIN_ROUGHNESS, brdf_reference, diffuse, fresnel_reference, ndf_reference,
    specular,
};
use splatzoo_illum::sampling::tangent_frame_reference;

/// A tensor of `shape` from f64 values (stored as f32).
pub(crate) fn tensor<const D: usize>(v: &[f64], shape: [usize; D], device: &Device) -> Tensor<D> {
    let data: Vec<f32> = v.iter().map(|&x| x as f32).collect();
    Tensor::from_data(TensorData::new(data, shape), device)
}

/// `v` rounded to f32, so the f64 reference sees exactly what the Burn ops see.
pub(crate) fn f32_round(v: f64) -> f64 {
    v as f32 as f64
}

pub(crate) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub(crate) fn random_unit(rng: &mut Rng) -> [f64; 3] {
    loop {
        let v = [rng.gauss(), rng.gauss(), rng.gauss()];
        let length = dot(v, v).sqrt();
        if length > 1e-3 {
            return v.map(|x| x / length);
        }
    }
}

/// The unit vector at cosine `cos` to unit `n` and azimuth `phi` about it.
pub(crate) fn around(n: [f64; 3], cos: f64, phi: f64) -> [f64; 3] {
    let (t, b) = tangent_frame_reference(n);
    let sin = (1.0 - cos * cos).max(0.0).sqrt();
    std::array::from_fn(|k| sin * phi.cos() * t[k] + sin * phi.sin() * b[k] + cos * n[k])
}

/// Central differences of `f` at `p`, one per coordinate.
pub(crate) fn central_difference(f: impl Fn(&[f64]) -> f64, p: &[f64], step: f64) -> Vec<f64> {
    (0..p.len())
        .map(|i| {
            let mut q = p.to_vec();
            q[i] = p[i] + step;
            let up = f(&q);
            q[i] = p[i] - step;
            (up - f(&q)) / (2.0 * step)
        })
        .collect()
}

/// Autodiff gradients `got` against finite differences `want`, 1 % of each or 0.1 % of the
/// largest.
pub(crate) fn assert_gradient(seed: u64, name: &str, got: &[f32], want: &[f64]) {
    assert_eq!(got.len(), want.len(), "seed {seed}: {name} gradient size");
    let scale = want.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for (k, (&g, &w)) in got.iter().zip(want).enumerate() {
        let g = f64::from(g);
        assert!(
            (g - w).abs() <= 1e-2 * w.abs() + 1e-3 * scale + 1e-7,
            "seed {seed}: d/d{name}[{k}] autodiff {g} vs finite difference {w}"
        );
    }
}

const NORMALS: usize = 0;
const VIEWS: usize = 1;
const LIGHTS: usize = 2;
const ALBEDO: usize = 3;
const METALLIC: usize = 4;
const ROUGHNESS: usize = 5;

/// One small random case, `n` Gaussians with `s` directions each, all inputs f32-exact and
/// flattened into `p` in the order of the block indices above.
#[derive(Clone)]
struct Case {
    n: usize,
    s: usize,
    p: Vec<f64>,
}

impl Case {
    /// Views and lights at cosines in `[lo, hi]` to the normal; every third light below the
    /// horizon when `back_lights`.
    fn random(rng: &mut Rng, n: usize, s: usize, (lo, hi): (f64, f64), back_lights: bool) -> Self {
        let normals: Vec<[f64; 3]> = (0..n).map(|_| random_unit(rng)).collect();
        let mut side = |m: [f64; 3], back: bool| {
            let cos = rng.range(lo, hi);
            around(m, if back { -cos } else { cos }, rng.range(0.0, 2.0 * PI))
        };
        let views: Vec<[f64; 3]> = normals.iter().map(|&m| side(m, false)).collect();
        let lights: Vec<[f64; 3]> = (0..n * s)
            .map(|k| side(normals[k / s], back_lights && k % 3 == 2))
            .collect();
        let mut p: Vec<f64> = [normals, views, lights]
            .iter()
            .flatten()
            .flatten()
            .copied()
            .collect();
        p.extend((0..4 * n).map(|_| rng.range(0.05, 0.95))); // albedo, metallic
        p.extend((0..n).map(|_| rng.range(0.3, 0.95))); // roughness
        Self {
            n,
            s,
            p: p.into_iter().map(f32_round).collect(),
        }
    }

    /// The ranges of `p` holding each input.
    fn blocks(&self) -> [std::ops::Range<usize>; 6] {
        let (n, s) = (self.n, self.s);
        let mut start = 0;
        [3 * n, 3 * n, 3 * n * s, 3 * n, n, n].map(|size| {
            start += size;
            start - size..start
        })
    }

    /// Row `i` of a 3-vector block.
    fn row(&self, block: usize, i: usize) -> [f64; 3] {
        let start = self.blocks()[block].start + 3 * i;
        std::array::from_fn(|k| self.p[start + k])
    }

    fn scalar(&self, block: usize, i: usize) -> f64 {
        self.p[self.blocks()[block].start + i]
    }

    /// `(f_d, f_s)` of Gaussian `i` and its light `j`, in f64.
    fn reference(&self, i: usize, j: usize) -> ([f64; 3], [f64; 3]) {
        brdf_reference(
            self.row(NORMALS, i),
            self.row(VIEWS, i),
            self.row(LIGHTS, i * self.s + j),
            self.row(ALBEDO, i),
            self.scalar(METALLIC, i),
            self.scalar(ROUGHNESS, i),
        )
    }

    /// `Σ w_s·f_s + Σ w_d·f_d` in f64.
    fn reference_loss(&self, w_spec: &[f64], w_diff: &[f64]) -> f64 {
        let mut loss = 0.0;
        for i in 0..self.n {
            for j in 0..self.s {
                let (f_d, f_s) = self.reference(i, j);
                for ch in 0..3 {
                    loss += w_spec[(i * self.s + j) * 3 + ch] * f_s[ch];
                    if j == 0 {
                        loss += w_diff[i * 3 + ch] * f_d[ch];
                    }
                }
            }
        }
        loss
    }

    /// One input block as a tensor.
    fn input<const D: usize>(&self, block: usize, shape: [usize; D], device: &Device) -> Tensor<D> {
        tensor(&self.p[self.blocks()[block].clone()], shape, device)
    }
}

/// The Burn lobes `(f_s [N, S, 3], f_d [N, 3])` of a case.
fn burn_lobes(case: &Case, device: &Device) -> (Vec<f32>, Vec<f32>) {
    let (n, s) = (case.n, case.s);
    let (albedo, metallic) = (
        case.input(ALBEDO, [n, 3], device),
        case.input(METALLIC, [n, 1], device),
    );
    let f_s = specular(
        case.input(NORMALS, [n, 3], device),
        case.input(VIEWS, [n, 3], device),
        case.input(LIGHTS, [n, s, 3], device),
        albedo.clone(),
        metallic.clone(),
        case.input(ROUGHNESS, [n, 1], device),
    );
    (values(f_s), values(diffuse(albedo, metallic)))
}

#[test]
fn burn_lobes_match_the_f64_reference() {
    let seed = fresh_seed();
    let mut rng = Rng(seed);
    let case = Case::random(&mut rng, 6, 8, (0.05, 1.0), true);
    let (f_s, f_d) = burn_lobes(&case, &Device::flex());
    for i in 0..case.n {
        for j in 0..case.s {
            let (want_d, want_s) = case.reference(i, j);
            for ch in 0..3 {
                let (got, want) = (f64::from(f_s[3 * (i * case.s + j) + ch]), want_s[ch]);
                assert!(
                    (got - want).abs() <= 2e-4 * want.abs() + 1e-6,
                    "seed {seed}: f_s[{i}, {j}, {ch}] = {got}, reference {want}"
                );
                let (got, want) = (f64::from(f_d[3 * i + ch]), want_d[ch]);
                assert!(
                    (got - want).abs() <= 1e-6 * (1.0 + want.abs()),
                    "seed {seed}: f_d[{i}, {ch}] = {got}, reference {want}"
                );
            }
        }
    }
}

#[test]
fn ggx_distribution_is_normalised() {
    // ∫ D(h)(n·h) dω_h = 2π ∫₀^{π/2} D(cos θ) cos θ sin θ dθ, by Simpson's rule on a grid fine
    // enough for the narrowest lobe (α = 0.01 rad at r = 0.1).
    let steps = 1 << 16;
    let width = 0.5 * PI / steps as f64;
    for tenth in 1..=10 {
        let r = 0.1 * tenth as f64;
        let integral: f64 = (0..=steps)
            .map(|i| {
                let theta = i as f64 * width;
                let weight = if i == 0 || i == steps {
                    1.0
                } else {
                    [2.0, 4.0][i % 2]
                };
                weight * ndf_reference(theta.cos(), r) * theta.cos() * theta.sin()
            })
            .sum::<f64>()
            * width
            / 3.0
            * 2.0
            * PI;
        assert!(
            (integral - 1.0).abs() < 1e-3,
            "r = {r}: ∫D(n·h)dω = {integral}"
        );
    }
}

#[test]
fn fresnel_at_normal_incidence_is_f0() {
    let seed = fresh_seed();
    let mut rng = Rng(seed);
    for _ in 0..20 {
        let n = random_unit(&mut rng);
        let albedo: [f64; 3] = std::array::from_fn(|_| rng.range(0.0, 1.0));
        let (metallic, roughness) = (rng.range(0.0, 1.0), rng.range(MIN_ROUGHNESS, 1.0));
        // ω_o = ω_i = n: h = n, ω_o·h = 1 and G = 1, so f_s = D(1)·F/4.
        let (_, f_s) = brdf_reference(n, n, n, albedo, metallic, roughness);
        for (ch, &b) in albedo.iter().enumerate() {
            let f0 = DIELECTRIC_F0 * (1.0 - metallic) + b * metallic;
            let fresnel = 4.0 * f_s[ch] / ndf_reference(1.0, roughness);
            // The spherical-Gaussian fit leaves 2^−12.54 ≈ 1.7e-4 of (1 − F0) at c = 1.
            assert!(
                fresnel >= f0 - 1e-12 && fresnel - f0 <= 1.7e-4 * (1.0 - f0) + 1e-12,
                "seed {seed}: F(ω_o = n) = {fresnel}, F0 = {f0}"
            );
            let grazing = fresnel_reference(f0, 0.0);
            assert!(
                (grazing - 1.0).abs() < 1e-12,
                "seed {seed}: F(c = 0) = {grazing}"
            );
        }
    }
}

#[test]
fn specular_lobe_is_reciprocal() {
    let seed = fresh_seed();
    let mut rng = Rng(seed);
    let case = Case::random(&mut rng, 5, 1, (0.02, 1.0), false);
    let mut swapped = case.clone();
    let [_, views, lights, ..] = case.blocks();
    swapped.p[views.clone()].copy_from_slice(&case.p[lights.clone()]);
    swapped.p[lights].copy_from_slice(&case.p[views]);
    let (there, _) = burn_lobes(&case, &Device::flex());
    let (back, _) = burn_lobes(&swapped, &Device::flex());
    for i in 0..case.n {
        let ((_, forward), (_, reverse)) = (case.reference(i, 0), swapped.reference(i, 0));
        for ch in 0..3 {
            assert!(
                (forward[ch] - reverse[ch]).abs() <= 1e-6 * forward[ch].abs(),
                "seed {seed}: f64 f_s(o, i) = {} vs f_s(i, o) = {}",
                forward[ch],
                reverse[ch]
            );
            let (a, b) = (there[3 * i + ch], back[3 * i + ch]);
            assert!(
                (a - b).abs() <= 1e-5 * a.abs() + 1e-7,
                "seed {seed}: Burn f_s(o, i) = {a} vs f_s(i, o) = {b}"
            );
        }
    }
}

/// The directional albedo `∫ f_s(ω_o, ω_i)(n·ω_i) dω_i` of the white specular lobe (m = 1,
/// b = 1, so F0 = F = 1) with ω_o at `theta_o` from `n = +z`, on a `steps²` midpoint grid in
/// GGX's own coordinates: `tan²θ_h = α² u/(1 − u)` makes `D(h)(n·h) dω_h = du dφ/2π`, and
/// `dω_i = 4(ω_o·h) dω_h`, so each cell weighs `f_s (n·ω_i)·4(ω_o·h)/(D(h)(n·h))`.
fn directional_albedo(roughness: f64, theta_o: f64, steps: usize) -> f64 {
    let n = [0.0, 0.0, 1.0];
    let wo = [theta_o.sin(), 0.0, theta_o.cos()];
    let alpha2 = roughness.max(MIN_ROUGHNESS).powi(4);
    let mut sum = 0.0;
    for a in 0..steps {
        let u = (a as f64 + 0.5) / steps as f64;
        let cos_h = 1.0 / (1.0 + alpha2 * u / (1.0 - u)).sqrt();
        for b in 0..steps {
            let h = around(n, cos_h, 2.0 * PI * (b as f64 + 0.5) / steps as f64);
            let o_h = dot(wo, h);
            let wi: [f64; 3] = std::array::from_fn(|k| 2.0 * o_h * h[k] - wo[k]);
            if o_h <= 0.0 || wi[2] <= 0.0 {
                continue; // ω_i below the surface: outside the hemisphere
            }
            let (_, f_s) = brdf_reference(n, wo, wi, [1.0; 3], 1.0, roughness);
            sum += f_s[0] * wi[2] * 4.0 * o_h / (ndf_reference(cos_h, roughness) * cos_h);
        }
    }
    sum / (steps * steps) as f64
}

/// [`directional_albedo`] on a plain (θ_i, φ_i) midpoint grid, to check its change of variables
/// where the lobe is wide enough for this grid.
fn directional_albedo_direct(roughness: f64, theta_o: f64, steps: usize) -> f64 {
    let n = [0.0, 0.0, 1.0];
    let wo = [theta_o.sin(), 0.0, theta_o.cos()];
    let (d_theta, d_phi) = (0.5 * PI / steps as f64, PI / steps as f64);
    let mut sum = 0.0;
    for a in 0..steps {
        let theta = (a as f64 + 0.5) * d_theta;
        for b in 0..2 * steps {
            let wi = around(n, theta.cos(), (b as f64 + 0.5) * d_phi);
            let (_, f_s) = brdf_reference(n, wo, wi, [1.0; 3], 1.0, roughness);
            sum += f_s[0] * theta.cos() * theta.sin();
        }
    }
    sum * d_theta * d_phi
}

#[test]
fn white_furnace_needs_the_factor_four() {
    let mut largest = 0.0f64;
    let roughness = std::iter::once(MIN_ROUGHNESS).chain((1..=10).map(|t| 0.1 * t as f64));
    for r in roughness {
        for theta_o in [0.0, 0.5, 1.0, 1.4, 1.55] {
            let albedo = directional_albedo(r, theta_o, 200);
            assert!(
                albedo <= 1.0 + 2e-3,
                "r = {r}, θ_o = {theta_o}: the white lobe reflects {albedo} of the light"
            );
            largest = largest.max(albedo);
        }
    }
    // Eq. 5 as printed (no 4) is 4× this lobe: it would reflect more than it receives.
    assert!(
        4.0 * largest > 1.5,
        "without the 4 the largest albedo would be {}",
        4.0 * largest
    );
    for r in [0.5, 1.0] {
        let (mapped, direct) = (
            directional_albedo(r, 0.7, 200),
            directional_albedo_direct(r, 0.7, 200),
        );
        assert!(
            (mapped - direct).abs() < 1e-3,
            "r = {r}: the two quadratures disagree, {mapped} vs {direct}"
        );
    }
}

#[test]
fn gradients_match_finite_differences() {
    let seed = fresh_seed();
    let mut rng = Rng(seed);
    let case = Case::random(&mut rng, 2, 3, (0.2, 0.9), false);
    let (n, s) = (case.n, case.s);
    let w_spec: Vec<f64> = (0..n * s * 3).map(|_| f32_round(rng.gauss())).collect();
    let w_diff: Vec<f64> = (0..n * 3).map(|_| f32_round(rng.gauss())).collect();
    let at = |q: &[f64]| {
        Case {
            p: q.to_vec(),
            ..case.clone()
        }
        .reference_loss(&w_spec, &w_diff)
    };
    let want = central_difference(at, &case.p, 1e-6);

    let device = Device::flex().autodiff();
    let leaf = |block: usize, width: usize| case.input(block, [n, width], &device).require_grad();
    let leaves = [
        ("normals", NORMALS, leaf(NORMALS, 3)),
        ("view", VIEWS, leaf(VIEWS, 3)),
        ("albedo", ALBEDO, leaf(ALBEDO, 3)),
        ("metallic", METALLIC, leaf(METALLIC, 1)),
        ("roughness", ROUGHNESS, leaf(ROUGHNESS, 1)),
    ];
    let light = case.input(LIGHTS, [n, s, 3], &device).require_grad();
    let input = |k: usize| leaves[k].2.clone();
    let lobe = specular(
        input(0),
        input(1),
        light.clone(),
        input(2),
        input(3),
        input(4),
    );
    let loss = (lobe * tensor(&w_spec, [n, s, 3], &device)).sum()
        + (diffuse(input(2), input(3)) * tensor(&w_diff, [n, 3], &device)).sum();
    let grads = loss.backward();
    let blocks = case.blocks();
    for (name, block, leaf) in leaves {
        let got = values(leaf.grad(&grads).expect("every input gets a gradient"));
        assert_gradient(seed, name, &got, &want[blocks[block].clone()]);
    }
    let got = values(light.grad(&grads).expect("the light gets a gradient"));
    assert_gradient(seed, "light", &got, &want[blocks[LIGHTS].clone()]);
}

#[test]
fn extremes_stay_finite() {
    let n = [0.0, 0.0, 1.0];
    let tilted = around(n, 0.6, 2.0);
    let below = around(n, -0.5, 1.0);
    let grazing = [1.0, 0.0, 0.0];
    let skimming = [1.0, 0.0, 1e-7];
    let opposite = tilted.map(|v| -v);
    let pairs = [
        (grazing, tilted),
        (tilted, grazing),
        (skimming, [-1.0, 0.0, 1e-7]),
        (below, tilted),
        (tilted, below),
        (below, below),
        (tilted, opposite), // h = 0
        (n, n),
    ];
    let rows = pairs.len();
    type Pair = ([f64; 3], [f64; 3]);
    let flat = |pick: fn(&Pair) -> [f64; 3]| -> Vec<f64> { pairs.iter().flat_map(pick).collect() };
    let device = Device::flex().autodiff();
    for r in [0.0, MIN_ROUGHNESS, 1.0] {
        let normals = tensor(&n.repeat(rows), [rows, 3], &device).require_grad();
        let view = tensor(&flat(|p| p.0), [rows, 3], &device).require_grad();
        let light = tensor(&flat(|p| p.1), [rows, 1, 3], &device).require_grad();
        let albedo = tensor(&vec![0.5; 3 * rows], [rows, 3], &device).require_grad();
        let metallic = tensor(&vec![0.5; rows], [rows, 1], &device).require_grad();
        let roughness = tensor(&vec![r; rows], [rows, 1], &device).require_grad();
        let lobe = specular(
            normals.clone(),
            view.clone(),
            light.clone(),
            albedo.clone(),
            metallic.clone(),
            roughness.clone(),
        );
        let got = values(lobe.clone());
        assert!(got.iter().all(|v| v.is_finite()), "r = {r}: f_s = {got:?}");
        let grads = (lobe.sum() + diffuse(albedo.clone(), metallic.clone()).sum()).backward();
        let gradients = [
            ("n", normals.grad(&grads).map(values)),
            ("ω_o", view.grad(&grads).map(values)),
            ("ω_i", light.grad(&grads).map(values)),
            ("b", albedo.grad(&grads).map(values)),
            ("m", metallic.grad(&grads).map(values)),
            ("r", roughness.grad(&grads).map(values)),
        ];
        for (name, grad) in gradients {
            let g = grad.expect("every input gets a gradient");
            assert!(
                g.iter().all(|v| v.is_finite()),
                "r = {r}: d/d{name} = {g:?}"
            );
        }
        for &(wo, wi) in &pairs {
            let (f_d, f_s) = brdf_reference(n, wo, wi, [0.5; 3], 0.5, r);
            assert!(
                f_d.iter().chain(&f_s).all(|v| v.is_finite()),
                "r = {r}, ω_o = {wo:?}, ω_i = {wi:?}: reference {f_d:?} {f_s:?}"
            );
        }
    }
}
