//! Per-splat projection and its backward on the GPU; the same mathematics as
//! `crate::cpu::project` (see there), one unit per splat.

use super::camera as cam;
use burn_cubecl::cubecl;
use cubecl::prelude::*;

/// Colour mode passed at compile time: SH degree `0..=3`, or this for free features.
pub const FEATURES: u32 = 99;

use crate::sh::{SH_C0, SH_C1, SH_C2, SH_C3};

// The shared constants (`crate::sh`) as f32 for the kernel.
const C0: f32 = SH_C0 as f32;
const C1: f32 = SH_C1 as f32;
const C2_0: f32 = SH_C2[0] as f32;
const C2_1: f32 = SH_C2[1] as f32;
const C2_2: f32 = SH_C2[2] as f32;
const C2_3: f32 = SH_C2[3] as f32;
const C2_4: f32 = SH_C2[4] as f32;
const C3_0: f32 = SH_C3[0] as f32;
const C3_1: f32 = SH_C3[1] as f32;
const C3_2: f32 = SH_C3[2] as f32;
const C3_3: f32 = SH_C3[3] as f32;
const C3_4: f32 = SH_C3[4] as f32;
const C3_5: f32 = SH_C3[5] as f32;
const C3_6: f32 = SH_C3[6] as f32;

#[cube]
fn bad(v: f32) -> bool {
    v.is_nan() || v.is_inf()
}

/// SH basis value `k` at unit direction (x, y, z).
#[cube]
fn sh_basis(k: usize, x: f32, y: f32, z: f32) -> f32 {
    let xx = x * x;
    let yy = y * y;
    let zz = z * z;
    let mut b = f32::new(C0);
    if k == 1 {
        b = -C1 * y;
    } else if k == 2 {
        b = C1 * z;
    } else if k == 3 {
        b = -C1 * x;
    } else if k == 4 {
        b = C2_0 * x * y;
    } else if k == 5 {
        b = C2_1 * y * z;
    } else if k == 6 {
        b = C2_2 * (2.0 * zz - xx - yy);
    } else if k == 7 {
        b = C2_3 * x * z;
    } else if k == 8 {
        b = C2_4 * (xx - yy);
    } else if k == 9 {
        b = C3_0 * y * (3.0 * xx - yy);
    } else if k == 10 {
        b = C3_1 * x * y * z;
    } else if k == 11 {
        b = C3_2 * y * (4.0 * zz - xx - yy);
    } else if k == 12 {
        b = C3_3 * z * (2.0 * zz - 3.0 * xx - 3.0 * yy);
    } else if k == 13 {
        b = C3_4 * x * (4.0 * zz - xx - yy);
    } else if k == 14 {
        b = C3_5 * z * (xx - yy);
    } else if k == 15 {
        b = C3_6 * x * (xx - 3.0 * yy);
    }
    b
}

