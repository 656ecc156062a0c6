//! Rotation representations as differentiable Burn ops, batched over the first dimension:
//! axis-angle `[N, 3]`, matrices `[N, 3, 3]` (row-major, acting on column vectors), unit
//! quaternions `[N, 4]` as (w, x, y, z), and the continuous 6-D representation `[N, 6]` (the
//! first two rows of the matrix, as PyTorch3D; Zhou et al., CVPR 2019).
//!
//! Every conversion is finite, with finite gradients, at angles 0, π and 2π: small angles use
//! Taylor expansions, matrix → quaternion picks the best-conditioned of Shepperd's four forms.

use burn::tensor::{Int, Tensor};

/// Angles below this use Taylor expansions.
const SMALL_ANGLE: f32 = 1e-4;

fn col(t: &Tensor<2>, j: usize) -> Tensor<1> {
    let n = t.dims()[0];
    t.clone().slice([0..n, j..j + 1]).reshape([n])
}

fn entry(m: &Tensor<3>, r: usize, c: usize) -> Tensor<1> {
    let n = m.dims()[0];
    m.clone().slice([0..n, r..r + 1, c..c + 1]).reshape([n])
}

/// `[N, 3, 3]` from nine `[N]` entries in row-major order.
fn from_entries(e: [Tensor<1>; 9]) -> Tensor<3> {
    let n = e[0].dims()[0];
    Tensor::stack::<2>(e.to_vec(), 1).reshape([n, 3, 3])
}

/// Rodrigues' formula on the unnormalised vector: `R = I + a K + b K²`, `K = [ω]×`,
/// `a = sin θ / θ`, `b = (1 − cos θ) / θ²`.
pub fn axis_angle_to_matrix(axis_angle: Tensor<2>) -> Tensor<3> {
    let (x, y, z) = (
        col(&axis_angle, 0),
        col(&axis_angle, 1),
        col(&axis_angle, 2),
    );
    let theta2 = x.clone().powi_scalar(2) + y.clone().powi_scalar(2) + z.clone().powi_scalar(2);
    let small = theta2.clone().lower_elem(SMALL_ANGLE * SMALL_ANGLE);
    let theta = theta2.clone().clamp_min(1e-16).sqrt();
    let a = (theta.clone().sin() / theta.clone())
        .mask_where(small.clone(), theta2.clone() * (-1.0 / 6.0) + 1.0);
    let b = ((theta.clone().cos().neg() + 1.0) / theta2.clone().clamp_min(1e-16))
        .mask_where(small, theta2 * (-1.0 / 24.0) + 0.5);
    // K² = ω ωᵀ − θ² I.
    let (xx, yy, zz) = (
        x.clone() * x.clone(),
        y.clone() * y.clone(),
        z.clone() * z.clone(),
    );
    let (xy, xz, yz) = (
        x.clone() * y.clone(),
        x.clone() * z.clone(),
        y.clone() * z.clone(),
    );
    let one = x.ones_like();
    from_entries([
        one.clone() - (yy.clone() + zz.clone()) * b.clone(),
        xy.clone() * b.clone() - z.clone() * a.clone(),
        xz.clone() * b.clone() + y.clone() * a.clone(),
        xy * b.clone() + z * a.clone(),
        one.clone() - (xx.clone() + zz) * b.clone(),
        yz.clone() * b.clone() - x.clone() * a.clone(),
        xz * b.clone() - y * a.clone(),
        yz * b.clone() + x * a,
        one - (xx + yy) * b,
    ])
}

