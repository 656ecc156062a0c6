//! Eq. 6's light volume (spec §8 check 1): interpolating coefficients equals interpolating
//! radiance; weights sum to 1; a probe reads itself; C⁰ across cell faces; clamping outside;
//! the f64 reference; one-probe and flat grids; the unit-radiance init; gradients reach exactly
//! the 8 corner probes. Eq. 13's probe smoothness by hand and against its reference (check 9),
//! the shared environment split off the probes, and the grid's bad inputs.

use crate::{Rng, fresh_seed, values};
use burn::module::Param;
use burn::tensor::{Device, Int, Tensor, TensorData};
use splatzoo_illum::IllumError;
use splatzoo_illum::light_volume::{
    LATENT_INIT_STD, LightVolume, ProbeGrid, UNIT_RADIANCE_DC, interpolate_reference,
    probe_smoothness_reference,
};
use splatzoo_rasterizer::sh::{coeff_count, sh_basis};

/// A fresh seed, its generator and the CPU device.
fn start() -> (u64, Rng, Device) {
    let seed = fresh_seed();
    (seed, Rng(seed), Device::flex())
}

fn tensor2(v: &[f64], shape: [usize; 2], device: &Device) -> Tensor<2> {
    let data: Vec<f32> = v.iter().map(|&x| x as f32).collect();
    Tensor::from_data(TensorData::new(data, shape), device)
}

fn ints(t: Tensor<2, Int>) -> Vec<i64> {
    t.into_data()
        .convert::<i64>()
        .try_into_vec::<i64>()
        .expect("i64 data")
}

/// A grid with dyadic origin and spacing (exact in f32) and 1–4 probes per axis, at least
/// `min_dims` on each.
fn random_grid(rng: &mut Rng, min_dims: usize) -> ProbeGrid {
    ProbeGrid {
        origin: [0; 3].map(|_| rng.range(-8.0, 8.0).round() / 4.0),
        spacing: [0.5, 1.0][(rng.next_u64() % 2) as usize],
        dims: [0; 3].map(|_| min_dims + (rng.next_u64() % (5 - min_dims as u64)) as usize),
    }
}

/// Values rounded to f32, as f64, so references see exactly what the tensors hold.
fn gauss(rng: &mut Rng, count: usize) -> Vec<f64> {
    (0..count).map(|_| rng.gauss() as f32 as f64).collect()
}

/// A volume with random coefficients and latents, returned beside their host values.
fn random_volume(
    grid: ProbeGrid,
    degree: u32,
    latent_dim: usize,
    rng: &mut Rng,
    device: &Device,
) -> (LightVolume, Vec<f64>, Vec<f64>) {
    let mut volume =
        LightVolume::new(grid, degree, latent_dim, rng.next_u64(), device).expect("a valid volume");
    let (p, k) = (grid.count(), coeff_count(degree));
    let sh = gauss(rng, p * k * 3);
    let latent = gauss(rng, p * latent_dim);
    let sh32: Vec<f32> = sh.iter().map(|&v| v as f32).collect();
    volume.sh = Param::from_tensor(Tensor::from_data(TensorData::new(sh32, [p, k, 3]), device));
    volume.latent = Param::from_tensor(tensor2(&latent, [p, latent_dim], device));
    (volume, sh, latent)
}

/// `n` points within one spacing of the grid (some outside it), flat `[n, 3]`.
fn random_points(grid: &ProbeGrid, n: usize, rng: &mut Rng) -> Vec<f64> {
    (0..n * 3)
        .map(|i| {
            let a = i % 3;
            let lo = grid.origin[a] - grid.spacing;
            let hi = grid.origin[a] + grid.dims[a] as f64 * grid.spacing;
            rng.range(lo, hi)
        })
        .collect()
}

fn wide(v: &[f32]) -> Vec<f64> {
    v.iter().map(|&x| f64::from(x)).collect()
}

/// Asserts `got ≈ want` element-wise, relative to `1 + |want|`.
fn assert_close(got: &[f32], want: &[f64], tol: f64, seed: u64) {
    assert_eq!(got.len(), want.len(), "seed {seed}");
    for (i, (g, w)) in wide(got).iter().zip(want).enumerate() {
        let ok = (g - w).abs() <= tol * (1.0 + w.abs());
        assert!(ok, "seed {seed}: element {i}: {g} vs {w}");
    }
}

