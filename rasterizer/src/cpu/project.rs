//! Per-splat projection (EWA splatting, Zwicker et al. 2001, as in INRIA 3DGS) and its exact
//! backward: world-space Gaussian → screen-space mean, conic, depth, opacity, colour, radius.

use super::real::{Mat3, Real, mat3_mul, mat3_transpose, mat3_vec, sigmoid};
use super::sh;
use super::{PROJ_COLOR, PROJ_CONIC, PROJ_DEPTH, PROJ_OPACITY, PROJ_RADIUS, Splats, proj_stride};
use crate::camera::{ColorMode, RasterMode, RasterSettings};
use rayon::prelude::*;

/// Camera quantities shared by every splat, in the kernel's precision.
struct CameraConsts<T> {
    rot: Mat3<T>,
    trans: [T; 3],
    position: [T; 3],
    fx: T,
    fy: T,
    cx: T,
    cy: T,
    width: T,
    height: T,
    near: T,
    far: T,
    lim_x: (T, T),
    lim_y: (T, T),
}

impl<T: Real> CameraConsts<T> {
    fn new(settings: &RasterSettings) -> Self {
        let cam = &settings.camera;
        let t = |v: f32| T::of(v as f64);
        let mut rot = [[T::zero(); 3]; 3];
        let mut trans = [T::zero(); 3];
        for r in 0..3 {
            for c in 0..3 {
                rot[r][c] = t(cam.world_to_camera[r][c]);
            }
            trans[r] = t(cam.world_to_camera[r][3]);
        }
        let pos = cam.position();
        let (w, h) = (cam.width as f64, cam.height as f64);
        // Off-screen splats use a Jacobian clamped to 1.3× the field of view (INRIA, gsplat).
        let tan_x = 0.5 * w / cam.fx as f64;
        let tan_y = 0.5 * h / cam.fy as f64;
        Self {
            rot,
            trans,
            position: [t(pos[0]), t(pos[1]), t(pos[2])],
            fx: t(cam.fx),
            fy: t(cam.fy),
            cx: t(cam.cx),
            cy: t(cam.cy),
            width: T::of(w),
            height: T::of(h),
            near: t(cam.near),
            far: t(cam.far),
            lim_x: (
                T::of(cam.cx as f64 / cam.fx as f64 + 0.3 * tan_x),
                T::of((w - cam.cx as f64) / cam.fx as f64 + 0.3 * tan_x),
            ),
            lim_y: (
                T::of(cam.cy as f64 / cam.fy as f64 + 0.3 * tan_y),
                T::of((h - cam.cy as f64) / cam.fy as f64 + 0.3 * tan_y),
            ),
        }
    }
}

/// Every intermediate of one splat's projection that the backward needs again.
struct Geometry<T> {
    p_cam: [T; 3],
    /// Normalised quaternion (w, x, y, z) and the norm it was divided by (0 for a zero quaternion).
    quat: [T; 4],
    quat_norm: T,
    rot: Mat3<T>,
    scale: [T; 3],
    cov_cam: Mat3<T>,
    jac: [[T; 3]; 2],
    clamped: (bool, bool),
    /// 2D covariance before dilation, as (a, b, c) of [[a, b], [b, c]].
    cov2: [T; 3],
    det_orig: T,
    compensation: T,
    conic: [T; 3],
    radius: T,
    mean2d: [T; 2],
}

/// Rotation matrix of a unit quaternion (w, x, y, z).
fn quat_to_rot<T: Real>(q: [T; 4]) -> Mat3<T> {
    let [w, x, y, z] = q;
    let two = T::of(2.0);
    let one = T::one();
    [
        [
            one - two * (y * y + z * z),
            two * (x * y - w * z),
            two * (x * z + w * y),
        ],
        [
            two * (x * y + w * z),
            one - two * (x * x + z * z),
            two * (y * z - w * x),
        ],
        [
            two * (x * z - w * y),
            two * (y * z + w * x),
            one - two * (x * x + y * y),
        ],
    ]
}

