//! The oracle: the same rasterizer written densely in plain Burn tensor ops (every splat against
//! every pixel, a global depth sort), differentiated by Burn's own autodiff.
//!
//! It is slow and memory-hungry (`N × H × W`), meant for tests at small sizes. It follows the
//! fast paths' conventions and cut-offs exactly (see the crate doc), except that it does not
//! cull: tests give it splats in front of the camera.

use crate::api::Splats;
use crate::camera::{ColorMode, RasterMode, RasterSettings};
use crate::cpu::{ALPHA_MAX, TRANSMITTANCE_MIN};
use burn::tensor::Tensor;

fn column(t: &Tensor<2>, j: usize) -> Tensor<1> {
    let n = t.dims()[0];
    t.clone().slice([0..n, j..j + 1]).reshape([n])
}

/// Renders `[H, W, C + 2]` (colour, alpha, accumulated depth) like [`crate::rasterize`]'s op.
pub fn render(splats: &Splats, background: Tensor<1>, settings: &RasterSettings) -> Tensor<3> {
    let cam = &settings.camera;
    let n = splats.len();
    let device = splats.means.device();
    let [_, k_stored, channels] = splats.colors.dims();
    let (h, w) = (cam.height as usize, cam.width as usize);
    let rot = cam.world_to_camera;

    // World → camera.
    let m: Vec<Tensor<1>> = (0..3).map(|j| column(&splats.means, j)).collect();
    let p: Vec<Tensor<1>> = (0..3)
        .map(|r| {
            m[0].clone() * rot[r][0]
                + m[1].clone() * rot[r][1]
                + m[2].clone() * rot[r][2]
                + rot[r][3]
        })
        .collect();
    let (x, y, z) = (p[0].clone(), p[1].clone(), p[2].clone());

    // Covariance Σ = R S Sᵀ Rᵀ from the normalised quaternion.
    let q_norm = splats.quats.clone().powi_scalar(2).sum_dim(1).sqrt();
    let q = splats.quats.clone() / q_norm;
    let (qw, qx, qy, qz) = (column(&q, 0), column(&q, 1), column(&q, 2), column(&q, 3));
    let r = [
        [
            (qy.clone() * qy.clone() + qz.clone() * qz.clone()) * -2.0 + 1.0,
            (qx.clone() * qy.clone() - qw.clone() * qz.clone()) * 2.0,
            (qx.clone() * qz.clone() + qw.clone() * qy.clone()) * 2.0,
        ],
        [
            (qx.clone() * qy.clone() + qw.clone() * qz.clone()) * 2.0,
            (qx.clone() * qx.clone() + qz.clone() * qz.clone()) * -2.0 + 1.0,
            (qy.clone() * qz.clone() - qw.clone() * qx.clone()) * 2.0,
        ],
        [
            (qx.clone() * qz.clone() - qw.clone() * qy.clone()) * 2.0,
            (qy.clone() * qz.clone() + qw.clone() * qx.clone()) * 2.0,
            (qx.clone() * qx.clone() + qy.clone() * qy.clone()) * -2.0 + 1.0,
        ],
    ];
    let s: Vec<Tensor<1>> = (0..3)
        .map(|j| column(&splats.log_scales, j).exp())
        .collect();
    let mm: Vec<Vec<Tensor<1>>> = (0..3)
        .map(|i| (0..3).map(|j| r[i][j].clone() * s[j].clone()).collect())
        .collect();
    let cov_world = |i: usize, j: usize| {
        mm[i][0].clone() * mm[j][0].clone()
            + mm[i][1].clone() * mm[j][1].clone()
            + mm[i][2].clone() * mm[j][2].clone()
    };
    let cw: Vec<Vec<Tensor<1>>> = (0..3)
        .map(|i| (0..3).map(|j| cov_world(i, j)).collect())
        .collect();
    let cov_cam = |i: usize, j: usize| {
        let mut acc = x.zeros_like();
        for a in 0..3 {
            for b in 0..3 {
                acc = acc + cw[a][b].clone() * (rot[i][a] * rot[j][b]);
            }
        }
        acc
    };
    let cc: Vec<Vec<Tensor<1>>> = (0..3)
        .map(|i| (0..3).map(|j| cov_cam(i, j)).collect())
        .collect();

    // EWA Jacobian with the 1.3× field-of-view clamp.
    let (wf, hf) = (w as f32, h as f32);
    let tan_x = 0.5 * wf / cam.fx;
    let tan_y = 0.5 * hf / cam.fy;
    let tx = (x.clone() / z.clone()).clamp(
        -(cam.cx / cam.fx + 0.3 * tan_x),
        (wf - cam.cx) / cam.fx + 0.3 * tan_x,
    ) * z.clone();
    let ty = (y.clone() / z.clone()).clamp(
        -(cam.cy / cam.fy + 0.3 * tan_y),
        (hf - cam.cy) / cam.fy + 0.3 * tan_y,
    ) * z.clone();
    let z2 = z.clone() * z.clone();
    let zero = x.zeros_like();
    let jac = [
        [
            z.clone().recip() * cam.fx,
            zero.clone(),
            tx / z2.clone() * -cam.fx,
        ],
        [zero, z.clone().recip() * cam.fy, ty / z2 * -cam.fy],
    ];
    let cov2 = |a: usize, b: usize| {
        let mut acc = x.zeros_like();
        for i in 0..3 {
            for j in 0..3 {
                acc = acc + jac[a][i].clone() * cc[i][j].clone() * jac[b][j].clone();
            }
        }
        acc
    };
    let (ca, cb, ccc) = (cov2(0, 0), cov2(0, 1), cov2(1, 1));
    let det_orig = ca.clone() * ccc.clone() - cb.clone() * cb.clone();
    let (a, c) = (ca + settings.eps2d, ccc + settings.eps2d);
    let det = a.clone() * c.clone() - cb.clone() * cb.clone();
    let conic = [c / det.clone(), cb.neg() / det.clone(), a / det.clone()];
    let compensation = match settings.mode {
        RasterMode::Classic => x.ones_like(),
        RasterMode::AntiAliased => (det_orig / det).clamp_min(0.0).sqrt(),
    };
    let opacity = burn::tensor::activation::sigmoid(splats.opacity_logits.clone()) * compensation;
    let u = x.clone() / z.clone() * cam.fx + cam.cx;
    let v = y / z.clone() * cam.fy + cam.cy;

    // Colour per splat, [N, C].
    let colors: Tensor<2> = match settings.color {
        ColorMode::Features => splats.colors.clone().reshape([n, channels]),
        ColorMode::Sh { degree } => {
            let pos = cam.position();
            let d: Vec<Tensor<1>> = (0..3).map(|j| m[j].clone() - pos[j]).collect();
            let len = (d[0].clone().powi_scalar(2)
                + d[1].clone().powi_scalar(2)
                + d[2].clone().powi_scalar(2))
            .sqrt();
            let basis = crate::sh::basis_columns(
                degree,
                &(d[0].clone() / len.clone()),
                &(d[1].clone() / len.clone()),
                &(d[2].clone() / len),
            );
            let mut acc = Tensor::<2>::zeros([n, channels], &device) + 0.5;
            for (k, b) in basis.into_iter().enumerate() {
                let coeff = splats
                    .colors
                    .clone()
                    .slice([0..n, k..k + 1, 0..channels])
                    .reshape([n, channels]);
                acc = acc + coeff * b.reshape([n, 1]);
            }
            let _ = k_stored;
            acc.clamp_min(0.0)
        }
    };

    // Every splat against every pixel centre: [N, P].
    let pixels = h * w;
    let px = Tensor::<1>::from_floats(
        (0..pixels)
            .map(|i| (i % w) as f32 + 0.5)
            .collect::<Vec<_>>()
            .as_slice(),
        &device,
    );
    let py = Tensor::<1>::from_floats(
        (0..pixels)
            .map(|i| (i / w) as f32 + 0.5)
            .collect::<Vec<_>>()
            .as_slice(),
        &device,
    );
    let dx = px.reshape([1, pixels]) - u.reshape([n, 1]);
    let dy = py.reshape([1, pixels]) - v.reshape([n, 1]);
    let [ka, kb, kc] = conic.map(|t| t.reshape([n, 1]));
    let sigma = (dx.clone() * dx.clone() * ka + dy.clone() * dy.clone() * kc) * 0.5 + dx * dy * kb;
    let clip = 0.5 * settings.clip_sigmas * settings.clip_sigmas;
    let inside = sigma.clone().greater_equal_elem(0.0).float()
        * sigma.clone().lower_equal_elem(clip).float();
    let alpha = (sigma.neg().exp() * opacity.reshape([n, 1])).clamp_max(ALPHA_MAX as f32);
    let alpha =
        alpha.clone() * inside * alpha.clone().greater_equal_elem(settings.alpha_min).float();

    // Global front-to-back order.
    let order = z.clone().argsort(0);
    let alpha = alpha.select(0, order.clone());
    let colors = colors.select(0, order.clone());
    let depth = z.select(0, order);

    // Transmittance by log-sum, with INRIA's early stop (monotone, so a mask suffices).
    let t_after = (alpha.clone().neg() + 1.0).log().cumsum(0).exp();
    let keep = t_after.greater_equal_elem(TRANSMITTANCE_MIN as f32).float();
    let alpha = alpha * keep;
    let log_keep = (alpha.clone().neg() + 1.0).log();
    let t_before = (log_keep.clone().cumsum(0) - log_keep.clone()).exp();
    let weights = alpha * t_before; // [N, P]
    let t_final = log_keep.sum_dim(0).exp(); // [1, P]

    let wt = weights.transpose(); // [P, N]
    let color = wt.clone().matmul(colors)
        + t_final
            .clone()
            .transpose()
            .matmul(background.reshape([1, channels]));
    let alpha_out = t_final.clone().transpose().neg() + 1.0;
    let depth_out = wt.matmul(depth.reshape([n, 1]));
    Tensor::cat(vec![color, alpha_out, depth_out], 1).reshape([h, w, channels + 2])
}