/// Gradient of SH basis value `k` along axis `axis` (0 = x, 1 = y, 2 = z).
#[cube]
fn sh_basis_grad(k: usize, axis: usize, x: f32, y: f32, z: f32) -> f32 {
    let xx = x * x;
    let yy = y * y;
    let zz = z * z;
    let mut g = 0.0f32;
    if axis == 0 {
        if k == 3 {
            g = -C1;
        } else if k == 4 {
            g = C2_0 * y;
        } else if k == 6 {
            g = -2.0 * C2_2 * x;
        } else if k == 7 {
            g = C2_3 * z;
        } else if k == 8 {
            g = 2.0 * C2_4 * x;
        } else if k == 9 {
            g = 6.0 * C3_0 * x * y;
        } else if k == 10 {
            g = C3_1 * y * z;
        } else if k == 11 {
            g = -2.0 * C3_2 * x * y;
        } else if k == 12 {
            g = -6.0 * C3_3 * x * z;
        } else if k == 13 {
            g = C3_4 * (4.0 * zz - 3.0 * xx - yy);
        } else if k == 14 {
            g = 2.0 * C3_5 * x * z;
        } else if k == 15 {
            g = 3.0 * C3_6 * (xx - yy);
        }
    } else if axis == 1 {
        if k == 1 {
            g = -C1;
        } else if k == 4 {
            g = C2_0 * x;
        } else if k == 5 {
            g = C2_1 * z;
        } else if k == 6 {
            g = -2.0 * C2_2 * y;
        } else if k == 8 {
            g = -2.0 * C2_4 * y;
        } else if k == 9 {
            g = 3.0 * C3_0 * (xx - yy);
        } else if k == 10 {
            g = C3_1 * x * z;
        } else if k == 11 {
            g = C3_2 * (4.0 * zz - xx - 3.0 * yy);
        } else if k == 12 {
            g = -6.0 * C3_3 * y * z;
        } else if k == 13 {
            g = -2.0 * C3_4 * x * y;
        } else if k == 14 {
            g = -2.0 * C3_5 * y * z;
        } else if k == 15 {
            g = -6.0 * C3_6 * x * y;
        }
    } else {
        if k == 2 {
            g = C1;
        } else if k == 5 {
            g = C2_1 * y;
        } else if k == 6 {
            g = 4.0 * C2_2 * z;
        } else if k == 7 {
            g = C2_3 * x;
        } else if k == 10 {
            g = C3_1 * x * y;
        } else if k == 11 {
            g = 8.0 * C3_2 * y * z;
        } else if k == 12 {
            g = C3_3 * (6.0 * zz - 3.0 * xx - 3.0 * yy);
        } else if k == 13 {
            g = 8.0 * C3_4 * x * z;
        } else if k == 14 {
            g = C3_5 * (xx - yy);
        }
    }
    g
}

/// Everything one splat's projection computes, recomputed identically by the backward.
#[derive(CubeType, Clone, Copy)]
pub struct Geom {
    pub visible: bool,
    pub px: f32,
    pub py: f32,
    pub pz: f32,
    pub qw: f32,
    pub qx: f32,
    pub qy: f32,
    pub qz: f32,
    pub qnorm: f32,
    pub s0: f32,
    pub s1: f32,
    pub s2: f32,
    pub c00: f32,
    pub c01: f32,
    pub c02: f32,
    pub c11: f32,
    pub c12: f32,
    pub c22: f32,
    pub j00: f32,
    pub j02: f32,
    pub j11: f32,
    pub j12: f32,
    pub clamped_x: bool,
    pub clamped_y: bool,
    pub a: f32,
    pub b: f32,
    pub c: f32,
    pub det_orig: f32,
    pub comp: f32,
    pub k0: f32,
    pub k1: f32,
    pub k2: f32,
    pub radius: f32,
    pub u: f32,
    pub v: f32,
}

#[cube]
fn rot(camera: &[f32], r: usize, c: usize) -> f32 {
    camera[cam::ROT + 3 * r + c]
}