/// Blending the coefficients and evaluating once (what `interpolate` does) equals Eq. 6
/// literally: every corner probe's radiance at the direction, blended by `Σ w L / Σ w`.
#[test]
fn interpolating_coefficients_equals_interpolating_radiance() {
    let (seed, mut rng, device) = start();
    let grid = random_grid(&mut rng, 1);
    let degree = 2;
    let k = coeff_count(degree);
    let (volume, sh, _) = random_volume(grid, degree, 4, &mut rng, &device);
    let n = 64;
    let points = tensor2(&random_points(&grid, n, &mut rng), [n, 3], &device);
    let directions: Vec<f64> = (0..n * 3).map(|_| rng.gauss()).collect();
    let basis = sh_basis(degree, tensor2(&directions, [n, 3], &device));
    let (blended, _) = volume.interpolate(points.clone());
    let radiance = values((blended * basis.clone().reshape([n, k, 1])).sum_dim(1));
    let basis = values(basis);
    let (indices, weights) = grid.corner_weights(points);
    let (indices, weights) = (ints(indices), values(weights));
    // Probe `q`'s radiance in channel `c` along point `i`'s direction.
    let radiance_of = |q: usize, i: usize, c: usize| -> f64 {
        (0..k)
            .map(|j| sh[(q * k + j) * 3 + c] * f64::from(basis[i * k + j]))
            .sum()
    };
    let w = |slot: usize| f64::from(weights[slot]);
    let want: Vec<f64> = (0..n * 3)
        .map(|ic| {
            let (i, c) = (ic / 3, ic % 3);
            let slots = i * 8..(i + 1) * 8;
            let sum: f64 = slots
                .clone()
                .map(|s| w(s) * radiance_of(indices[s] as usize, i, c))
                .sum();
            sum / slots.map(w).sum::<f64>()
        })
        .collect();
    assert_close(&radiance, &want, 1e-5, seed);
}

/// Weights are ≥ 0 and sum to 1, indices are probes (also for NaN and far-away queries), and
/// a query at a probe returns that probe's coefficients and latent exactly.
#[test]
fn weights_sum_to_one_and_probes_read_themselves() {
    let (seed, mut rng, device) = start();
    let grid = random_grid(&mut rng, 1);
    let p = grid.count();
    let mut points = random_points(&grid, 40, &mut rng);
    points.extend([f64::NAN, 0.0, 0.0, 1e30, -1e30, 0.5]);
    let n = points.len() / 3;
    let (indices, weights) = grid.corner_weights(tensor2(&points, [n, 3], &device));
    let (indices, weights) = (ints(indices), values(weights));
    let sums: Vec<f32> = weights
        .chunks_exact(8)
        .map(|row| row.iter().sum())
        .collect();
    assert_close(&sums, &vec![1.0; n], 1e-6, seed);
    assert!(
        weights.iter().all(|&w| w >= 0.0),
        "seed {seed}: {weights:?}"
    );
    assert!(indices.iter().all(|&j| (0..p as i64).contains(&j)));
    let (volume, _, _) = random_volume(grid, 1, 3, &mut rng, &device);
    let at: Vec<f64> = (0..p).flat_map(|i| grid.position(i)).collect();
    let (sh, latent) = volume.interpolate(tensor2(&at, [p, 3], &device));
    assert_eq!(values(sh), values(volume.sh.val()), "seed {seed}");
    assert_eq!(values(latent), values(volume.latent.val()), "seed {seed}");
}

/// Values just below and just above an interior cell face (different cells) agree.
#[test]
fn interpolation_is_continuous_across_cell_faces() {
    let (seed, mut rng, device) = start();
    let grid = random_grid(&mut rng, 3);
    let (volume, _, _) = random_volume(grid, 2, 4, &mut rng, &device);
    for axis in 0..3 {
        let face = 1 + (rng.next_u64() % (grid.dims[axis] as u64 - 2)) as usize;
        let mut point = random_points(&grid, 1, &mut rng);
        point[axis] = grid.origin[axis] + face as f64 * grid.spacing;
        let mut both = point.clone();
        both[axis] -= 1e-6;
        point[axis] += 1e-6;
        both.extend(point);
        let points = tensor2(&both, [2, 3], &device);
        let corners = ints(grid.corner_weights(points.clone()).0);
        assert_ne!(corners[..8], corners[8..], "seed {seed}: both in one cell");
        let (sh, latent) = volume.interpolate(points);
        for v in [values(sh), values(latent)] {
            let half = v.len() / 2;
            assert_close(&v[..half], &wide(&v[half..]), 2e-4, seed);
        }
    }
}

