//! Fibonacci hemisphere sampling (Eq. 6): unit directions on the normal's hemisphere at the
//! rule's cosines, a right-handed frame that stays stable at n = ±z, the midpoint rule's mean
//! cosine ½ and R3DG's floor at sin 10°, the azimuth offset as a pure rotation about n, and the
//! Burn ops against the f64 reference (values, and finite gradients at the poles).

use std::f64::consts::PI;

use crate::brdf::{dot, f32_round, random_unit, tensor};
use crate::{Rng, fresh_seed, values};
use burn::tensor::Device;
use splatzoo_illum::sampling::{
    GOLDEN_ANGLE, HemisphereRule, fibonacci_hemisphere, fibonacci_hemisphere_reference,
    local_directions, solid_angle_weight, tangent_frame_reference,
};

const RULES: [HemisphereRule; 2] = [HemisphereRule::Midpoint, HemisphereRule::R3dg];

/// ±z exactly, normals a hair off −z (the classic frame's singularity), then random ones.
fn test_normals(rng: &mut Rng, random: usize) -> Vec<[f64; 3]> {
    let mut normals = vec![[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]];
    for tiny in [1e-7f64, -3e-5] {
        let length = (1.0 + 2.0 * tiny * tiny).sqrt();
        normals.push([tiny, -tiny, -1.0].map(|v| v / length));
    }
    normals.extend((0..random).map(|_| random_unit(rng)));
    normals
}

fn rotate_about(v: [f64; 3], axis: [f64; 3], angle: f64) -> [f64; 3] {
    // Rodrigues: v cos θ + (k × v) sin θ + k (k·v)(1 − cos θ).
    let cross = [
        axis[1] * v[2] - axis[2] * v[1],
        axis[2] * v[0] - axis[0] * v[2],
        axis[0] * v[1] - axis[1] * v[0],
    ];
    let along = dot(axis, v) * (1.0 - angle.cos());
    std::array::from_fn(|k| v[k] * angle.cos() + cross[k] * angle.sin() + axis[k] * along)
}

#[test]
fn directions_are_unit_and_on_the_normals_hemisphere() {
    let seed = fresh_seed();
    let mut rng = Rng(seed);
    assert!((GOLDEN_ANGLE - PI * (3.0 - 5f64.sqrt())).abs() < 1e-14);
    for n in test_normals(&mut rng, 20) {
        let (t, b) = tangent_frame_reference(n);
        let cross = [
            t[1] * b[2] - t[2] * b[1],
            t[2] * b[0] - t[0] * b[2],
            t[0] * b[1] - t[1] * b[0],
        ];
        for (what, got, want) in [
            ("t·t", dot(t, t), 1.0),
            ("b·b", dot(b, b), 1.0),
            ("t·b", dot(t, b), 0.0),
            ("t·n", dot(t, n), 0.0),
            ("b·n", dot(b, n), 0.0),
            ("(t × b)·n", dot(cross, n), 1.0),
        ] {
            assert!(
                (got - want).abs() < 1e-12,
                "seed {seed}: n = {n:?}: {what} = {got}"
            );
        }
        let count = 1 + (rng.next_u64() % 200) as usize;
        let offset = rng.range(0.0, 2.0 * PI);
        for rule in RULES {
            let directions = fibonacci_hemisphere_reference(n, count, rule, offset);
            assert_eq!(directions.len(), count);
            for (j, d) in directions.iter().enumerate() {
                let (length, cos) = (dot(*d, *d).sqrt(), dot(*d, n));
                assert!(
                    (length - 1.0).abs() < 1e-12,
                    "seed {seed}: |ω_{j}| = {length}"
                );
                let want = rule.cos_theta(j, count);
                assert!(
                    want > 0.0 && (cos - want).abs() < 1e-12,
                    "seed {seed}: {rule:?} n·ω_{j} = {cos}, z_j = {want}"
                );
            }
        }
    }
}

#[test]
fn midpoint_rule_has_mean_cosine_one_half() {
    let seed = fresh_seed();
    let mut rng = Rng(seed);
    for count in [1, 2, 7, 64, 1 + (rng.next_u64() % 5000) as usize] {
        let z: Vec<f64> = local_directions(count, HemisphereRule::Midpoint, 0.0)
            .iter()
            .map(|d| d[2])
            .collect();
        let mean = z.iter().sum::<f64>() / count as f64;
        assert!((mean - 0.5).abs() < 1e-12, "N = {count}: mean z = {mean}");
        assert!(
            z.windows(2).all(|w| w[0] > w[1]),
            "N = {count}: z not decreasing"
        );
        // A constant light's Eq. 7 sum: Σ z_j Δω/π = 2·mean z = 1.
        let constant = z.iter().sum::<f64>() * solid_angle_weight(count) / PI;
        assert!((constant - 1.0).abs() < 1e-12, "N = {count}: {constant}");
    }
}

#[test]
fn r3dg_rule_stays_above_ten_degrees() {
    let floor = 10f64.to_radians().sin();
    for count in [1, 6, 32, 64, 1024, 4096] {
        let z: Vec<f64> = (0..count)
            .map(|j| HemisphereRule::R3dg.cos_theta(j, count))
            .collect();
        assert_eq!(z[0], 1.0, "N = {count}: R3DG starts at the pole");
        assert!(
            z.iter().all(|&v| v >= floor - 1e-15),
            "N = {count}: a sample below 10°"
        );
        if count >= 6 {
            assert_eq!(
                *z.last().unwrap(),
                floor,
                "N = {count}: the floor is reached"
            );
        }
    }
    // The clamp's bias on a constant light: 2·mean z → 1 + sin²10° ≈ 1.0302.
    let z = local_directions(4096, HemisphereRule::R3dg, 0.0);
    let bias = 2.0 * z.iter().map(|d| d[2]).sum::<f64>() / 4096.0;
    assert!((bias - (1.0 + floor * floor)).abs() < 2e-4, "bias {bias}");
}