/// Rotation matrix of a quaternion (normalised first; zero maps to identity).
pub fn quaternion_to_matrix(quaternion: Tensor<2>) -> Tensor<3> {
    let norm = quaternion.clone().powi_scalar(2).sum_dim(1).sqrt();
    let zero = norm.clone().lower_equal_elem(0.0);
    let identity = Tensor::<2>::from_floats([[1.0, 0.0, 0.0, 0.0]], &quaternion.device())
        .expand(quaternion.dims());
    let q = (quaternion / norm.clamp_min(1e-30)).mask_where(zero.expand(identity.dims()), identity);
    let (w, x, y, z) = (col(&q, 0), col(&q, 1), col(&q, 2), col(&q, 3));
    let two = |t: Tensor<1>| t * 2.0;
    let one = w.ones_like();
    from_entries([
        one.clone() - two(y.clone() * y.clone() + z.clone() * z.clone()),
        two(x.clone() * y.clone() - w.clone() * z.clone()),
        two(x.clone() * z.clone() + w.clone() * y.clone()),
        two(x.clone() * y.clone() + w.clone() * z.clone()),
        one.clone() - two(x.clone() * x.clone() + z.clone() * z.clone()),
        two(y.clone() * z.clone() - w.clone() * x.clone()),
        two(x.clone() * z.clone() - w.clone() * y.clone()),
        two(y.clone() * z.clone() + w.clone() * x.clone()),
        one - two(x.clone() * x + y.clone() * y),
    ])
}

/// Unit quaternion (w ≥ 0) of a rotation matrix, by the best-conditioned of Shepperd's forms.
pub fn matrix_to_quaternion(matrix: Tensor<3>) -> Tensor<2> {
    let n = matrix.dims()[0];
    let m = |r, c| entry(&matrix, r, c);
    let (m00, m11, m22) = (m(0, 0), m(1, 1), m(2, 2));
    // 4·(w², x², y², z²), one per form.
    let four_sq = [
        m00.clone() + m11.clone() + m22.clone() + 1.0,
        m00.clone() - m11.clone() - m22.clone() + 1.0,
        m11.clone() - m00.clone() - m22.clone() + 1.0,
        m22.clone() - m00.clone() - m11.clone() + 1.0,
    ];
    let (d21, d02, d10) = (m(2, 1) - m(1, 2), m(0, 2) - m(2, 0), m(1, 0) - m(0, 1));
    let (s10, s02, s21) = (m(1, 0) + m(0, 1), m(0, 2) + m(2, 0), m(2, 1) + m(1, 2));
    // Each form: [4w², …] rows scaled by 1 / (4 · its own large component).
    let forms = [
        [four_sq[0].clone(), d21.clone(), d02.clone(), d10.clone()],
        [d21, four_sq[1].clone(), s10.clone(), s02.clone()],
        [d02, s10, four_sq[2].clone(), s21.clone()],
        [d10, s02, s21, four_sq[3].clone()],
    ];
    let candidates: Vec<Tensor<2>> = forms
        .into_iter()
        .zip(&four_sq)
        .map(|(f, sq)| {
            let denom = sq.clone().clamp_min(0.01).sqrt() * 2.0;
            Tensor::stack::<2>(f.to_vec(), 1) / denom.reshape([n, 1])
        })
        .collect();
    let squares = Tensor::stack::<2>(four_sq.to_vec(), 1); // [N, 4]
    let best = squares.argmax(1); // [N, 1]
    let choice = best.equal(Tensor::<1, Int>::arange(0..4, &matrix.device()).reshape([1, 4]));
    let mut q = Tensor::<2>::zeros([n, 4], &matrix.device());
    for (k, candidate) in candidates.into_iter().enumerate() {
        let pick = choice.clone().slice([0..n, k..k + 1]).float();
        q = q + candidate * pick;
    }
    // Canonical sign w ≥ 0, unit length.
    let sign = col(&q, 0).sign().mask_fill(col(&q, 0).equal_elem(0.0), 1.0);
    let q = q * sign.reshape([n, 1]);
    let norm = q.clone().powi_scalar(2).sum_dim(1).sqrt();
    q / norm
}

