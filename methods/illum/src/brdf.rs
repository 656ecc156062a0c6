//! The BRDF of Illum's PBR human Gaussians (Eq. 4–5): the "simplified Disney" model of R3DG
//! (ref. 14), a Lambert diffuse lobe plus a Cook–Torrance specular lobe with the GGX distribution, the
//! Schlick–Smith geometry term and the spherical-Gaussian Schlick Fresnel.
//!
//! - Diffuse `f_d = (1 − m)·b/π` (Disney; the paper's `b/π` at `m = 0`).
//! - Specular `f_s = D·F·G / (4 (n·ω_i)(n·ω_o))`. The paper prints the denominator without the
//!   4; Cook–Torrance and R3DG's code have it, and without it the lobe reflects up to 4× the
//!   energy it receives (spec, Eq. 5; the white-furnace test shows both).
//! - `h = normalize(ω_i + ω_o)`, `α = r²`, `D = α²/(π((n·h)²(α² − 1) + 1)²)`,
//!   `F = F0 + (1 − F0)·2^{(−5.55473 (ω_o·h) − 6.98316)(ω_o·h)}`, `G = G1(ω_i)·G1(ω_o)` with
//!   `G1(ω) = n·ω/((n·ω)(1 − k) + k)`, `k = (r + 1)²/8`, `F0 = 0.04(1 − m) + b·m`.
//! - Every cosine is clamped to `[1e-6, 1]` and the roughness to `≥ 0.04`, so grazing,
//!   back-facing and opposite directions give finite values and gradients. Flipping `n`
//!   towards the viewer is the caller's (`crate::pbr::face_forward`).
//!
//! [`specular`] and [`diffuse`] are Burn ops; [`brdf_reference`] and [`ndf_reference`] are the
//! same formulas in scalar f64 for tests.

use std::f64::consts::{LN_2, PI};

use burn::tensor::Tensor;

/// The smallest roughness `r` the BRDF uses (`α = r² ≥ 1.6e-3`), so the GGX peak stays finite.
pub const MIN_ROUGHNESS: f64 = 0.04;

/// Every cosine of Eq. 5 is clamped to `[DOT_EPS, 1]`, as R3DG does.
pub const DOT_EPS: f64 = 1e-6;

/// The Fresnel reflectance at normal incidence of a dielectric (`m = 0`).
pub const DIELECTRIC_F0: f64 = 0.04;

/// The spherical-Gaussian Fresnel exponent's coefficients: `2^{(A·c + B)·c}`, `c = ω_o·h`.
const FRESNEL_A: f64 = -5.55473;
const FRESNEL_B: f64 = -6.98316;

/// Added to a squared length before its root, so a zero vector (`ω_i = −ω_o`) gives a zero half
/// vector with a finite gradient instead of a NaN.
const LENGTH_EPS: f64 = 1e-30;

/// Disney's diffuse lobe `f_d = (1 − m)·b/π` (Eq. 4, spec's choice), `[N, 3]` from albedo
/// `[N, 3]` and metallic `[N, 1]`.
pub fn diffuse(albedo: Tensor<2>, metallic: Tensor<2>) -> Tensor<2> {
    let [n, three] = albedo.dims();
    assert_eq!(
        three, 3,
        "diffuse: albedo must be [N, 3], got [{n}, {three}]"
    );
    assert_eq!(
        metallic.dims(),
        [n, 1],
        "diffuse: metallic must be [{n}, 1]"
    );
    albedo * (1.0 - metallic) / PI
}

/// `F0 = 0.04(1 − m) + b·m`, `[N, 3]`.
fn base_reflectance(albedo: Tensor<2>, metallic: Tensor<2>) -> Tensor<2> {
    albedo * metallic.clone() + (1.0 - metallic) * DIELECTRIC_F0
}