/// Gradient of `quat_to_rot` with respect to the unit quaternion.
fn quat_to_rot_backward<T: Real>(q: [T; 4], g: &Mat3<T>) -> [T; 4] {
    let [w, x, y, z] = q;
    let two = T::of(2.0);
    let four = T::of(4.0);
    let gw =
        two * (-z * g[0][1] + y * g[0][2] + z * g[1][0] - x * g[1][2] - y * g[2][0] + x * g[2][1]);
    let gx = two
        * (y * g[0][1] + z * g[0][2] + y * g[1][0] - w * g[1][2] + z * g[2][0] + w * g[2][1])
        - four * x * (g[1][1] + g[2][2]);
    let gy = two
        * (x * g[0][1] + w * g[0][2] + x * g[1][0] + z * g[1][2] - w * g[2][0] + z * g[2][1])
        - four * y * (g[0][0] + g[2][2]);
    let gz = two
        * (-w * g[0][1] + x * g[0][2] + w * g[1][0] + y * g[1][2] + x * g[2][0] + y * g[2][1])
        - four * z * (g[0][0] + g[1][1]);
    [gw, gx, gy, gz]
}

/// Normalises a quaternion without overflow for huge entries; zero maps to identity.
fn normalize_quat<T: Real>(q: [T; 4]) -> ([T; 4], T) {
    let m = q.iter().fold(T::zero(), |acc, v| acc.max(v.abs()));
    if m == T::zero() {
        return ([T::one(), T::zero(), T::zero(), T::zero()], T::zero());
    }
    let s = [q[0] / m, q[1] / m, q[2] / m, q[3] / m];
    let n = (s[0] * s[0] + s[1] * s[1] + s[2] * s[2] + s[3] * s[3]).sqrt();
    ([s[0] / n, s[1] / n, s[2] / n, s[3] / n], m * n)
}

fn all_finite<T: Real>(values: &[T]) -> bool {
    values.iter().all(|v| v.is_finite())
}