/// Projects splat `i` (culling as `crate::cpu::project::geometry`).
#[cube]
#[allow(clippy::too_many_arguments)]
pub fn geometry(
    means: &[f32],
    quats: &[f32],
    log_scales: &[f32],
    opacity_logits: &[f32],
    colors: &[f32],
    offsets: &[f32],
    camera: &[f32],
    i: usize,
    #[comptime] color_len: usize,
    #[comptime] antialiased: bool,
) -> Geom {
    let mx = means[3 * i];
    let my = means[3 * i + 1];
    let mz = means[3 * i + 2];
    let mut any_bad = bad(mx) || bad(my) || bad(mz) || bad(opacity_logits[i]);
    any_bad = any_bad || bad(offsets[2 * i]) || bad(offsets[2 * i + 1]);
    for k in 0..4usize {
        any_bad = any_bad || bad(quats[4 * i + k]);
    }
    for k in 0..3usize {
        any_bad = any_bad || bad(log_scales[3 * i + k]);
    }
    for k in 0..color_len {
        any_bad = any_bad || bad(colors[i * color_len + k]);
    }
    let px = rot(camera, 0, 0) * mx
        + rot(camera, 0, 1) * my
        + rot(camera, 0, 2) * mz
        + camera[cam::TRANS];
    let py = rot(camera, 1, 0) * mx
        + rot(camera, 1, 1) * my
        + rot(camera, 1, 2) * mz
        + camera[cam::TRANS + 1];
    let pz = rot(camera, 2, 0) * mx
        + rot(camera, 2, 1) * my
        + rot(camera, 2, 2) * mz
        + camera[cam::TRANS + 2];
    let mut visible = !any_bad && pz > camera[cam::NEAR] && pz <= camera[cam::FAR];

    // Normalised quaternion, overflow-safe; zero is the identity.
    let q0 = quats[4 * i];
    let q1 = quats[4 * i + 1];
    let q2 = quats[4 * i + 2];
    let q3 = quats[4 * i + 3];
    let m = q0.abs().max(q1.abs()).max(q2.abs().max(q3.abs()));
    let mut qw = 1.0f32;
    let mut qx = 0.0f32;
    let mut qy = 0.0f32;
    let mut qz = 0.0f32;
    let mut qnorm = 0.0f32;
    if m > 0.0 && !any_bad {
        let a0 = q0 / m;
        let a1 = q1 / m;
        let a2 = q2 / m;
        let a3 = q3 / m;
        let n = (a0 * a0 + a1 * a1 + a2 * a2 + a3 * a3).sqrt();
        qw = a0 / n;
        qx = a1 / n;
        qy = a2 / n;
        qz = a3 / n;
        qnorm = m * n;
    }
    let r00 = 1.0 - 2.0 * (qy * qy + qz * qz);
    let r01 = 2.0 * (qx * qy - qw * qz);
    let r02 = 2.0 * (qx * qz + qw * qy);
    let r10 = 2.0 * (qx * qy + qw * qz);
    let r11 = 1.0 - 2.0 * (qx * qx + qz * qz);
    let r12 = 2.0 * (qy * qz - qw * qx);
    let r20 = 2.0 * (qx * qz - qw * qy);
    let r21 = 2.0 * (qy * qz + qw * qx);
    let r22 = 1.0 - 2.0 * (qx * qx + qy * qy);
    let s0 = log_scales[3 * i].exp();
    let s1 = log_scales[3 * i + 1].exp();
    let s2 = log_scales[3 * i + 2].exp();
    // M = R diag(s); Σw = M Mᵀ.
    let m00 = r00 * s0;
    let m01 = r01 * s1;
    let m02 = r02 * s2;
    let m10 = r10 * s0;
    let m11 = r11 * s1;
    let m12 = r12 * s2;
    let m20 = r20 * s0;
    let m21 = r21 * s1;
    let m22 = r22 * s2;
    let w00 = m00 * m00 + m01 * m01 + m02 * m02;
    let w01 = m00 * m10 + m01 * m11 + m02 * m12;
    let w02 = m00 * m20 + m01 * m21 + m02 * m22;
    let w11 = m10 * m10 + m11 * m11 + m12 * m12;
    let w12 = m10 * m20 + m11 * m21 + m12 * m22;
    let w22 = m20 * m20 + m21 * m21 + m22 * m22;
    // T = W Σw, Σc = T Wᵀ.
    let t00 = rot(camera, 0, 0) * w00 + rot(camera, 0, 1) * w01 + rot(camera, 0, 2) * w02;
    let t01 = rot(camera, 0, 0) * w01 + rot(camera, 0, 1) * w11 + rot(camera, 0, 2) * w12;
    let t02 = rot(camera, 0, 0) * w02 + rot(camera, 0, 1) * w12 + rot(camera, 0, 2) * w22;
    let t10 = rot(camera, 1, 0) * w00 + rot(camera, 1, 1) * w01 + rot(camera, 1, 2) * w02;
    let t11 = rot(camera, 1, 0) * w01 + rot(camera, 1, 1) * w11 + rot(camera, 1, 2) * w12;
    let t12 = rot(camera, 1, 0) * w02 + rot(camera, 1, 1) * w12 + rot(camera, 1, 2) * w22;
    let t20 = rot(camera, 2, 0) * w00 + rot(camera, 2, 1) * w01 + rot(camera, 2, 2) * w02;
    let t21 = rot(camera, 2, 0) * w01 + rot(camera, 2, 1) * w11 + rot(camera, 2, 2) * w12;
    let t22 = rot(camera, 2, 0) * w02 + rot(camera, 2, 1) * w12 + rot(camera, 2, 2) * w22;
    let c00 = t00 * rot(camera, 0, 0) + t01 * rot(camera, 0, 1) + t02 * rot(camera, 0, 2);
    let c01 = t00 * rot(camera, 1, 0) + t01 * rot(camera, 1, 1) + t02 * rot(camera, 1, 2);
    let c02 = t00 * rot(camera, 2, 0) + t01 * rot(camera, 2, 1) + t02 * rot(camera, 2, 2);
    let c11 = t10 * rot(camera, 1, 0) + t11 * rot(camera, 1, 1) + t12 * rot(camera, 1, 2);
    let c12 = t10 * rot(camera, 2, 0) + t11 * rot(camera, 2, 1) + t12 * rot(camera, 2, 2);
    let c22 = t20 * rot(camera, 2, 0) + t21 * rot(camera, 2, 1) + t22 * rot(camera, 2, 2);

    let fx = camera[cam::FX];
    let fy = camera[cam::FY];
    let rx = px / pz;
    let ry = py / pz;
    let clamped_x = rx < -camera[cam::LIM_X_NEG] || rx > camera[cam::LIM_X_POS];
    let clamped_y = ry < -camera[cam::LIM_Y_NEG] || ry > camera[cam::LIM_Y_POS];
    let tx = pz * rx.max(-camera[cam::LIM_X_NEG]).min(camera[cam::LIM_X_POS]);
    let ty = pz * ry.max(-camera[cam::LIM_Y_NEG]).min(camera[cam::LIM_Y_POS]);
    let j00 = fx / pz;
    let j02 = -fx * tx / (pz * pz);
    let j11 = fy / pz;
    let j12 = -fy * ty / (pz * pz);
    let a = j00 * j00 * c00 + 2.0 * j00 * j02 * c02 + j02 * j02 * c22;
    let b = j00 * j11 * c01 + j00 * j12 * c02 + j02 * j11 * c12 + j02 * j12 * c22;
    let c = j11 * j11 * c11 + 2.0 * j11 * j12 * c12 + j12 * j12 * c22;
    let eps = camera[cam::EPS2D];
    let det_orig = a * c - b * b;
    let ad = a + eps;
    let cd = c + eps;
    let det = ad * cd - b * b;
    visible = visible && det > 0.0 && !bad(det);
    let mut comp = 1.0f32;
    if comptime!(antialiased) {
        comp = (det_orig / det).max(0.0).sqrt();
    }
    let k0 = cd / det;
    let k1 = -b / det;
    let k2 = ad / det;
    let mid = 0.5 * (ad + cd);
    let lambda = mid + (mid * mid - det).max(0.1).sqrt();
    let radius = (camera[cam::CLIP] * lambda.sqrt()).ceil();
    let u = fx * px / pz + camera[cam::CX] + offsets[2 * i];
    let v = fy * py / pz + camera[cam::CY] + offsets[2 * i + 1];
    visible = visible && radius > 0.0 && !bad(radius) && !bad(u) && !bad(v);
    visible = visible && !bad(k0) && !bad(k1) && !bad(k2);
    visible = visible
        && u + radius > 0.0
        && u - radius < camera[cam::WIDTH]
        && v + radius > 0.0
        && v - radius < camera[cam::HEIGHT];
    Geom {
        visible,
        px,
        py,
        pz,
        qw,
        qx,
        qy,
        qz,
        qnorm,
        s0,
        s1,
        s2,
        c00,
        c01,
        c02,
        c11,
        c12,
        c22,
        j00,
        j02,
        j11,
        j12,
        clamped_x,
        clamped_y,
        a,
        b,
        c,
        det_orig,
        comp,
        k0,
        k1,
        k2,
        radius,
        u,
        v,
    }
}