/// Axis-angle of a unit quaternion: `θ = 2 atan2(|v|, w)`, angle in `[0, π]` after making
/// `w ≥ 0`.
pub fn quaternion_to_axis_angle(quaternion: Tensor<2>) -> Tensor<2> {
    let n = quaternion.dims()[0];
    let w0 = col(&quaternion, 0);
    let sign = w0
        .clone()
        .sign()
        .mask_fill(w0.equal_elem(0.0), 1.0)
        .reshape([n, 1]);
    let q = quaternion * sign;
    let w = col(&q, 0);
    let v = q.clone().slice([0..n, 1..4]);
    let vn2 = v.clone().powi_scalar(2).sum_dim(1).reshape([n]);
    let vn = vn2.clone().clamp_min(1e-24).sqrt();
    let small = vn2.clone().lower_elem(SMALL_ANGLE * SMALL_ANGLE);
    // θ / |v|, with the series 2/w (1 − |v|²/(3w²)) near the identity.
    let ratio = (vn.clone().atan2(w.clone()) * 2.0 / vn).mask_where(
        small,
        (vn2 / w.clone().powi_scalar(2).clamp_min(1e-12) * (-1.0 / 3.0) + 1.0) * 2.0
            / w.clamp_min(1e-6),
    );
    v * ratio.reshape([n, 1])
}

/// Unit quaternion of an axis-angle vector.
pub fn axis_angle_to_quaternion(axis_angle: Tensor<2>) -> Tensor<2> {
    let n = axis_angle.dims()[0];
    let theta2 = axis_angle.clone().powi_scalar(2).sum_dim(1).reshape([n]);
    let small = theta2.clone().lower_elem(SMALL_ANGLE * SMALL_ANGLE);
    let theta = theta2.clone().clamp_min(1e-16).sqrt();
    let half = theta.clone() * 0.5;
    let s = (half.clone().sin() / theta)
        .mask_where(small.clone(), theta2.clone() * (-1.0 / 48.0) + 0.5);
    let w = half.cos().mask_where(small, theta2 * (-1.0 / 8.0) + 1.0);
    Tensor::cat(vec![w.reshape([n, 1]), axis_angle * s.reshape([n, 1])], 1)
}

/// Axis-angle of a rotation matrix (angle in `[0, π]`).
pub fn matrix_to_axis_angle(matrix: Tensor<3>) -> Tensor<2> {
    quaternion_to_axis_angle(matrix_to_quaternion(matrix))
}

/// The 6-D representation: the first two rows of the matrix.
pub fn matrix_to_rotation_6d(matrix: Tensor<3>) -> Tensor<2> {
    let n = matrix.dims()[0];
    matrix.slice([0..n, 0..2, 0..3]).reshape([n, 6])
}

/// Gram–Schmidt of the two 3-vectors of a 6-D representation into a rotation matrix.
pub fn rotation_6d_to_matrix(r6: Tensor<2>) -> Tensor<3> {
    let n = r6.dims()[0];
    let a1 = r6.clone().slice([0..n, 0..3]);
    let a2 = r6.slice([0..n, 3..6]);
    let unit = |v: Tensor<2>| {
        let norm = v.clone().powi_scalar(2).sum_dim(1).sqrt().clamp_min(1e-12);
        v / norm
    };
    let b1 = unit(a1);
    let b2 = unit(a2.clone() - b1.clone() * (b1.clone() * a2).sum_dim(1));
    let (x1, y1, z1) = (col(&b1, 0), col(&b1, 1), col(&b1, 2));
    let (x2, y2, z2) = (col(&b2, 0), col(&b2, 1), col(&b2, 2));
    let b3 = Tensor::stack::<2>(
        vec![
            y1.clone() * z2.clone() - z1.clone() * y2.clone(),
            z1 * x2.clone() - x1.clone() * z2,
            x1 * y2 - y1 * x2,
        ],
        1,
    );
    Tensor::stack::<3>(vec![b1, b2, b3], 1)
}