/// Projects splat `i`; `None` if it is culled (behind/near/far, degenerate, off screen or
/// holding a non-finite parameter).
fn geometry<T: Real>(
    splats: &Splats<T>,
    i: usize,
    cam: &CameraConsts<T>,
    settings: &RasterSettings,
) -> Option<Geometry<T>> {
    let mean = &splats.means[3 * i..3 * i + 3];
    let raw_quat = &splats.quats[4 * i..4 * i + 4];
    let log_scale = &splats.log_scales[3 * i..3 * i + 3];
    let offset = &splats.screen_offsets[2 * i..2 * i + 2];
    if !(all_finite(mean)
        && all_finite(raw_quat)
        && all_finite(log_scale)
        && all_finite(offset)
        && splats.opacity_logits[i].is_finite()
        && all_finite(splats.color_row(i)))
    {
        return None;
    }
    let p_cam = {
        let p = mat3_vec(&cam.rot, [mean[0], mean[1], mean[2]]);
        [
            p[0] + cam.trans[0],
            p[1] + cam.trans[1],
            p[2] + cam.trans[2],
        ]
    };
    let z = p_cam[2];
    if !(z > cam.near) || z > cam.far {
        return None;
    }
    let (quat, quat_norm) = normalize_quat([raw_quat[0], raw_quat[1], raw_quat[2], raw_quat[3]]);
    let rot = quat_to_rot(quat);
    let scale = [log_scale[0].exp(), log_scale[1].exp(), log_scale[2].exp()];
    let mut m = rot;
    for row in m.iter_mut() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = *v * scale[j];
        }
    }
    let cov_world = mat3_mul(&m, &mat3_transpose(&m));
    let cov_cam = mat3_mul(&mat3_mul(&cam.rot, &cov_world), &mat3_transpose(&cam.rot));

    let (x, y) = (p_cam[0], p_cam[1]);
    let rx = x / z;
    let ry = y / z;
    let clamped = (
        rx < -cam.lim_x.0 || rx > cam.lim_x.1,
        ry < -cam.lim_y.0 || ry > cam.lim_y.1,
    );
    let tx = z * rx.max(-cam.lim_x.0).min(cam.lim_x.1);
    let ty = z * ry.max(-cam.lim_y.0).min(cam.lim_y.1);
    let zero = T::zero();
    let jac = [
        [cam.fx / z, zero, -cam.fx * tx / (z * z)],
        [zero, cam.fy / z, -cam.fy * ty / (z * z)],
    ];
    let mut jc = [[zero; 3]; 2];
    for r in 0..2 {
        for c in 0..3 {
            jc[r][c] =
                jac[r][0] * cov_cam[0][c] + jac[r][1] * cov_cam[1][c] + jac[r][2] * cov_cam[2][c];
        }
    }
    let dot = |a: &[T; 3], b: &[T; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let cov2 = [
        dot(&jc[0], &jac[0]),
        dot(&jc[0], &jac[1]),
        dot(&jc[1], &jac[1]),
    ];
    let eps = T::of(settings.eps2d as f64);
    let det_orig = cov2[0] * cov2[2] - cov2[1] * cov2[1];
    let (a, b, c) = (cov2[0] + eps, cov2[1], cov2[2] + eps);
    let det = a * c - b * b;
    if !(det > zero) || !det.is_finite() {
        return None;
    }
    let compensation = match settings.mode {
        RasterMode::Classic => T::one(),
        RasterMode::AntiAliased => (det_orig / det).max(zero).sqrt(),
    };
    let conic = [c / det, -b / det, a / det];
    let mid = T::of(0.5) * (a + c);
    let lambda = mid + (mid * mid - det).max(T::of(0.1)).sqrt();
    let radius = (T::of(settings.clip_sigmas as f64) * lambda.sqrt()).ceil();
    let mean2d = [
        cam.fx * x / z + cam.cx + offset[0],
        cam.fy * y / z + cam.cy + offset[1],
    ];
    if !(radius > zero && radius.is_finite() && all_finite(&mean2d) && all_finite(&conic)) {
        return None;
    }
    if mean2d[0] + radius <= zero
        || mean2d[0] - radius >= cam.width
        || mean2d[1] + radius <= zero
        || mean2d[1] - radius >= cam.height
    {
        return None;
    }
    Some(Geometry {
        p_cam,
        quat,
        quat_norm,
        rot,
        scale,
        cov_cam,
        jac,
        clamped,
        cov2,
        det_orig,
        compensation,
        conic,
        radius,
        mean2d,
    })
}

/// Unit view direction from the camera centre to the splat, and the distance.
fn view_direction<T: Real>(mean: &[T], cam: &CameraConsts<T>) -> ([T; 3], T) {
    let v = [
        mean[0] - cam.position[0],
        mean[1] - cam.position[1],
        mean[2] - cam.position[2],
    ];
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if n > T::zero() {
        ([v[0] / n, v[1] / n, v[2] / n], n)
    } else {
        ([T::zero(), T::zero(), T::one()], T::zero())
    }
}

/// Projects every splat into rows of `proj_stride(C)` values (see the layout in `cpu`).
pub fn project<T: Real>(splats: &Splats<T>, settings: &RasterSettings) -> Vec<T> {
    let cam = CameraConsts::new(settings);
    let stride = proj_stride(splats.channels);
    let mut out = vec![T::zero(); splats.count * stride];
    out.par_chunks_mut(stride).enumerate().for_each(|(i, row)| {
        let Some(g) = geometry(splats, i, &cam, settings) else {
            return;
        };
        row[0] = g.mean2d[0];
        row[1] = g.mean2d[1];
        row[PROJ_CONIC..PROJ_CONIC + 3].copy_from_slice(&g.conic);
        row[PROJ_DEPTH] = g.p_cam[2];
        row[PROJ_OPACITY] = sigmoid(splats.opacity_logits[i]) * g.compensation;
        row[PROJ_RADIUS] = g.radius;
        let color = &mut row[PROJ_COLOR..];
        match settings.color {
            ColorMode::Features => color.copy_from_slice(splats.color_row(i)),
            ColorMode::Sh { degree } => {
                let (dir, _) = view_direction(&splats.means[3 * i..3 * i + 3], &cam);
                let mut basis = [T::zero(); 16];
                sh::basis(degree, dir, &mut basis, None);
                let coeffs = splats.color_row(i);
                for (ch, out) in color.iter_mut().enumerate() {
                    let mut sum = T::of(0.5);
                    for (k, b) in basis.iter().enumerate().take(sh::coeff_count(degree)) {
                        sum = sum + *b * coeffs[k * splats.channels + ch];
                    }
                    *out = sum.max(T::zero());
                }
            }
        }
    });
    out
}

