//! The scalar type the CPU kernels are generic over: `f32` for speed, `f64` for the
//! finite-difference gradient checks that hold the kernels to their derivatives.

use std::fmt::Debug;

/// A float the CPU kernels run in.
pub trait Real: num_traits::Float + Default + Debug + Send + Sync + 'static {
    /// Converts an `f64` constant (exact for `f64`, rounded for `f32`).
    fn of(value: f64) -> Self;
}

impl Real for f32 {
    fn of(value: f64) -> Self {
        value as f32
    }
}

impl Real for f64 {
    fn of(value: f64) -> Self {
        value
    }
}

/// A 3×3 matrix as rows.
pub type Mat3<T> = [[T; 3]; 3];

pub fn mat3_mul<T: Real>(a: &Mat3<T>, b: &Mat3<T>) -> Mat3<T> {
    let mut out = [[T::zero(); 3]; 3];
    for (i, row) in out.iter_mut().enumerate() {
        for (j, value) in row.iter_mut().enumerate() {
            *value = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
        }
    }
    out
}

pub fn mat3_transpose<T: Real>(a: &Mat3<T>) -> Mat3<T> {
    let mut out = [[T::zero(); 3]; 3];
    for (i, row) in out.iter_mut().enumerate() {
        for (j, value) in row.iter_mut().enumerate() {
            *value = a[j][i];
        }
    }
    out
}

pub fn mat3_vec<T: Real>(a: &Mat3<T>, v: [T; 3]) -> [T; 3] {
    [
        a[0][0] * v[0] + a[0][1] * v[1] + a[0][2] * v[2],
        a[1][0] * v[0] + a[1][1] * v[1] + a[1][2] * v[2],
        a[2][0] * v[0] + a[2][1] * v[1] + a[2][2] * v[2],
    ]
}

/// Logistic sigmoid, finite for any finite input.
pub fn sigmoid<T: Real>(x: T) -> T {
    if x >= T::zero() {
        T::one() / (T::one() + (-x).exp())
    } else {
        let e = x.exp();
        e / (T::one() + e)
    }
}