/// Eq. 5 of Illum (with Cook–Torrance's 4): the specular lobe `f_s(ω_o, ω_i)` `[N, S, 3]` of each
/// Gaussian's `S` incident directions `light` `[N, S, 3]`, seen from `view` `[N, 3]`, about
/// `normals` `[N, 3]`, for albedo `[N, 3]`, metallic `[N, 1]` and roughness `[N, 1]` (clamped to
/// ≥ [`MIN_ROUGHNESS`]). Directions and normals are unit vectors.
pub fn specular(
    normals: Tensor<2>,
    view: Tensor<2>,
    light: Tensor<3>,
    albedo: Tensor<2>,
    metallic: Tensor<2>,
    roughness: Tensor<2>,
) -> Tensor<3> {
    let [n, s, three] = light.dims();
    assert_eq!(
        three, 3,
        "specular: light directions must be [N, S, 3], got [{n}, {s}, {three}]"
    );
    for (name, tensor, width) in [
        ("normals", &normals, 3),
        ("view", &view, 3),
        ("albedo", &albedo, 3),
        ("metallic", &metallic, 1),
        ("roughness", &roughness, 1),
    ] {
        assert_eq!(
            tensor.dims(),
            [n, width],
            "specular: {name} must be [{n}, {width}]"
        );
    }
    let normals = normals.unsqueeze_dim::<3>(1); // [N, 1, 3]
    let view = view.unsqueeze_dim::<3>(1); // [N, 1, 3]
    let sum = light.clone() + view.clone();
    let half = sum.clone() / (sum.powi_scalar(2).sum_dim(2) + LENGTH_EPS).sqrt(); // [N, S, 3]
    let cosine = |a: Tensor<3>, b: Tensor<3>| (a * b).sum_dim(2).clamp(DOT_EPS, 1.0);
    let n_v = cosine(normals.clone(), view.clone()); // [N, 1, 1]
    let n_l = cosine(normals.clone(), light); // [N, S, 1]
    let n_h = cosine(normals, half.clone()); // [N, S, 1]
    let v_h = cosine(view, half); // [N, S, 1]

    let r = roughness.clamp_min(MIN_ROUGHNESS).unsqueeze_dim::<3>(1); // [N, 1, 1]
    let alpha2 = r.clone().powi_scalar(4);
    let ndf = alpha2.clone() / ((n_h.powi_scalar(2) * (alpha2 - 1.0) + 1.0).powi_scalar(2) * PI);
    let k = (r + 1.0).powi_scalar(2) / 8.0;
    let g1 = |c: Tensor<3>| c.clone() / (c * (1.0 - k.clone()) + k.clone());
    let geometry = g1(n_l.clone()) * g1(n_v.clone());
    let f0 = base_reflectance(albedo, metallic).unsqueeze_dim::<3>(1); // [N, 1, 3]
    let weight = ((v_h.clone() * FRESNEL_A + FRESNEL_B) * v_h * LN_2).exp(); // 2^(…)
    let fresnel = f0.clone() + (1.0 - f0) * weight; // [N, S, 3]
    fresnel * (ndf * geometry / (n_l * n_v * 4.0))
}

/// The GGX normal distribution `D(h) = α²/(π((n·h)²(α² − 1) + 1)²)`, `α = r²`, at cosine
/// `n_dot_h` (not clamped here) and roughness `roughness` (clamped to ≥ [`MIN_ROUGHNESS`]).
pub fn ndf_reference(n_dot_h: f64, roughness: f64) -> f64 {
    let alpha2 = roughness.max(MIN_ROUGHNESS).powi(4);
    let denominator = n_dot_h * n_dot_h * (alpha2 - 1.0) + 1.0;
    alpha2 / (PI * denominator * denominator)
}

/// The spherical-Gaussian Schlick Fresnel `F0 + (1 − F0)·2^{(−5.55473 c − 6.98316) c}` at
/// `c = ω_o·h` (not clamped here). At `c = 1` it leaves `(1 − F0)·2^{−12.54} ≈ 1.7e-4·(1 − F0)`
/// above `F0`, where Schlick's `(1 − c)⁵` gives 0.
pub fn fresnel_reference(f0: f64, v_dot_h: f64) -> f64 {
    f0 + (1.0 - f0) * 2f64.powf((FRESNEL_A * v_dot_h + FRESNEL_B) * v_dot_h)
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// [`diffuse`] and [`specular`] in f64 for one Gaussian and one incident direction: normal `n`,
/// view `wo` and light `wi` (unit vectors), albedo, metallic and roughness. Returns
/// `(f_d, f_s)` per RGB channel.
pub fn brdf_reference(
    n: [f64; 3],
    wo: [f64; 3],
    wi: [f64; 3],
    albedo: [f64; 3],
    metallic: f64,
    roughness: f64,
) -> ([f64; 3], [f64; 3]) {
    let diffuse = albedo.map(|b| (1.0 - metallic) * b / PI);
    let sum: [f64; 3] = std::array::from_fn(|k| wi[k] + wo[k]);
    let length = (dot(sum, sum) + LENGTH_EPS).sqrt();
    let h = sum.map(|v| v / length);
    let clamp = |c: f64| c.clamp(DOT_EPS, 1.0);
    let (n_v, n_l, n_h, v_h) = (
        clamp(dot(n, wo)),
        clamp(dot(n, wi)),
        clamp(dot(n, h)),
        clamp(dot(wo, h)),
    );
    let r = roughness.max(MIN_ROUGHNESS);
    let k = (r + 1.0) * (r + 1.0) / 8.0;
    let g1 = |c: f64| c / (c * (1.0 - k) + k);
    let lobe = ndf_reference(n_h, r) * g1(n_l) * g1(n_v) / (4.0 * n_l * n_v);
    let specular = albedo.map(|b| {
        let f0 = DIELECTRIC_F0 * (1.0 - metallic) + b * metallic;
        fresnel_reference(f0, v_h) * lobe
    });
    (diffuse, specular)
}
