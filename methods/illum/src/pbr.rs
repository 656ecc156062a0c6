//! Illum's per-Gaussian physically based shading (Eq. 4 and 7) and the sRGB colour curves.
//!
//! Eq. 7 estimates the rendering equation (Eq. 4) over `S` sampled incident directions ω_j:
//! `c' = Σ_j (f_d + f_s(ω_o, ω_j))·V_j·L(ω_j)·max(ω_j·n, 0)·Δω`, with `Δω = 2π/S` (the paper
//! prints `N_l + 1` terms; we sum `N_l`, each standing for an equal share of the hemisphere, as
//! R3DG does). `L(ω) = max(Σ_lm c_lm Y_lm(ω), 0)` per channel from the SH coefficients already
//! interpolated from the light volume (Eq. 6; the rasterizer's INRIA basis, no +0.5 offset). `n`
//! is flipped to face the viewer first (spec, Eq. 5). `c'` is linear RGB; [`linear_to_srgb`]
//! encodes it per Gaussian before the splat.
//!
//! [`shade`] is Burn ops; [`shade_reference`] is one Gaussian in scalar f64, on the f64 SH
//! basis ([`splatzoo_rasterizer::sh::sh_basis_f64`]) and [`brdf_reference`].
//! [`splatzoo_rasterizer::sh::irradiance_f64`] is the analytic diffuse irradiance
//! `Σ Â_l c_lm Y_lm(n)` the Monte-Carlo sum must approach (spec §8, check 2).

use burn::tensor::Tensor;
use splatzoo_rasterizer::sh::{coeff_count, sh_basis, sh_basis_f64};

use crate::brdf::{brdf_reference, diffuse, specular};
use crate::sampling::solid_angle_weight;

/// sRGB's knee on the linear side: `12.92 x` at and below it, the power curve above.
pub const SRGB_LINEAR_KNEE: f64 = 0.003_130_8;

/// sRGB's knee on the encoded side (`12.92 ×` [`SRGB_LINEAR_KNEE`], rounded as the standard does).
pub const SRGB_ENCODED_KNEE: f64 = 0.040_45;

/// The shading knobs of Eq. 7.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shading {
    /// Add the specular lobe `f_s` (Eq. 5) to the diffuse one.
    pub specular: bool,
}

impl Default for Shading {
    fn default() -> Self {
        Self { specular: true }
    }
}

/// Eq. 7's inputs for `N` Gaussians and `S` incident directions each.
#[derive(Debug, Clone)]
pub struct ShadeInputs {
    /// `[N, 3]` unit normals (flipped towards the viewer inside [`shade`]).
    pub normals: Tensor<2>,
    /// `[N, 3]` unit directions ω_o from each Gaussian to the camera centre.
    pub view_dirs: Tensor<2>,
    /// `[N, 3]` linear albedo `b`.
    pub albedo: Tensor<2>,
    /// `[N, 1]` metallic `m`.
    pub metallic: Tensor<2>,
    /// `[N, 1]` roughness `r`.
    pub roughness: Tensor<2>,
    /// `[N, K, 3]` incident-radiance SH coefficients, `K = (l_max + 1)² ≤ 16`.
    pub radiance_sh: Tensor<3>,
    /// `[N, S, 3]` unit incident directions ω_j, sampled about [`face_forward`]'s normals.
    pub directions: Tensor<3>,
    /// `[N, S]` visibility `V(ω_j)` in `[0, 1]`; `None` is `V ≡ 1`.
    pub visibility: Option<Tensor<2>>,
}

/// The SH degree `l` with `(l + 1)² = count`.
fn sh_degree(count: usize) -> u32 {
    let Some(degree) = (0..=3).find(|&l| coeff_count(l) == count) else {
        panic!("{count} SH coefficients: expected (l + 1)² for l ≤ 3");
    };
    degree
}

