//! The public SH basis in Burn ops (`splatzoo_rasterizer::sh`) against the kernels' scalar f64
//! basis, on fresh random directions (unnormalised, and the axes), every degree; the colour
//! against its definition, clamp included; gradients against finite differences.

use burn::tensor::{Device, Tensor, TensorData};
use rand::{Rng, SeedableRng, rngs::StdRng};
use splatzoo_rasterizer::cpu::sh::basis;
use splatzoo_rasterizer::sh::{coeff_count, sh_basis, sh_colour};

fn directions(rng: &mut StdRng, n: usize) -> Vec<[f64; 3]> {
    let mut d: Vec<[f64; 3]> = (0..n)
        .map(|_| std::array::from_fn(|_| rng.random_range(-2.0..2.0)))
        .collect();
    d.extend([[1.0, 0.0, 0.0], [0.0, -3.0, 0.0], [0.0, 0.0, 1e-3]]);
    d
}

fn unit(d: [f64; 3]) -> [f64; 3] {
    let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    d.map(|c| c / n)
}

fn tensor2(rows: &[[f64; 3]], device: &Device) -> Tensor<2> {
    let flat: Vec<f32> = rows.iter().flatten().map(|&v| v as f32).collect();
    Tensor::from_data(TensorData::new(flat, [rows.len(), 3]), device)
}

#[test]
fn the_burn_basis_matches_the_scalar_basis_at_every_degree() {
    let seed: u64 = rand::random();
    let mut rng = StdRng::seed_from_u64(seed);
    let device = Device::flex();
    let dirs = directions(&mut rng, 40);
    for degree in 0..=3u32 {
        let k = coeff_count(degree);
        let got = super::common::values(sh_basis(degree, tensor2(&dirs, &device)));
        assert_eq!(got.len(), dirs.len() * k);
        for (i, &d) in dirs.iter().enumerate() {
            let mut want = [0.0f64; 16];
            basis(degree, unit(d), &mut want, None);
            for j in 0..k {
                let (g, w) = (got[i * k + j] as f64, want[j]);
                assert!(
                    (g - w).abs() < 2e-5 * (1.0 + w.abs()),
                    "seed {seed}, degree {degree}, direction {d:?}, Y_{j}: {g} vs {w}"
                );
            }
        }
    }
}

#[test]
fn sh_colour_follows_its_definition_and_its_gradient_finite_differences() {
    let seed: u64 = rand::random();
    let mut rng = StdRng::seed_from_u64(seed);
    let device = Device::flex().autodiff();
    let dirs = directions(&mut rng, 12);
    let n = dirs.len();
    let (k, c, degree) = (16, 3, 3);
    // Large enough coefficients that some colours clamp at 0.
    let coefficients: Vec<f64> = (0..n * k * c)
        .map(|_| rng.random_range(-1.0..1.0))
        .collect();
    let as_tensor = |values: &[f64]| {
        let flat: Vec<f32> = values.iter().map(|&v| v as f32).collect();
        Tensor::<3>::from_data(TensorData::new(flat, [n, k, c]), &device)
    };
    let expected = |coefficients: &[f64]| -> Vec<f64> {
        let mut out = Vec::new();
        for (i, &d) in dirs.iter().enumerate() {
            let mut y = [0.0f64; 16];
            basis(degree, unit(d), &mut y, None);
            for ch in 0..c {
                let sum: f64 = (0..k)
                    .map(|j| y[j] * coefficients[(i * k + j) * c + ch])
                    .sum();
                out.push((sum + 0.5).max(0.0));
            }
        }
        out
    };
    let got = super::common::values(sh_colour(
        as_tensor(&coefficients),
        tensor2(&dirs, &device),
        degree,
    ));
    let want = expected(&coefficients);
    assert!(want.contains(&0.0), "seed {seed}: no clamped colour");
    for (g, w) in got.iter().zip(&want) {
        assert!((*g as f64 - w).abs() < 2e-5, "seed {seed}: {g} vs {w}");
    }
    // d(Σ colour · weight)/d coefficient against central differences in f64.
    let weights: Vec<f64> = (0..n * c).map(|_| rng.random_range(-1.0..1.0)).collect();
    let leaf = as_tensor(&coefficients).require_grad();
    let weight_tensor = Tensor::<2>::from_data(
        TensorData::new(weights.iter().map(|&v| v as f32).collect(), [n, c]),
        &device,
    );
    let loss = (sh_colour(leaf.clone(), tensor2(&dirs, &device), degree) * weight_tensor).sum();
    let grads = loss.backward();
    let analytic = super::common::values(leaf.grad(&grads).unwrap());
    let objective = |coefficients: &[f64]| -> f64 {
        expected(coefficients)
            .iter()
            .zip(&weights)
            .map(|(a, b)| a * b)
            .sum()
    };
    let h = 1e-6;
    for index in (0..n * k * c).step_by(7) {
        let (mut up, mut down) = (coefficients.clone(), coefficients.clone());
        up[index] += h;
        down[index] -= h;
        let numeric = (objective(&up) - objective(&down)) / (2.0 * h);
        assert!(
            (analytic[index] as f64 - numeric).abs() < 1e-4,
            "seed {seed}: coefficient {index}: {} vs {numeric}",
            analytic[index]
        );
    }
}