/// A query outside the grid reads the same as the nearest boundary point.
#[test]
fn queries_outside_are_clamped_to_the_boundary() {
    let (seed, mut rng, device) = start();
    let grid = random_grid(&mut rng, 1);
    let (volume, _, _) = random_volume(grid, 1, 2, &mut rng, &device);
    let n = 30;
    let outside: Vec<f64> = (0..n * 3)
        .map(|i| {
            let a = i % 3;
            let far = grid.origin[a] + grid.dims[a] as f64 * grid.spacing + rng.range(0.0, 5.0);
            match rng.next_u64() % 3 {
                0 => grid.origin[a] - rng.range(0.01, 5.0),
                1 => far,
                _ => rng.range(grid.origin[a], grid.position(grid.count() - 1)[a]),
            }
        })
        .collect();
    let hi = grid.position(grid.count() - 1);
    let nearest: Vec<f64> = outside
        .iter()
        .enumerate()
        .map(|(i, &v)| v.clamp(grid.origin[i % 3], hi[i % 3]))
        .collect();
    let (a_sh, a_z) = volume.interpolate(tensor2(&outside, [n, 3], &device));
    let (b_sh, b_z) = volume.interpolate(tensor2(&nearest, [n, 3], &device));
    assert_close(&values(a_sh), &wide(&values(b_sh)), 1e-6, seed);
    assert_close(&values(a_z), &wide(&values(b_z)), 1e-6, seed);
}

/// Burn's interpolation equals the tent-function f64 reference, flat axes included.
#[test]
fn interpolation_matches_the_f64_reference() {
    let (seed, mut rng, device) = start();
    for _ in 0..4 {
        let grid = random_grid(&mut rng, 1);
        let (volume, sh, latent) = random_volume(grid, 2, 5, &mut rng, &device);
        let n = 25;
        let points = random_points(&grid, n, &mut rng);
        let (got_sh, got_z) = volume.interpolate(tensor2(&points, [n, 3], &device));
        let want = |probe_values: &[f64]| -> Vec<f64> {
            points
                .chunks_exact(3)
                .flat_map(|p| interpolate_reference(&grid, probe_values, [p[0], p[1], p[2]]))
                .collect()
        };
        assert_close(&values(got_sh), &want(&sh), 1e-5, seed);
        assert_close(&values(got_z), &want(&latent), 1e-5, seed);
    }
}

/// A one-probe grid returns its probe everywhere, near and far.
#[test]
fn a_one_probe_grid_returns_its_probe_everywhere() {
    let (seed, mut rng, device) = start();
    let grid = ProbeGrid {
        origin: [0; 3].map(|_| rng.range(-3.0, 3.0)),
        spacing: rng.range(0.1, 2.0),
        dims: [1, 1, 1],
    };
    let (volume, sh, latent) = random_volume(grid, 3, 4, &mut rng, &device);
    let mut points: Vec<f64> = (0..60).map(|_| rng.range(-10.0, 10.0)).collect();
    points.extend([1e6, -1e6, 3e5]);
    let n = points.len() / 3;
    let (got_sh, got_z) = volume.interpolate(tensor2(&points, [n, 3], &device));
    assert_eq!(wide(&values(got_sh)), sh.repeat(n), "seed {seed}");
    assert_eq!(wide(&values(got_z)), latent.repeat(n), "seed {seed}");
}

