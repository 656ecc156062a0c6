//! Real spherical harmonics up to degree 3 in the INRIA 3DGS basis and sign convention: the
//! constants every evaluation uses (the CPU and CubeCL kernels, the dense reference, colour
//! initialisation), and the basis as differentiable Burn ops, for methods that evaluate colour
//! outside the op (a world-frame colour under refined cameras, rendered as features). A
//! colour is `max(Σ_k Y_k(d) c_k + 0.5, 0)` with `d` the unit direction from the camera centre
//! to the Gaussian. [`sh_basis_f64`] is the basis in scalar f64, and [`irradiance_f64`] the
//! cosine-convolved SH radiance (lighting with SH on the CPU).

use burn::tensor::Tensor;
use std::f64::consts::PI;

/// `Y_0`: the DC basis value (colour = `SH_C0 · dc + 0.5`).
pub const SH_C0: f64 = 0.282_094_791_773_878_14;
/// Degree 1: `Y_1..3 = (−C1 y, C1 z, −C1 x)`.
pub const SH_C1: f64 = 0.488_602_511_902_919_9;
/// Degree 2 factors.
pub const SH_C2: [f64; 5] = [
    1.092_548_430_592_079_2,
    -1.092_548_430_592_079_2,
    0.315_391_565_252_520_05,
    -1.092_548_430_592_079_2,
    0.546_274_215_296_039_6,
];
/// Degree 3 factors.
pub const SH_C3: [f64; 7] = [
    -0.590_043_589_926_643_5,
    2.890_611_442_640_554,
    -0.457_045_799_464_465_8,
    0.373_176_332_590_115_4,
    -0.457_045_799_464_465_8,
    1.445_305_721_320_277,
    -0.590_043_589_926_643_5,
];

/// Number of coefficients of degree `degree`: `(degree + 1)²`.
pub fn coeff_count(degree: u32) -> usize {
    ((degree + 1) * (degree + 1)) as usize
}

/// The basis functions `Y_k(d)` for `k < (degree + 1)²`, each `[N]`, at unit directions with
/// components `x`, `y`, `z` (each `[N]`).
pub fn basis_columns(degree: u32, x: &Tensor<1>, y: &Tensor<1>, z: &Tensor<1>) -> Vec<Tensor<1>> {
    assert!(degree <= 3, "SH degree {degree} > 3");
    let mut b = vec![x.ones_like() * SH_C0];
    if degree >= 1 {
        b.push(y.clone() * -SH_C1);
        b.push(z.clone() * SH_C1);
        b.push(x.clone() * -SH_C1);
    }
    if degree >= 2 {
        let (xx, yy, zz) = (
            x.clone() * x.clone(),
            y.clone() * y.clone(),
            z.clone() * z.clone(),
        );
        b.push(x.clone() * y.clone() * SH_C2[0]);
        b.push(y.clone() * z.clone() * SH_C2[1]);
        b.push((zz.clone() * 2.0 - xx.clone() - yy.clone()) * SH_C2[2]);
        b.push(x.clone() * z.clone() * SH_C2[3]);
        b.push((xx.clone() - yy.clone()) * SH_C2[4]);
        if degree >= 3 {
            b.push(y.clone() * (xx.clone() * 3.0 - yy.clone()) * SH_C3[0]);
            b.push(x.clone() * y.clone() * z.clone() * SH_C3[1]);
            b.push(y.clone() * (zz.clone() * 4.0 - xx.clone() - yy.clone()) * SH_C3[2]);
            b.push(z.clone() * (zz.clone() * 2.0 - xx.clone() * 3.0 - yy.clone() * 3.0) * SH_C3[3]);
            b.push(x.clone() * (zz.clone() * 4.0 - xx.clone() - yy.clone()) * SH_C3[4]);
            b.push(z.clone() * (xx.clone() - yy.clone()) * SH_C3[5]);
            b.push(x.clone() * (xx - yy * 3.0) * SH_C3[6]);
        }
    }
    b
}

