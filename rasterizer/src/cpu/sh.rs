//! Real spherical harmonics up to degree 3 in the INRIA 3DGS basis and sign convention, and their
//! gradient with respect to the (unit) view direction.

use super::real::Real;

use crate::sh::{SH_C0 as C0, SH_C1 as C1, SH_C2 as C2, SH_C3 as C3};

pub use crate::sh::coeff_count;

/// Basis values `Y_k(d)` for `k < (degree + 1)²` at unit direction `d`, and, if `grad` is given,
/// their gradients `∂Y_k/∂d`.
pub fn basis<T: Real>(degree: u32, d: [T; 3], out: &mut [T; 16], grad: Option<&mut [[T; 3]; 16]>) {
    let c = T::of;
    let [x, y, z] = d;
    let zero = T::zero();
    *out = [zero; 16];
    out[0] = c(C0);
    let mut g = [[zero; 3]; 16];
    if degree >= 1 {
        out[1] = -c(C1) * y;
        out[2] = c(C1) * z;
        out[3] = -c(C1) * x;
        g[1] = [zero, -c(C1), zero];
        g[2] = [zero, zero, c(C1)];
        g[3] = [-c(C1), zero, zero];
    }
    if degree >= 2 {
        let (xx, yy, zz) = (x * x, y * y, z * z);
        out[4] = c(C2[0]) * x * y;
        out[5] = c(C2[1]) * y * z;
        out[6] = c(C2[2]) * (c(2.0) * zz - xx - yy);
        out[7] = c(C2[3]) * x * z;
        out[8] = c(C2[4]) * (xx - yy);
        g[4] = [c(C2[0]) * y, c(C2[0]) * x, zero];
        g[5] = [zero, c(C2[1]) * z, c(C2[1]) * y];
        g[6] = [c(-2.0 * C2[2]) * x, c(-2.0 * C2[2]) * y, c(4.0 * C2[2]) * z];
        g[7] = [c(C2[3]) * z, zero, c(C2[3]) * x];
        g[8] = [c(2.0 * C2[4]) * x, c(-2.0 * C2[4]) * y, zero];
    }
    if degree >= 3 {
        let (xx, yy, zz) = (x * x, y * y, z * z);
        out[9] = c(C3[0]) * y * (c(3.0) * xx - yy);
        out[10] = c(C3[1]) * x * y * z;
        out[11] = c(C3[2]) * y * (c(4.0) * zz - xx - yy);
        out[12] = c(C3[3]) * z * (c(2.0) * zz - c(3.0) * xx - c(3.0) * yy);
        out[13] = c(C3[4]) * x * (c(4.0) * zz - xx - yy);
        out[14] = c(C3[5]) * z * (xx - yy);
        out[15] = c(C3[6]) * x * (xx - c(3.0) * yy);
        g[9] = [c(6.0 * C3[0]) * x * y, c(3.0 * C3[0]) * (xx - yy), zero];
        g[10] = [c(C3[1]) * y * z, c(C3[1]) * x * z, c(C3[1]) * x * y];
        g[11] = [
            c(-2.0 * C3[2]) * x * y,
            c(C3[2]) * (c(4.0) * zz - xx - c(3.0) * yy),
            c(8.0 * C3[2]) * y * z,
        ];
        g[12] = [
            c(-6.0 * C3[3]) * x * z,
            c(-6.0 * C3[3]) * y * z,
            c(C3[3]) * (c(6.0) * zz - c(3.0) * xx - c(3.0) * yy),
        ];
        g[13] = [
            c(C3[4]) * (c(4.0) * zz - c(3.0) * xx - yy),
            c(-2.0 * C3[4]) * x * y,
            c(8.0 * C3[4]) * x * z,
        ];
        g[14] = [
            c(2.0 * C3[5]) * x * z,
            c(-2.0 * C3[5]) * y * z,
            c(C3[5]) * (xx - yy),
        ];
        g[15] = [c(3.0 * C3[6]) * (xx - yy), c(-6.0 * C3[6]) * x * y, zero];
    }
    if let Some(grad) = grad {
        *grad = g;
    }
}