/// Normals `[N, 3]` flipped where they face away from `view_dirs` `[N, 3]` (`n·ω_o < 0`), so
/// the shaded hemisphere is the one the camera sees. The flip carries no gradient of its own.
pub fn face_forward(normals: Tensor<2>, view_dirs: Tensor<2>) -> Tensor<2> {
    let facing = (normals.clone() * view_dirs).sum_dim(1); // [N, 1]
    let sign = facing.greater_equal_elem(0.0).float() * 2.0 - 1.0;
    normals * sign
}

/// The incident radiance `L(ω) = max(Σ_k c_k Y_k(ω), 0)` `[N, S, 3]` of SH coefficients
/// `[N, K, 3]` at unit directions `[N, S, 3]` (Eq. 6's probe radiance, no +0.5 offset).
pub fn incident_radiance(radiance_sh: Tensor<3>, directions: Tensor<3>) -> Tensor<3> {
    let [n, k, c] = radiance_sh.dims();
    let [rows, s, three] = directions.dims();
    assert_eq!(
        (rows, three),
        (n, 3),
        "incident_radiance: directions must be [{n}, S, 3], got [{rows}, {s}, {three}]"
    );
    assert_eq!(
        c, 3,
        "incident_radiance: SH must be [N, K, 3], got [{n}, {k}, {c}]"
    );
    let basis = sh_basis(sh_degree(k), directions.reshape([n * s, 3])).reshape([n, s, k]);
    basis.matmul(radiance_sh).clamp_min(0.0)
}

/// Eq. 7 of Illum: the linear RGB colour `[N, 3]` of each Gaussian, the Monte-Carlo sum over
/// its sampled directions of `(f_d + f_s)·V·L·max(ω_j·n, 0)·2π/S`.
pub fn shade(inputs: ShadeInputs, shading: &Shading) -> Tensor<2> {
    let ShadeInputs {
        normals,
        view_dirs,
        albedo,
        metallic,
        roughness,
        radiance_sh,
        directions,
        visibility,
    } = inputs;
    let [n, s, three] = directions.dims();
    assert_eq!(
        three, 3,
        "shade: directions must be [N, S, 3], got [{n}, {s}, {three}]"
    );
    assert!(s > 0, "shade: no incident directions");
    for (name, tensor, width) in [
        ("normals", &normals, 3),
        ("view_dirs", &view_dirs, 3),
        ("albedo", &albedo, 3),
        ("metallic", &metallic, 1),
        ("roughness", &roughness, 1),
    ] {
        assert_eq!(
            tensor.dims(),
            [n, width],
            "shade: {name} must be [{n}, {width}]"
        );
    }
    if n == 0 {
        return Tensor::zeros([0, 3], &albedo.device());
    }
    let normals = face_forward(normals, view_dirs.clone());
    let cosine = (directions.clone() * normals.clone().unsqueeze_dim::<3>(1))
        .sum_dim(2)
        .clamp_min(0.0); // [N, S, 1]
    let mut arriving = incident_radiance(radiance_sh, directions.clone()) * cosine; // [N, S, 3]
    if let Some(visibility) = visibility {
        assert_eq!(
            visibility.dims(),
            [n, s],
            "shade: visibility must be [{n}, {s}]"
        );
        arriving = arriving * visibility.reshape([n, s, 1]);
    }
    // f_d does not depend on ω_j: weight the summed irradiance once.
    let mut colour =
        diffuse(albedo.clone(), metallic.clone()) * arriving.clone().sum_dim(1).reshape([n, 3]);
    if shading.specular {
        let lobe = specular(normals, view_dirs, directions, albedo, metallic, roughness);
        colour = colour + (lobe * arriving).sum_dim(1).reshape([n, 3]);
    }
    colour * solid_angle_weight(s)
}

/// The sRGB encoding (OETF) of linear values, element-wise: `12.92 x` up to
/// [`SRGB_LINEAR_KNEE`], `1.055 x^{1/2.4} − 0.055` above. The power branch is evaluated on
/// inputs clamped to the knee, so its gradient stays finite at and below 0.
pub fn linear_to_srgb<const D: usize>(linear: Tensor<D>) -> Tensor<D> {
    let line = linear.clone() * 12.92;
    let curve = linear
        .clone()
        .clamp_min(SRGB_LINEAR_KNEE)
        .powf_scalar(1.0 / 2.4)
        * 1.055
        - 0.055;
    line.mask_where(linear.greater_elem(SRGB_LINEAR_KNEE), curve)
}