/// Gradients of a loss with respect to every splat input.
#[derive(Debug, Clone)]
pub struct SplatGrads<T> {
    pub means: Vec<T>,
    pub quats: Vec<T>,
    pub log_scales: Vec<T>,
    pub opacity_logits: Vec<T>,
    pub colors: Vec<T>,
    pub screen_offsets: Vec<T>,
}

/// Backward of `project`: `grad_proj` holds dL/d(projected row) for every splat (the radius slot
/// is ignored). Culled splats get zero gradients.
pub fn project_backward<T: Real>(
    splats: &Splats<T>,
    settings: &RasterSettings,
    grad_proj: &[T],
) -> SplatGrads<T> {
    let cam = CameraConsts::new(settings);
    let n = splats.count;
    let channels = splats.channels;
    let stride = proj_stride(channels);
    let coeffs = splats.coeffs;
    let row_len = 3 + 4 + 3 + 1 + coeffs * channels + 2;
    let mut packed = vec![T::zero(); n * row_len];
    packed
        .par_chunks_mut(row_len)
        .enumerate()
        .for_each(|(i, out)| {
            let Some(g) = geometry(splats, i, &cam, settings) else {
                return;
            };
            let gp = &grad_proj[i * stride..(i + 1) * stride];
            let (o_means, rest) = out.split_at_mut(3);
            let (o_quats, rest) = rest.split_at_mut(4);
            let (o_scales, rest) = rest.split_at_mut(3);
            let (o_opacity, rest) = rest.split_at_mut(1);
            let (o_colors, o_offsets) = rest.split_at_mut(coeffs * channels);
            backward_one(
                splats, i, &cam, settings, &g, gp, o_means, o_quats, o_scales, o_opacity, o_colors,
                o_offsets,
            );
        });
    let mut grads = SplatGrads {
        means: vec![T::zero(); n * 3],
        quats: vec![T::zero(); n * 4],
        log_scales: vec![T::zero(); n * 3],
        opacity_logits: vec![T::zero(); n],
        colors: vec![T::zero(); n * coeffs * channels],
        screen_offsets: vec![T::zero(); n * 2],
    };
    let cc = coeffs * channels;
    for (i, row) in packed.chunks(row_len).enumerate() {
        grads.means[3 * i..3 * i + 3].copy_from_slice(&row[0..3]);
        grads.quats[4 * i..4 * i + 4].copy_from_slice(&row[3..7]);
        grads.log_scales[3 * i..3 * i + 3].copy_from_slice(&row[7..10]);
        grads.opacity_logits[i] = row[10];
        grads.colors[cc * i..cc * (i + 1)].copy_from_slice(&row[11..11 + cc]);
        grads.screen_offsets[2 * i..2 * i + 2].copy_from_slice(&row[11 + cc..13 + cc]);
    }
    grads
}

