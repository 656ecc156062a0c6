//! Fibonacci sampling of the hemisphere about each Gaussian's normal, the incident directions
//! ω_j of Illum's Monte-Carlo shading (Eq. 6–7; spec §2 Eq. 6, "Sampling").
//!
//! Sample `j < N` has cosine `z_j` to the normal, `ρ_j = √(1 − z_j²)` and azimuth
//! `φ_j = j·π(3 − √5) + u` (the golden angle, so the azimuths never line up); the local direction
//! `(ρ sin φ, ρ cos φ, z)` is rotated into the normal's frame. `u` is a per-Gaussian random
//! offset in training and 0 at evaluation. Two rules for `z_j` ([`HemisphereRule`]):
//! - the equal-area midpoint rule `z_j = 1 − (j + ½)/N` (default): each sample stands for the same
//!   solid angle `Δω = 2π/N`, so Eq. 7 integrates a constant light exactly;
//! - R3DG's `z_j = max(1 − 2j/(2N − 1), sin 10°)`, whose clamp biases a constant light by about
//!   +3.0 % (a knob, to reproduce R3DG, ref. 14).
//!
//! The tangent frame is Duff et al. 2017's branchless orthonormal basis, stable for every unit
//! normal including ±z. [`fibonacci_hemisphere`] is the differentiable Burn version;
//! [`fibonacci_hemisphere_reference`] is the same rule in scalar f64 for tests.

use std::f64::consts::PI;

use burn::tensor::{Tensor, TensorData};

/// The golden angle `π(3 − √5)`, the azimuth step between consecutive samples.
pub const GOLDEN_ANGLE: f64 = 2.399_963_229_728_653;

/// R3DG's lowest elevation: its rule keeps `z_j ≥ sin 10°`.
pub const R3DG_MIN_ELEVATION_DEG: f64 = 10.0;

/// How the cosines `z_j` of the samples to the normal are spaced.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum HemisphereRule {
    /// `z_j = 1 − (j + ½)/N`: equal solid angle per sample, unbiased (our default).
    #[default]
    Midpoint,
    /// `z_j = max(1 − 2j/(2N − 1), sin 10°)`, as R3DG's code samples (+3.0 % on a constant light).
    R3dg,
}

impl HemisphereRule {
    /// The cosine `z_j` of sample `j` of `count` to the normal.
    pub fn cos_theta(self, j: usize, count: usize) -> f64 {
        let (j, count) = (j as f64, count as f64);
        match self {
            HemisphereRule::Midpoint => 1.0 - (j + 0.5) / count,
            HemisphereRule::R3dg => {
                (1.0 - 2.0 * j / (2.0 * count - 1.0)).max(R3DG_MIN_ELEVATION_DEG.to_radians().sin())
            }
        }
    }
}

/// The solid angle `Δω = 2π/N` each of `count` samples stands for (Eq. 7's `Δω_i`).
pub fn solid_angle_weight(count: usize) -> f64 {
    assert!(count > 0, "solid_angle_weight: no samples");
    2.0 * PI / count as f64
}

/// The `count` sample directions in the normal's local frame (normal = +z), azimuths offset by
/// `offset` radians: `(ρ_j sin φ_j, ρ_j cos φ_j, z_j)`.
pub fn local_directions(count: usize, rule: HemisphereRule, offset: f64) -> Vec<[f64; 3]> {
    (0..count)
        .map(|j| {
            let z = rule.cos_theta(j, count);
            let rho = (1.0 - z * z).max(0.0).sqrt();
            // Reduce the base angle first, so large j keep full precision in f32 callers.
            let phi = (j as f64 * GOLDEN_ANGLE).rem_euclid(2.0 * PI) + offset;
            [rho * phi.sin(), rho * phi.cos(), z]
        })
        .collect()
}

/// Duff et al. 2017's branchless orthonormal basis `(t, b)` of a unit normal `n`: `t × b = n`,
/// defined and smooth on each side of `n_z = 0` (the sign is taken as + at `n_z = 0`).
pub fn tangent_frame_reference(n: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let sign = if n[2] >= 0.0 { 1.0 } else { -1.0 };
    let a = -1.0 / (sign + n[2]);
    let b = n[0] * n[1] * a;
    (
        [1.0 + sign * n[0] * n[0] * a, sign * b, -sign * n[0]],
        [b, sign + n[1] * n[1] * a, -n[1]],
    )
}