/// The sRGB decoding (inverse of [`linear_to_srgb`]), element-wise: `x/12.92` up to
/// [`SRGB_ENCODED_KNEE`], `((x + 0.055)/1.055)^{2.4}` above.
pub fn srgb_to_linear<const D: usize>(srgb: Tensor<D>) -> Tensor<D> {
    let line = srgb.clone() / 12.92;
    let curve = ((srgb.clone().clamp_min(SRGB_ENCODED_KNEE) + 0.055) / 1.055).powf_scalar(2.4);
    line.mask_where(srgb.greater_elem(SRGB_ENCODED_KNEE), curve)
}

/// [`linear_to_srgb`] of one value in f64.
pub fn linear_to_srgb_reference(x: f64) -> f64 {
    if x <= SRGB_LINEAR_KNEE {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// [`srgb_to_linear`] of one value in f64.
pub fn srgb_to_linear_reference(x: f64) -> f64 {
    if x <= SRGB_ENCODED_KNEE {
        x / 12.92
    } else {
        ((x + 0.055) / 1.055).powf(2.4)
    }
}

/// [`incident_radiance`] in f64: `max(Σ_k c_k Y_k(d), 0)` per channel, degree from `sh.len()`.
pub fn radiance_reference(sh: &[[f64; 3]], d: [f64; 3]) -> [f64; 3] {
    let basis = sh_basis_f64(sh_degree(sh.len()), d);
    std::array::from_fn(|ch| {
        sh.iter()
            .zip(&basis)
            .map(|(c, y)| c[ch] * y)
            .sum::<f64>()
            .max(0.0)
    })
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// One Gaussian's inputs to [`shade_reference`], in f64.
#[derive(Debug, Clone, Copy)]
pub struct ShadePoint<'a> {
    /// Unit normal (flipped towards `view_dir` as in [`shade`]).
    pub normal: [f64; 3],
    /// Unit direction ω_o to the camera.
    pub view_dir: [f64; 3],
    /// Linear albedo `b`.
    pub albedo: [f64; 3],
    /// Metallic `m`.
    pub metallic: f64,
    /// Roughness `r`.
    pub roughness: f64,
    /// `K` SH coefficient triples of the incident radiance.
    pub radiance_sh: &'a [[f64; 3]],
    /// The `S` unit incident directions ω_j.
    pub directions: &'a [[f64; 3]],
    /// `V(ω_j)` per direction; `None` is `V ≡ 1`.
    pub visibility: Option<&'a [f64]>,
}

/// [`shade`] in f64 for one Gaussian: Eq. 7 term by term.
pub fn shade_reference(point: &ShadePoint, shading: &Shading) -> [f64; 3] {
    let facing = if dot(point.normal, point.view_dir) >= 0.0 {
        1.0
    } else {
        -1.0
    };
    let n = point.normal.map(|v| facing * v);
    let weight = solid_angle_weight(point.directions.len());
    if let Some(visibility) = point.visibility {
        assert_eq!(
            visibility.len(),
            point.directions.len(),
            "shade_reference: one visibility per direction"
        );
    }
    let mut colour = [0.0; 3];
    for (j, &wi) in point.directions.iter().enumerate() {
        let visibility = point.visibility.map_or(1.0, |v| v[j]);
        let cosine = dot(wi, n).max(0.0);
        let radiance = radiance_reference(point.radiance_sh, wi);
        let (f_d, f_s) = brdf_reference(
            n,
            point.view_dir,
            wi,
            point.albedo,
            point.metallic,
            point.roughness,
        );
        for (ch, out) in colour.iter_mut().enumerate() {
            let f = if shading.specular {
                f_d[ch] + f_s[ch]
            } else {
                f_d[ch]
            };
            *out += f * visibility * radiance[ch] * cosine * weight;
        }
    }
    colour
}