#[allow(clippy::too_many_arguments)]
fn backward_one<T: Real>(
    splats: &Splats<T>,
    i: usize,
    cam: &CameraConsts<T>,
    settings: &RasterSettings,
    g: &Geometry<T>,
    gp: &[T],
    o_means: &mut [T],
    o_quats: &mut [T],
    o_scales: &mut [T],
    o_opacity: &mut [T],
    o_colors: &mut [T],
    o_offsets: &mut [T],
) {
    let zero = T::zero();
    let half = T::of(0.5);
    let two = T::of(2.0);
    let channels = splats.channels;
    let mean = &splats.means[3 * i..3 * i + 3];
    let mut grad_mean = [zero; 3];

    // Screen offsets enter the 2D mean additively.
    o_offsets[0] = gp[0];
    o_offsets[1] = gp[1];

    // Colour.
    let gcol = &gp[PROJ_COLOR..PROJ_COLOR + channels];
    match settings.color {
        ColorMode::Features => o_colors.copy_from_slice(gcol),
        ColorMode::Sh { degree } => {
            let (dir, dist) = view_direction(mean, cam);
            let mut basis = [zero; 16];
            let mut dbasis = [[zero; 3]; 16];
            sh::basis(degree, dir, &mut basis, Some(&mut dbasis));
            let k_count = sh::coeff_count(degree);
            let coeffs = splats.color_row(i);
            let mut grad_dir = [zero; 3];
            for ch in 0..channels {
                let mut raw = half;
                for k in 0..k_count {
                    raw = raw + basis[k] * coeffs[k * channels + ch];
                }
                if raw < zero {
                    continue; // clamped at 0
                }
                let gc = gcol[ch];
                for k in 0..k_count {
                    o_colors[k * channels + ch] = basis[k] * gc;
                    let w = coeffs[k * channels + ch] * gc;
                    for a in 0..3 {
                        grad_dir[a] = grad_dir[a] + dbasis[k][a] * w;
                    }
                }
            }
            if dist > zero {
                let along = dir[0] * grad_dir[0] + dir[1] * grad_dir[1] + dir[2] * grad_dir[2];
                for a in 0..3 {
                    grad_mean[a] = grad_mean[a] + (grad_dir[a] - dir[a] * along) / dist;
                }
            }
        }
    }

    // Opacity: sigmoid(logit) · compensation.
    let s = sigmoid(splats.opacity_logits[i]);
    let g_opacity = gp[PROJ_OPACITY];
    o_opacity[0] = g_opacity * g.compensation * s * (T::one() - s);
    let g_comp = g_opacity * s;

    // Conic = inverse of the dilated covariance. Gradients below are w.r.t. the full symmetric
    // 2×2 matrices (each off-diagonal entry carries half of the conic's `b` gradient).
    let k = [[g.conic[0], g.conic[1]], [g.conic[1], g.conic[2]]];
    let gk = [
        [gp[PROJ_CONIC], half * gp[PROJ_CONIC + 1]],
        [half * gp[PROJ_CONIC + 1], gp[PROJ_CONIC + 2]],
    ];
    let kgk = mul2(&mul2(&k, &gk), &k);
    let mut g_cov2 = [[-kgk[0][0], -kgk[0][1]], [-kgk[1][0], -kgk[1][1]]];
    if settings.mode == RasterMode::AntiAliased && g.compensation > zero && g.det_orig > zero {
        // d sqrt(det Σ / det Σ') = ½ · comp · (Σ⁻¹ − Σ'⁻¹).
        let (a, b, c) = (g.cov2[0], g.cov2[1], g.cov2[2]);
        let inv_orig = [
            [c / g.det_orig, -b / g.det_orig],
            [-b / g.det_orig, a / g.det_orig],
        ];
        let scale = half * g.compensation * g_comp;
        for r in 0..2 {
            for col in 0..2 {
                g_cov2[r][col] = g_cov2[r][col] + scale * (inv_orig[r][col] - k[r][col]);
            }
        }
    }

    // cov2 = J Σc Jᵀ.
    let jac = &g.jac;
    let mut g_cov_cam = [[zero; 3]; 3];
    for r in 0..3 {
        for c in 0..3 {
            let mut v = zero;
            for a in 0..2 {
                for b in 0..2 {
                    v = v + jac[a][r] * g_cov2[a][b] * jac[b][c];
                }
            }
            g_cov_cam[r][c] = v;
        }
    }
    let mut g_jac = [[zero; 3]; 2];
    for a in 0..2 {
        for c in 0..3 {
            let mut v = zero;
            for b in 0..2 {
                for d in 0..3 {
                    v = v + g_cov2[a][b] * jac[b][d] * g.cov_cam[d][c];
                }
            }
            g_jac[a][c] = two * v;
        }
    }

    // Camera-space point: through J, the 2D mean and the depth.
    let [x, y, z] = g.p_cam;
    let z2 = z * z;
    let z3 = z2 * z;
    let tx = -jac[0][2] * z2 / cam.fx;
    let ty = -jac[1][2] * z2 / cam.fy;
    let g_tx = -cam.fx / z2 * g_jac[0][2];
    let g_ty = -cam.fy / z2 * g_jac[1][2];
    let mut g_p = [zero; 3];
    g_p[2] = -cam.fx / z2 * g_jac[0][0] + two * cam.fx * tx / z3 * g_jac[0][2]
        - cam.fy / z2 * g_jac[1][1]
        + two * cam.fy * ty / z3 * g_jac[1][2];
    if g.clamped.0 {
        g_p[2] = g_p[2] + g_tx * tx / z;
    } else {
        g_p[0] = g_p[0] + g_tx;
    }
    if g.clamped.1 {
        g_p[2] = g_p[2] + g_ty * ty / z;
    } else {
        g_p[1] = g_p[1] + g_ty;
    }
    let (gu, gv) = (gp[0], gp[1]);
    g_p[0] = g_p[0] + gu * cam.fx / z;
    g_p[1] = g_p[1] + gv * cam.fy / z;
    g_p[2] = g_p[2] - gu * cam.fx * x / z2 - gv * cam.fy * y / z2 + gp[PROJ_DEPTH];

    // p_cam = W p + t.
    let wt = mat3_transpose(&cam.rot);
    let gm = mat3_vec(&wt, g_p);
    for a in 0..3 {
        grad_mean[a] = grad_mean[a] + gm[a];
    }
    o_means.copy_from_slice(&grad_mean);

    // Σc = W Σw Wᵀ, Σw = M Mᵀ, M = R(q) diag(s).
    let g_cov_world = mat3_mul(&mat3_mul(&wt, &g_cov_cam), &cam.rot);
    let mut m = g.rot;
    for row in m.iter_mut() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = *v * g.scale[j];
        }
    }
    let g_m = mat3_mul(&g_cov_world, &m);
    let mut g_rot = [[zero; 3]; 3];
    let mut g_scale = [zero; 3];
    for r in 0..3 {
        for c in 0..3 {
            let gm_rc = two * g_m[r][c];
            g_rot[r][c] = gm_rc * g.scale[c];
            g_scale[c] = g_scale[c] + gm_rc * g.rot[r][c];
        }
    }
    for a in 0..3 {
        o_scales[a] = g_scale[a] * g.scale[a];
    }
    if g.quat_norm > zero {
        let gq = quat_to_rot_backward(g.quat, &g_rot);
        let q = g.quat;
        let along = q[0] * gq[0] + q[1] * gq[1] + q[2] * gq[2] + q[3] * gq[3];
        for a in 0..4 {
            o_quats[a] = (gq[a] - q[a] * along) / g.quat_norm;
        }
    }
}

fn mul2<T: Real>(a: &[[T; 2]; 2], b: &[[T; 2]; 2]) -> [[T; 2]; 2] {
    [
        [
            a[0][0] * b[0][0] + a[0][1] * b[1][0],
            a[0][0] * b[0][1] + a[0][1] * b[1][1],
        ],
        [
            a[1][0] * b[0][0] + a[1][1] * b[1][0],
            a[1][0] * b[0][1] + a[1][1] * b[1][1],
        ],
    ]
}