/// The initial volume radiates exactly 1 in every direction, at every point, for every degree;
/// latents are N(0, 0.01²), fixed by the seed.
#[test]
fn the_initial_radiance_is_one_in_every_direction() {
    let (seed, mut rng, device) = start();
    let grid = ProbeGrid {
        origin: [-1.0, 0.0, -1.0],
        spacing: 0.5,
        dims: [5, 4, 5],
    };
    for degree in 0..=3 {
        let volume = LightVolume::new(grid, degree, 16, seed, &device).expect("a volume");
        assert_eq!(volume.degree(), degree);
        let n = 50;
        let k = coeff_count(degree);
        let points = tensor2(&random_points(&grid, n, &mut rng), [n, 3], &device);
        let (sh, _) = volume.interpolate(points);
        let directions: Vec<f64> = (0..n * 3).map(|_| rng.gauss()).collect();
        let basis = sh_basis(degree, tensor2(&directions, [n, 3], &device));
        let radiance = values((sh * basis.reshape([n, k, 1])).sum_dim(1));
        assert_close(&radiance, &vec![1.0; n * 3], 1e-6, seed);
    }
    let volume = LightVolume::new(grid, 2, 16, seed, &device).expect("a volume");
    let latent = values(volume.latent.val());
    let count = latent.len() as f64;
    let mean = wide(&latent).iter().sum::<f64>() / count;
    let std = (wide(&latent)
        .iter()
        .map(|v| (v - mean).powi(2))
        .sum::<f64>()
        / count)
        .sqrt();
    assert!(mean.abs() < 1e-3, "seed {seed}: mean {mean}");
    assert!(
        (std / LATENT_INIT_STD - 1.0).abs() < 0.1,
        "seed {seed}: std {std}"
    );
    let again = LightVolume::new(grid, 2, 16, seed, &device).expect("a volume");
    assert_eq!(values(again.latent.val()), latent, "seed {seed}");
    let other = LightVolume::new(grid, 2, 16, seed ^ 1, &device).expect("a volume");
    assert_ne!(values(other.latent.val()), latent, "seed {seed}");
}

/// A loss on one point's interpolated coefficients and latent reaches exactly its cell's 8
/// corner probes, each with `w_c ×` the upstream gradient; every other probe gets zero.
#[test]
fn gradients_reach_exactly_the_eight_corner_probes() {
    let seed = fresh_seed();
    let mut rng = Rng(seed);
    let device = Device::flex().autodiff();
    let grid = random_grid(&mut rng, 2);
    let (p, k, dz) = (grid.count(), coeff_count(1), 3);
    let volume = LightVolume::new(grid, 1, dz, seed, &device).expect("a volume");
    // A point strictly inside a random cell, so all eight weights are non-zero.
    let cell = [0, 1, 2].map(|a| (rng.next_u64() % (grid.dims[a] as u64 - 1)) as usize);
    let t = [0; 3].map(|_| rng.range(0.1, 0.9));
    let point: Vec<f64> = (0..3)
        .map(|a| grid.origin[a] + (cell[a] as f64 + t[a]) * grid.spacing)
        .collect();
    let upstream_sh = gauss(&mut rng, k * 3);
    let upstream_z = gauss(&mut rng, dz);
    let (sh, latent) = volume.interpolate(tensor2(&point, [1, 3], &device));
    let loss = (sh * tensor2(&upstream_sh, [1, k * 3], &device).reshape([1, k, 3])).sum()
        + (latent * tensor2(&upstream_z, [1, dz], &device)).sum();
    let grads = loss.backward();
    let g_sh = values(volume.sh.val().grad(&grads).expect("sh is reached"));
    let g_z = values(
        volume
            .latent
            .val()
            .grad(&grads)
            .expect("latents are reached"),
    );
    let mut want_weight = vec![0.0; p];
    for c in 0..8 {
        let corner = [0, 1, 2].map(|a| cell[a] + ((c >> a) & 1));
        let w: f64 = (0..3)
            .map(|a| if (c >> a) & 1 == 1 { t[a] } else { 1.0 - t[a] })
            .product();
        want_weight[grid.index(corner)] += w;
    }
    for (g, up) in [(&g_sh, &upstream_sh), (&g_z, &upstream_z)] {
        let want: Vec<f64> = want_weight
            .iter()
            .flat_map(|w| up.iter().map(move |u| w * u))
            .collect();
        assert_close(g, &want, 1e-5, seed);
        let width = up.len();
        for (probe, _) in want_weight.iter().enumerate().filter(|(_, w)| **w == 0.0) {
            let row = &g[probe * width..(probe + 1) * width];
            assert!(row.iter().all(|&v| v == 0.0), "seed {seed}: probe {probe}");
        }
    }
}

