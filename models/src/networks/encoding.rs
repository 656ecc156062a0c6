//! NeRF's frequency (positional) encoding, `γ(x) = [x, sin(2⁰πx), cos(2⁰πx), …,
//! sin(2^{L−1}πx), cos(2^{L−1}πx)]` per input column, as deformation fields condition on a
//! point or a time (DeformGS, OmniRe, APF-GS's Eq. 5). Burn ops ([`frequency_encoding`]) beside
//! the scalar f64 reference they are tested against ([`frequency_encoding_reference`]).

use burn::tensor::Tensor;
use std::f64::consts::PI;

/// Width of `γ(x)` for `dims` input columns and `levels` frequencies: `dims · (1 + 2 L)`.
pub fn encoded_width(dims: usize, levels: usize) -> usize {
    dims * (1 + 2 * levels)
}

/// `γ(x)` of `x` `[N, D]`: `[N, D (1 + 2 L)]`, the input first, then per level the sines of
/// every column, then their cosines.
pub fn frequency_encoding(x: Tensor<2>, levels: usize) -> Tensor<2> {
    let mut parts = Vec::with_capacity(1 + 2 * levels);
    parts.push(x.clone());
    for l in 0..levels {
        let scaled = x.clone() * (2f64.powi(l as i32) * PI);
        parts.push(scaled.clone().sin());
        parts.push(scaled.cos());
    }
    Tensor::cat(parts, 1)
}

/// The scalar reference of [`frequency_encoding`] for one row.
pub fn frequency_encoding_reference(x: &[f64], levels: usize) -> Vec<f64> {
    let mut out = x.to_vec();
    for l in 0..levels {
        let f = 2f64.powi(l as i32) * PI;
        out.extend(x.iter().map(|v| (f * v).sin()));
        out.extend(x.iter().map(|v| (f * v).cos()));
    }
    out
}