/// [`tangent_frame_reference`] as Burn ops on unit normals `[N, 3]`: `(t, b)`, each `[N, 3]`.
fn tangent_frame(n: Tensor<2>) -> (Tensor<2>, Tensor<2>) {
    let component = |k: usize| n.clone().narrow(1, k, 1);
    let (x, y, z) = (component(0), component(1), component(2));
    // +1 where n_z ≥ 0, else −1: a constant, so it carries no gradient.
    let sign = z.clone().greater_equal_elem(0.0).float() * 2.0 - 1.0;
    let a = (sign.clone() + z).recip().neg();
    let b = x.clone() * y.clone() * a.clone();
    let tangent = Tensor::cat(
        vec![
            sign.clone() * x.clone().powi_scalar(2) * a.clone() + 1.0,
            sign.clone() * b.clone(),
            sign.clone().neg() * x,
        ],
        1,
    );
    let bitangent = Tensor::cat(vec![b, sign + y.clone().powi_scalar(2) * a, y.neg()], 1);
    (tangent, bitangent)
}

/// Eq. 6's Fibonacci sampling as Burn ops: `count` unit directions `[N, count, 3]` on the
/// hemisphere about each of `normals` `[N, 3]` (normalised here), azimuths offset per normal by
/// `azimuth_offsets` `[N]` radians (`None`: 0, the evaluation setting). Differentiable in the
/// normals and the offsets.
pub fn fibonacci_hemisphere(
    normals: Tensor<2>,
    count: usize,
    rule: HemisphereRule,
    azimuth_offsets: Option<Tensor<1>>,
) -> Tensor<3> {
    let [n, three] = normals.dims();
    assert_eq!(
        three, 3,
        "fibonacci_hemisphere: normals must be [N, 3], got [{n}, {three}]"
    );
    assert!(count > 0, "fibonacci_hemisphere: count must be positive");
    let device = normals.device();
    let local = local_directions(count, rule, 0.0);
    let column = |k: usize| {
        let v: Vec<f32> = local.iter().map(|d| d[k] as f32).collect();
        Tensor::<2>::from_data(TensorData::new(v, [1, count]), &device)
    };
    let (mut x, mut y, z) = (column(0), column(1), column(2)); // each [1, S]
    if let Some(u) = azimuth_offsets {
        assert_eq!(
            u.dims(),
            [n],
            "fibonacci_hemisphere: azimuth_offsets must be [{n}]"
        );
        // Adding u to φ rotates (ρ sin φ, ρ cos φ) by u: one exact rotation per normal.
        let u = u.reshape([n, 1]);
        let (cos, sin) = (u.clone().cos(), u.sin());
        (x, y) = (
            x.clone() * cos.clone() + y.clone() * sin.clone(),
            y * cos - x * sin,
        );
    }
    // The ε inside the root keeps a zero normal's gradient finite.
    let length = (normals.clone().powi_scalar(2).sum_dim(1) + 1e-30).sqrt();
    let normals = normals / length;
    let (tangent, bitangent) = tangent_frame(normals.clone());
    let along =
        |w: Tensor<2>, axis: Tensor<2>| w.unsqueeze_dim::<3>(2) * axis.unsqueeze_dim::<3>(1);
    along(x, tangent) + along(y, bitangent) + along(z, normals)
}

/// [`fibonacci_hemisphere`] in f64 for one normal (normalised here) and one azimuth offset.
pub fn fibonacci_hemisphere_reference(
    normal: [f64; 3],
    count: usize,
    rule: HemisphereRule,
    azimuth_offset: f64,
) -> Vec<[f64; 3]> {
    let length = normal.iter().map(|v| v * v).sum::<f64>().sqrt();
    assert!(length > 0.0, "fibonacci_hemisphere_reference: zero normal");
    let n = normal.map(|v| v / length);
    let (t, b) = tangent_frame_reference(n);
    local_directions(count, rule, azimuth_offset)
        .into_iter()
        .map(|[x, y, z]| std::array::from_fn(|k| x * t[k] + y * b[k] + z * n[k]))
        .collect()
}