/// Eq. 13: 0 on a constant field; by hand on a 3×3×3 grid with the centre probe (6
/// neighbours, each of which has 5) or a corner probe (3 neighbours, each with 4) set to `c`
/// and the rest 0; and equal to the f64 reference on random fields.
#[test]
fn probe_smoothness_matches_hand_computed_values() {
    let (seed, mut rng, device) = start();
    let grid = ProbeGrid {
        origin: [0.0; 3],
        spacing: 1.0,
        dims: [3, 3, 3],
    };
    let k = coeff_count(1);
    let mut volume = LightVolume::new(grid, 1, 2, seed, &device).expect("a volume");
    let set = |volume: &mut LightVolume, sh: &[f64]| {
        volume.sh = Param::from_tensor(tensor2(sh, [27, k * 3], &device).reshape([27, k, 3]));
    };
    let constant = gauss(&mut rng, k * 3);
    let field: Vec<f64> = (0..27).flat_map(|_| constant.clone()).collect();
    set(&mut volume, &field);
    // Zero up to f32 rounding of the 1/n neighbour weights.
    assert_close(&values(volume.probe_smoothness()), &[0.0], 1e-5, seed);
    let c = gauss(&mut rng, k * 3);
    let l1: f64 = c.iter().map(|v| v.abs()).sum();
    for (probe, want) in [(13, 11.0 * l1 / 135.0), (0, 7.0 * l1 / 108.0)] {
        let mut field = vec![0.0; 27 * k * 3];
        field[probe * k * 3..(probe + 1) * k * 3].copy_from_slice(&c);
        set(&mut volume, &field);
        assert_close(&values(volume.probe_smoothness()), &[want], 1e-5, seed);
        let reference = probe_smoothness_reference(&grid, &field);
        assert!((reference - want).abs() < 1e-12, "{reference} vs {want}");
    }
    for _ in 0..3 {
        let grid = random_grid(&mut rng, 1);
        let (volume, sh, _) = random_volume(grid, 2, 2, &mut rng, &device);
        let want = probe_smoothness_reference(&grid, &sh);
        assert_close(&values(volume.probe_smoothness()), &[want], 1e-5, seed);
    }
}

/// One environment written into every probe is read back everywhere; latents stay.
#[test]
fn set_environment_lights_every_probe_alike() {
    let (seed, mut rng, device) = start();
    let grid = random_grid(&mut rng, 1);
    let (mut volume, _, latent) = random_volume(grid, 2, 3, &mut rng, &device);
    let environment = gauss(&mut rng, 9 * 3);
    volume.set_environment(tensor2(&environment, [9, 3], &device));
    let n = 20;
    let points = tensor2(&random_points(&grid, n, &mut rng), [n, 3], &device);
    let (sh, _) = volume.interpolate(points);
    assert_close(&values(sh), &environment.repeat(n), 1e-5, seed);
    assert_eq!(wide(&values(volume.latent.val())), latent, "seed {seed}");
}

/// Splitting the probes' mean off into the shared environment changes no probe, no
/// interpolated value and not Eq. 13; on a fresh volume it leaves the unit radiance in the
/// environment and zero in every probe; the environment's gradient is the sum over points of
/// the interpolated coefficients' upstream gradient (the corner weights sum to 1); and writing
/// an environment clears the probes' own parts.
#[test]
fn the_shared_environment_splits_off_without_changing_a_probe() {
    let (seed, mut rng, device) = start();
    let grid = random_grid(&mut rng, 1);
    let (p, k) = (grid.count(), coeff_count(2));
    let (volume, sh, _) = random_volume(grid, 2, 3, &mut rng, &device);
    let n = 17;
    let points = random_points(&grid, n, &mut rng);
    let (before, _) = volume.interpolate(tensor2(&points, [n, 3], &device));
    let smoothness = values(volume.probe_smoothness());
    let split = volume.split_environment();
    assert_close(&values(split.coefficients()), &sh, 1e-5, seed);
    let (after, _) = split.interpolate(tensor2(&points, [n, 3], &device));
    assert_close(&values(after), &wide(&values(before)), 1e-5, seed);
    assert_close(
        &values(split.probe_smoothness()),
        &wide(&smoothness),
        1e-5,
        seed,
    );
    let mean: Vec<f64> = (0..k * 3)
        .map(|j| (0..p).map(|i| sh[i * k * 3 + j]).sum::<f64>() / p as f64)
        .collect();
    assert_close(&values(split.environment.val()), &mean, 1e-5, seed);

    let fresh = LightVolume::new(grid, 2, 3, seed, &device)
        .expect("a volume")
        .split_environment();
    assert!(
        values(fresh.sh.val()).iter().all(|&v| v == 0.0),
        "seed {seed}"
    );
    let unit: Vec<f64> = (0..k * 3)
        .map(|j| if j < 3 { UNIT_RADIANCE_DC } else { 0.0 })
        .collect();
    assert_close(&values(fresh.environment.val()), &unit, 1e-6, seed);

    let autodiff = device.clone().autodiff();
    let volume = LightVolume::new(grid, 2, 3, seed, &autodiff)
        .expect("a volume")
        .split_environment();
    let upstream = gauss(&mut rng, n * k * 3);
    let (sh, _) = volume.interpolate(tensor2(&points, [n, 3], &autodiff));
    let loss = (sh * tensor2(&upstream, [n, k * 3], &autodiff).reshape([n, k, 3])).sum();
    let grads = loss.backward();
    let got = values(
        volume
            .environment
            .val()
            .grad(&grads)
            .expect("the environment is reached"),
    );
    let want: Vec<f64> = (0..k * 3)
        .map(|j| (0..n).map(|i| upstream[i * k * 3 + j]).sum())
        .collect();
    assert_close(&got, &want, 1e-5, seed);

    let mut written = split;
    let environment = gauss(&mut rng, k * 3);
    written.set_environment(tensor2(&environment, [k, 3], &device));
    assert_close(
        &values(written.coefficients()),
        &environment.repeat(p),
        1e-6,
        seed,
    );
    assert!(
        values(written.sh.val()).iter().all(|&v| v == 0.0),
        "seed {seed}"
    );
}