/// Burn directions `[N, count, 3]` of f32-exact normals and offsets, as f64 rows.
fn burn_directions(
    normals: &[[f64; 3]],
    offsets: Option<&[f64]>,
    count: usize,
    rule: HemisphereRule,
) -> Vec<[f64; 3]> {
    let device = Device::flex();
    let n = normals.len();
    let flat: Vec<f64> = normals.iter().flatten().copied().collect();
    let offsets = offsets.map(|u| tensor(u, [n], &device));
    let out = fibonacci_hemisphere(tensor(&flat, [n, 3], &device), count, rule, offsets);
    assert_eq!(out.dims(), [n, count, 3]);
    values(out)
        .chunks(3)
        .map(|c| [c[0], c[1], c[2]].map(f64::from))
        .collect()
}

#[test]
fn azimuth_offset_only_rotates_about_the_normal() {
    let seed = fresh_seed();
    let mut rng = Rng(seed);
    let normals: Vec<[f64; 3]> = test_normals(&mut rng, 12)
        .into_iter()
        .map(|n| n.map(f32_round))
        .collect();
    let offsets: Vec<f64> = normals
        .iter()
        .map(|_| f32_round(rng.range(0.0, 2.0 * PI)))
        .collect();
    let count = 1 + (rng.next_u64() % 96) as usize;
    for rule in RULES {
        let plain = burn_directions(&normals, None, count, rule);
        let turned = burn_directions(&normals, Some(&offsets[..]), count, rule);
        for (i, (&n, &u)) in normals.iter().zip(&offsets).enumerate() {
            let n = n.map(|v| v / dot(n, n).sqrt());
            for j in 0..count {
                let (a, b) = (plain[i * count + j], turned[i * count + j]);
                let (za, zb) = (dot(a, n), dot(b, n));
                assert!(
                    (za - zb).abs() < 1e-5,
                    "seed {seed}: {rule:?} n·ω_{j} moved from {za} to {zb}"
                );
                // φ → φ + u turns (ρ sin φ, ρ cos φ) from b towards t: −u about n = t × b.
                let want = rotate_about(a, n, -u);
                let gap = (0..3).map(|k| (want[k] - b[k]).abs()).fold(0.0, f64::max);
                assert!(
                    gap < 2e-5,
                    "seed {seed}: {rule:?} ω_{j} off the rotation by {gap}"
                );
            }
        }
    }
}

#[test]
fn burn_sampling_matches_the_f64_reference() {
    let seed = fresh_seed();
    let mut rng = Rng(seed);
    // Unnormalised inputs: the op normalises them.
    let normals: Vec<[f64; 3]> = test_normals(&mut rng, 12)
        .into_iter()
        .map(|n| n.map(|v| f32_round(v * 3.0)))
        .collect();
    let offsets: Vec<f64> = normals
        .iter()
        .map(|_| f32_round(rng.range(0.0, 2.0 * PI)))
        .collect();
    for (count, rule) in [
        (1 + (rng.next_u64() % 64) as usize, HemisphereRule::Midpoint),
        (1024, HemisphereRule::Midpoint),
        (1 + (rng.next_u64() % 64) as usize, HemisphereRule::R3dg),
    ] {
        let got = burn_directions(&normals, Some(&offsets[..]), count, rule);
        for (i, (&n, &u)) in normals.iter().zip(&offsets).enumerate() {
            let want = fibonacci_hemisphere_reference(n, count, rule, u);
            for (j, w) in want.iter().enumerate() {
                let g = got[i * count + j];
                let gap = (0..3).map(|k| (g[k] - w[k]).abs()).fold(0.0, f64::max);
                assert!(
                    gap < 1e-5,
                    "seed {seed}: {rule:?} N = {count}, normal {i}, sample {j}: off by {gap}"
                );
            }
        }
    }
}

#[test]
fn gradients_are_finite_at_the_poles() {
    let seed = fresh_seed();
    let mut rng = Rng(seed);
    let device = Device::flex().autodiff();
    let normals: Vec<f64> = test_normals(&mut rng, 2).into_iter().flatten().collect();
    let n = normals.len() / 3;
    let offsets: Vec<f64> = (0..n).map(|_| rng.range(0.0, 2.0 * PI)).collect();
    let normals = tensor(&normals, [n, 3], &device).require_grad();
    let offsets = tensor(&offsets, [n], &device).require_grad();
    let count = 16;
    let weights: Vec<f64> = (0..n * count * 3).map(|_| rng.gauss()).collect();
    let directions = fibonacci_hemisphere(
        normals.clone(),
        count,
        HemisphereRule::Midpoint,
        Some(offsets.clone()),
    );
    let grads = (directions * tensor(&weights, [n, count, 3], &device))
        .sum()
        .backward();
    for (name, grad) in [
        ("normals", normals.grad(&grads).map(values)),
        ("offsets", offsets.grad(&grads).map(values)),
    ] {
        let grad = grad.expect("the input gets a gradient");
        assert!(
            grad.iter().all(|v| v.is_finite()),
            "seed {seed}: d/d{name} = {grad:?}"
        );
    }
}