#[cube]
fn sigmoid(x: f32) -> f32 {
    // exp of a non-positive number only: no overflow for any logit.
    let e = (-x.abs()).exp();
    let s = 1.0 / (1.0 + e);
    select(x >= 0.0, s, e * s)
}

/// Tile rectangle bound `floor(v / 16)` clamped to `[0, n - 1]`.
#[cube]
pub fn tile_bound(v: f32, n: u32) -> u32 {
    let t = (v / 16.0).floor();
    let mut out = 0u32;
    if t > 0.0 {
        out = u32::cast_from(t.min(f32::cast_from(n - 1)));
    }
    out
}

/// Projects every splat into `projected` (`[N, 8 + C]`) and counts the tiles it touches.
#[cube(launch)]
#[allow(clippy::too_many_arguments)]
pub fn project_forward(
    means: &[f32],
    quats: &[f32],
    log_scales: &[f32],
    opacity_logits: &[f32],
    colors: &[f32],
    offsets: &[f32],
    camera: &[f32],
    projected: &mut [f32],
    tiles_touched: &mut [u32],
    n: u32,
    tiles_x: u32,
    tiles_y: u32,
    #[comptime] channels: usize,
    #[comptime] coeffs: usize,
    #[comptime] color_mode: u32,
    #[comptime] antialiased: bool,
) {
    let i = ABSOLUTE_POS;
    if i >= n as usize {
        terminate!();
    }
    let stride = 8 + channels;
    let base = i * stride;
    let g = geometry(
        means,
        quats,
        log_scales,
        opacity_logits,
        colors,
        offsets,
        camera,
        i,
        coeffs * channels,
        antialiased,
    );
    if !g.visible {
        for k in 0..stride {
            projected[base + k] = 0.0;
        }
        tiles_touched[i] = 0;
        terminate!();
    }
    projected[base] = g.u;
    projected[base + 1] = g.v;
    projected[base + 2] = g.k0;
    projected[base + 3] = g.k1;
    projected[base + 4] = g.k2;
    projected[base + 5] = g.pz;
    projected[base + 6] = sigmoid(opacity_logits[i]) * g.comp;
    projected[base + 7] = g.radius;
    let color_base = i * coeffs * channels;
    if comptime!(color_mode == FEATURES) {
        for ch in 0..channels {
            projected[base + 8 + ch] = colors[color_base + ch];
        }
    } else {
        let dx = means[3 * i] - camera[cam::POS];
        let dy = means[3 * i + 1] - camera[cam::POS + 1];
        let dz = means[3 * i + 2] - camera[cam::POS + 2];
        let len = (dx * dx + dy * dy + dz * dz).sqrt();
        let mut x = 0.0f32;
        let mut y = 0.0f32;
        let mut z = 1.0f32;
        if len > 0.0 {
            x = dx / len;
            y = dy / len;
            z = dz / len;
        }
        let used = comptime!(((color_mode + 1) * (color_mode + 1)) as usize);
        for ch in 0..channels {
            let mut sum = 0.5f32;
            for k in 0..used {
                sum += sh_basis(k, x, y, z) * colors[color_base + k * channels + ch];
            }
            projected[base + 8 + ch] = sum.max(0.0);
        }
    }
    let x0 = tile_bound(g.u - g.radius, tiles_x);
    let x1 = tile_bound(g.u + g.radius, tiles_x);
    let y0 = tile_bound(g.v - g.radius, tiles_y);
    let y1 = tile_bound(g.v + g.radius, tiles_y);
    tiles_touched[i] = (x1 - x0 + 1) * (y1 - y0 + 1);
}