/// `covering` spans the padded box within the probe budget (the spec's 4×2×4 m example at
/// 0.25 m gives 17×9×17), enlarges the spacing when the budget is exceeded, and names bad input.
#[test]
fn covering_spans_the_padded_box_and_rejects_bad_input() {
    let seed = fresh_seed();
    let mut rng = Rng(seed);
    let example = ProbeGrid::covering([0.0; 3], [4.0, 2.0, 4.0], 0.0, 0.25, 32).unwrap();
    assert_eq!(example.dims, [17, 9, 17]);
    assert_eq!(example.spacing, 0.25);
    for _ in 0..20 {
        let min = [0; 3].map(|_| rng.range(-5.0, 5.0));
        let max = min.map(|v| v + rng.range(0.0, 6.0));
        let (pad, spacing) = (rng.range(0.0, 1.0), rng.range(0.05, 1.0));
        let budget = 2 + (rng.next_u64() % 40) as usize;
        let grid = ProbeGrid::covering(min, max, pad, spacing, budget).unwrap();
        assert!(
            grid.dims.iter().all(|&d| (1..=budget).contains(&d)),
            "seed {seed}: {grid:?}"
        );
        assert!(grid.spacing >= spacing, "seed {seed}: {grid:?}");
        let far = grid.position(grid.count() - 1);
        for a in 0..3 {
            let slack = 1e-8 * grid.spacing;
            assert!(
                grid.origin[a] <= min[a] - pad + slack,
                "seed {seed}: {grid:?}"
            );
            assert!(far[a] >= max[a] + pad - slack, "seed {seed}: {grid:?}");
        }
        if grid.spacing > spacing {
            assert!(grid.dims.contains(&budget), "seed {seed}: {grid:?}");
        }
    }
    let what = |r: Result<ProbeGrid, IllumError>| match r {
        Err(e) => e.to_string(),
        Ok(grid) => panic!("accepted {grid:?}"),
    };
    let unit = |max, pad, spacing, per_axis| {
        what(ProbeGrid::covering([0.0; 3], max, pad, spacing, per_axis))
    };
    for spacing in [0.0, -0.5, f64::NAN, f64::INFINITY] {
        let err = unit([1.0; 3], 0.1, spacing, 32);
        assert!(err.contains("spacing"), "{err}");
    }
    assert!(unit([1.0, -1.0, 1.0], 0.1, 0.2, 32).contains("bounds"));
    assert!(unit([1.0; 3], -0.1, 0.2, 32).contains("padding"));
    assert!(unit([1.0; 3], 0.0, 0.2, 1).contains("per axis"));
    let device = Device::flex();
    let empty = ProbeGrid {
        origin: [0.0; 3],
        spacing: 1.0,
        dims: [2, 0, 2],
    };
    assert!(LightVolume::new(empty, 2, 16, 0, &device).is_err());
    assert!(LightVolume::new(example, 4, 16, 0, &device).is_err());
    assert!(LightVolume::new(example, 2, 0, 0, &device).is_err());
}