/// `[N, (degree + 1)²]` basis values at `[N, 3]` directions (normalised here; a zero direction
/// gives the DC term only).
pub fn sh_basis(degree: u32, directions: Tensor<2>) -> Tensor<2> {
    let [n, three] = directions.dims();
    assert_eq!(three, 3, "sh_basis: directions [N, 3], got [{n}, {three}]");
    let norm = directions
        .clone()
        .powi_scalar(2)
        .sum_dim(1)
        .sqrt()
        .clamp_min(1e-12);
    let d = directions / norm;
    let column = |j: usize| d.clone().slice([0..n, j..j + 1]).reshape([n]);
    let (x, y, z) = (column(0), column(1), column(2));
    Tensor::stack(basis_columns(degree, &x, &y, &z), 1)
}

/// Colours `[N, C]` of SH coefficients `[N, K, C]` (`K ≥ (degree + 1)²`; higher ones ignored)
/// seen along `[N, 3]` directions: `max(Σ_k Y_k(d) c_k + 0.5, 0)`, as the rasterizer does.
pub fn sh_colour(coefficients: Tensor<3>, directions: Tensor<2>, degree: u32) -> Tensor<2> {
    let [n, k, c] = coefficients.dims();
    let used = coeff_count(degree);
    assert!(
        k >= used,
        "sh_colour: {k} coefficients, degree {degree} needs {used}"
    );
    let basis = sh_basis(degree, directions).reshape([n, used, 1]);
    let coefficients = coefficients.slice([0..n, 0..used, 0..c]);
    (coefficients * basis)
        .sum_dim(1)
        .reshape([n, c])
        .add_scalar(0.5)
        .clamp_min(0.0)
}

/// The clamped-cosine convolution factors `Â_l` for `l = 0..=3` (Ramamoorthi & Hanrahan 2001).
pub const COSINE_LOBE_BANDS: [f64; 4] = [PI, 2.0 * PI / 3.0, PI / 4.0, 0.0];

/// The real SH basis `Y_k(d)`, `k < (degree + 1)²`, at direction `d` (normalised here), in
/// scalar f64: the CPU kernel's basis, for anything that lights with SH on the CPU.
pub fn sh_basis_f64(degree: u32, d: [f64; 3]) -> Vec<f64> {
    assert!(degree <= 3, "sh_basis_f64: degree {degree} > 3");
    let length = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    assert!(length > 0.0, "sh_basis_f64: zero direction");
    let mut out = [0.0f64; 16];
    crate::cpu::sh::basis(degree, d.map(|v| v / length), &mut out, None);
    out[..coeff_count(degree)].to_vec()
}

/// The irradiance `E(n) = ∫ L(ω) max(ω·n, 0) dω = Σ_lm Â_l c_lm Y_lm(n)` of the unclamped SH
/// radiance `L(ω) = Σ c_k Y_k(ω)` (no +0.5 offset: a light, not a colour) of the first
/// `(degree + 1)²` coefficients of `sh`, at unit `normal` (Ramamoorthi & Hanrahan 2001). A
/// Lambertian surface of albedo `b` sends out `b E(n) / π`.
pub fn irradiance_f64(sh: &[[f64; 3]], degree: u32, normal: [f64; 3]) -> [f64; 3] {
    let basis = sh_basis_f64(degree, normal);
    assert!(
        sh.len() >= basis.len(),
        "irradiance_f64: {} coefficients, degree {degree} needs {}",
        sh.len(),
        basis.len()
    );
    let band = |k: usize| COSINE_LOBE_BANDS[(k as f64).sqrt() as usize];
    std::array::from_fn(|ch| {
        basis
            .iter()
            .enumerate()
            .map(|(k, y)| band(k) * sh[k][ch] * y)
            .sum()
    })
}