/// `J[a][r]` of the EWA Jacobian `[[j00, 0, j02], [0, j11, j12]]`.
#[cube]
fn jac(g: &Geom, a: usize, r: usize) -> f32 {
    let mut v = 0.0f32;
    if a == 0 {
        if r == 0 {
            v = g.j00;
        } else if r == 2 {
            v = g.j02;
        }
    } else if r == 1 {
        v = g.j11;
    } else if r == 2 {
        v = g.j12;
    }
    v
}

/// Backward of `project_forward` given dL/d(projected rows); culled splats get zeros.
#[cube(launch)]
// The comptime condition stays a separate `if` so it is resolved when the kernel is expanded.
#[allow(clippy::too_many_arguments, clippy::collapsible_if)]
pub fn project_backward(
    means: &[f32],
    quats: &[f32],
    log_scales: &[f32],
    opacity_logits: &[f32],
    colors: &[f32],
    offsets: &[f32],
    camera: &[f32],
    grad_projected: &[f32],
    g_means: &mut [f32],
    g_quats: &mut [f32],
    g_scales: &mut [f32],
    g_opacity: &mut [f32],
    g_colors: &mut [f32],
    g_offsets: &mut [f32],
    n: u32,
    #[comptime] channels: usize,
    #[comptime] coeffs: usize,
    #[comptime] color_mode: u32,
    #[comptime] antialiased: bool,
) {
    let i = ABSOLUTE_POS;
    if i >= n as usize {
        terminate!();
    }
    let stride = comptime!(8 + channels);
    let color_len = comptime!(coeffs * channels);
    let gp = i * stride;
    for k in 0..3usize {
        g_means[3 * i + k] = 0.0;
        g_scales[3 * i + k] = 0.0;
    }
    for k in 0..4usize {
        g_quats[4 * i + k] = 0.0;
    }
    for k in 0..color_len {
        g_colors[i * color_len + k] = 0.0;
    }
    g_opacity[i] = 0.0;
    g_offsets[2 * i] = 0.0;
    g_offsets[2 * i + 1] = 0.0;
    let g = geometry(
        means,
        quats,
        log_scales,
        opacity_logits,
        colors,
        offsets,
        camera,
        i,
        color_len,
        antialiased,
    );
    if !g.visible {
        terminate!();
    }
    g_offsets[2 * i] = grad_projected[gp];
    g_offsets[2 * i + 1] = grad_projected[gp + 1];
    let mut gm0 = 0.0f32;
    let mut gm1 = 0.0f32;
    let mut gm2 = 0.0f32;

    // Colour.
    let color_base = i * color_len;
    if comptime!(color_mode == FEATURES) {
        for ch in 0..channels {
            g_colors[color_base + ch] = grad_projected[gp + 8 + ch];
        }
    } else {
        let dx = means[3 * i] - camera[cam::POS];
        let dy = means[3 * i + 1] - camera[cam::POS + 1];
        let dz = means[3 * i + 2] - camera[cam::POS + 2];
        let len = (dx * dx + dy * dy + dz * dz).sqrt();
        let mut x = 0.0f32;
        let mut y = 0.0f32;
        let mut z = 1.0f32;
        if len > 0.0 {
            x = dx / len;
            y = dy / len;
            z = dz / len;
        }
        let used = comptime!(((color_mode + 1) * (color_mode + 1)) as usize);
        let mut gd0 = 0.0f32;
        let mut gd1 = 0.0f32;
        let mut gd2 = 0.0f32;
        for ch in 0..channels {
            let mut raw = 0.5f32;
            for k in 0..used {
                raw += sh_basis(k, x, y, z) * colors[color_base + k * channels + ch];
            }
            if raw >= 0.0 {
                let gc = grad_projected[gp + 8 + ch];
                for k in 0..used {
                    g_colors[color_base + k * channels + ch] = sh_basis(k, x, y, z) * gc;
                    let wk = colors[color_base + k * channels + ch] * gc;
                    gd0 += sh_basis_grad(k, 0, x, y, z) * wk;
                    gd1 += sh_basis_grad(k, 1, x, y, z) * wk;
                    gd2 += sh_basis_grad(k, 2, x, y, z) * wk;
                }
            }
        }
        if len > 0.0 {
            let along = x * gd0 + y * gd1 + z * gd2;
            gm0 += (gd0 - x * along) / len;
            gm1 += (gd1 - y * along) / len;
            gm2 += (gd2 - z * along) / len;
        }
    }

    // Opacity.
    let s = sigmoid(opacity_logits[i]);
    let g_op = grad_projected[gp + 6];
    g_opacity[i] = g_op * g.comp * s * (1.0 - s);
    let g_comp = g_op * s;

    // Conic → dilated covariance: dL/dΣ = −K G K (full symmetric matrices).
    let ga = grad_projected[gp + 2];
    let gb = 0.5 * grad_projected[gp + 3];
    let gc = grad_projected[gp + 4];
    let kg00 = g.k0 * ga + g.k1 * gb;
    let kg01 = g.k0 * gb + g.k1 * gc;
    let kg10 = g.k1 * ga + g.k2 * gb;
    let kg11 = g.k1 * gb + g.k2 * gc;
    let mut g2 = Array::<f32>::new(4usize);
    g2[0] = -(kg00 * g.k0 + kg01 * g.k1);
    g2[1] = -(kg00 * g.k1 + kg01 * g.k2);
    g2[2] = -(kg10 * g.k0 + kg11 * g.k1);
    g2[3] = -(kg10 * g.k1 + kg11 * g.k2);
    if comptime!(antialiased) {
        if g.comp > 0.0 && g.det_orig > 0.0 {
            let scale = 0.5 * g.comp * g_comp;
            g2[0] += scale * (g.c / g.det_orig - g.k0);
            g2[1] += scale * (-g.b / g.det_orig - g.k1);
            g2[2] += scale * (-g.b / g.det_orig - g.k1);
            g2[3] += scale * (g.a / g.det_orig - g.k2);
        }
    }

    // Σ2 = J Σc Jᵀ.
    let mut cov = Array::<f32>::new(9usize);
    cov[0] = g.c00;
    cov[1] = g.c01;
    cov[2] = g.c02;
    cov[3] = g.c01;
    cov[4] = g.c11;
    cov[5] = g.c12;
    cov[6] = g.c02;
    cov[7] = g.c12;
    cov[8] = g.c22;
    let mut g_cov = Array::<f32>::new(9usize);
    for r in 0..3usize {
        for c in 0..3usize {
            let mut v = 0.0f32;
            for a in 0..2usize {
                for b in 0..2usize {
                    v += jac(&g, a, r) * g2[a * 2 + b] * jac(&g, b, c);
                }
            }
            g_cov[r * 3 + c] = v;
        }
    }
    let mut g_jac = Array::<f32>::new(6usize);
    for a in 0..2usize {
        for c in 0..3usize {
            let mut v = 0.0f32;
            for b in 0..2usize {
                for d in 0..3usize {
                    v += g2[a * 2 + b] * jac(&g, b, d) * cov[d * 3 + c];
                }
            }
            g_jac[a * 3 + c] = 2.0 * v;
        }
    }

    // Camera-space point.
    let fx = camera[cam::FX];
    let fy = camera[cam::FY];
    let z = g.pz;
    let z2 = z * z;
    let z3 = z2 * z;
    let tx = -g.j02 * z2 / fx;
    let ty = -g.j12 * z2 / fy;
    let g_tx = -fx / z2 * g_jac[2];
    let g_ty = -fy / z2 * g_jac[5];
    let mut gp0 = 0.0f32;
    let mut gp1 = 0.0f32;
    let mut gp2 = -fx / z2 * g_jac[0] + 2.0 * fx * tx / z3 * g_jac[2] - fy / z2 * g_jac[4]
        + 2.0 * fy * ty / z3 * g_jac[5];
    if g.clamped_x {
        gp2 += g_tx * tx / z;
    } else {
        gp0 += g_tx;
    }
    if g.clamped_y {
        gp2 += g_ty * ty / z;
    } else {
        gp1 += g_ty;
    }
    let gu = grad_projected[gp];
    let gv = grad_projected[gp + 1];
    gp0 += gu * fx / z;
    gp1 += gv * fy / z;
    gp2 += -gu * fx * g.px / z2 - gv * fy * g.py / z2 + grad_projected[gp + 5];

    // p_cam = W p + t.
    gm0 += rot(camera, 0, 0) * gp0 + rot(camera, 1, 0) * gp1 + rot(camera, 2, 0) * gp2;
    gm1 += rot(camera, 0, 1) * gp0 + rot(camera, 1, 1) * gp1 + rot(camera, 2, 1) * gp2;
    gm2 += rot(camera, 0, 2) * gp0 + rot(camera, 1, 2) * gp1 + rot(camera, 2, 2) * gp2;
    g_means[3 * i] = gm0;
    g_means[3 * i + 1] = gm1;
    g_means[3 * i + 2] = gm2;

    // Σc = W Σw Wᵀ → dL/dΣw = Wᵀ G W.
    let mut g_w = Array::<f32>::new(9usize);
    for r in 0..3usize {
        for c in 0..3usize {
            let mut v = 0.0f32;
            for a in 0..3usize {
                for b in 0..3usize {
                    v += rot(camera, a, r) * g_cov[a * 3 + b] * rot(camera, b, c);
                }
            }
            g_w[r * 3 + c] = v;
        }
    }
    // Σw = M Mᵀ, M = R(q) diag(s).
    let qw = g.qw;
    let qx = g.qx;
    let qy = g.qy;
    let qz = g.qz;
    let mut rq = Array::<f32>::new(9usize);
    rq[0] = 1.0 - 2.0 * (qy * qy + qz * qz);
    rq[1] = 2.0 * (qx * qy - qw * qz);
    rq[2] = 2.0 * (qx * qz + qw * qy);
    rq[3] = 2.0 * (qx * qy + qw * qz);
    rq[4] = 1.0 - 2.0 * (qx * qx + qz * qz);
    rq[5] = 2.0 * (qy * qz - qw * qx);
    rq[6] = 2.0 * (qx * qz - qw * qy);
    rq[7] = 2.0 * (qy * qz + qw * qx);
    rq[8] = 1.0 - 2.0 * (qx * qx + qy * qy);
    let mut sc = Array::<f32>::new(3usize);
    sc[0] = g.s0;
    sc[1] = g.s1;
    sc[2] = g.s2;
    let mut g_rot = Array::<f32>::new(9usize);
    let mut g_s = Array::<f32>::new(3usize);
    for c in 0..3usize {
        g_s[c] = 0.0;
    }
    for r in 0..3usize {
        for c in 0..3usize {
            // (G_w M)[r][c] with M[k][c] = R[k][c] s[c].
            let mut v = 0.0f32;
            for k in 0..3usize {
                v += g_w[r * 3 + k] * rq[k * 3 + c] * sc[c];
            }
            let gm_rc = 2.0 * v;
            g_rot[r * 3 + c] = gm_rc * sc[c];
            g_s[c] += gm_rc * rq[r * 3 + c];
        }
    }
    for c in 0..3usize {
        g_scales[3 * i + c] = g_s[c] * sc[c];
    }
    if g.qnorm > 0.0 {
        let gw = 2.0
            * (-qz * g_rot[1] + qy * g_rot[2] + qz * g_rot[3] - qx * g_rot[5] - qy * g_rot[6]
                + qx * g_rot[7]);
        let gx = 2.0
            * (qy * g_rot[1] + qz * g_rot[2] + qy * g_rot[3] - qw * g_rot[5]
                + qz * g_rot[6]
                + qw * g_rot[7])
            - 4.0 * qx * (g_rot[4] + g_rot[8]);
        let gy = 2.0
            * (qx * g_rot[1] + qw * g_rot[2] + qx * g_rot[3] + qz * g_rot[5] - qw * g_rot[6]
                + qz * g_rot[7])
            - 4.0 * qy * (g_rot[0] + g_rot[8]);
        let gz = 2.0
            * (-qw * g_rot[1]
                + qx * g_rot[2]
                + qw * g_rot[3]
                + qy * g_rot[5]
                + qx * g_rot[6]
                + qy * g_rot[7])
            - 4.0 * qz * (g_rot[0] + g_rot[4]);
        let along = qw * gw + qx * gx + qy * gy + qz * gz;
        g_quats[4 * i] = (gw - qw * along) / g.qnorm;
        g_quats[4 * i + 1] = (gx - qx * along) / g.qnorm;
        g_quats[4 * i + 2] = (gy - qy * along) / g.qnorm;
        g_quats[4 * i + 3] = (gz - qz * along) / g.qnorm;
    }
}
