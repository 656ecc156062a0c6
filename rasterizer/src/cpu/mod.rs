//! The CPU rasterizer: plain Rust, multi-threaded with rayon, generic over `f32`/`f64`.
//!
//! Pipeline: `project` (per splat) → `bin` (tile lists sorted by depth) → `blend` (per pixel,
//! front to back, early termination) and back again for gradients. Each tile row of the image is
//! one rayon task; gradients are written per (tile, splat) intersection and reduced in a fixed
//! order, so results are bit-for-bit deterministic whatever the thread count.
//!
//! A projected splat is a row of `8 + C` values:
//! `[x, y, conic_a, conic_b, conic_c, depth, opacity, radius, colour_0 .. colour_C]`, with the
//! conic `[[a, b], [b, c]]` the inverse of the dilated 2D covariance and `radius` 0 when culled.

// Negated comparisons are deliberate: they reject NaN. Index loops mirror the matrix algebra.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::needless_range_loop)]

pub mod bin;
pub mod blend;
pub mod project;
pub mod real;
pub mod sh;

use crate::camera::RasterSettings;
pub use project::SplatGrads;
pub use real::Real;

/// Tile side in pixels.
pub const TILE: usize = 16;
/// Opacity clamp of a single contribution (INRIA 3DGS).
pub const ALPHA_MAX: f64 = 0.99;
/// A pixel stops once its transmittance would fall below this (INRIA 3DGS).
pub const TRANSMITTANCE_MIN: f64 = 1e-4;

pub const PROJ_CONIC: usize = 2;
pub const PROJ_DEPTH: usize = 5;
pub const PROJ_OPACITY: usize = 6;
pub const PROJ_RADIUS: usize = 7;
pub const PROJ_COLOR: usize = 8;

/// Values per projected splat for `channels` colour channels.
pub const fn proj_stride(channels: usize) -> usize {
    PROJ_COLOR + channels
}

/// Borrowed splat parameters, flattened row-major.
#[derive(Clone, Copy)]
pub struct Splats<'a, T> {
    pub count: usize,
    /// Colour coefficients per splat (`K`): `(degree + 1)²` for SH, 1 for features.
    pub coeffs: usize,
    /// Colour channels (`C`).
    pub channels: usize,
    pub means: &'a [T],
    pub quats: &'a [T],
    pub log_scales: &'a [T],
    pub opacity_logits: &'a [T],
    /// `[N, K, C]`.
    pub colors: &'a [T],
    /// `[N, 2]` added to the projected means; their gradient is dL/d(screen position).
    pub screen_offsets: &'a [T],
}

impl<'a, T> Splats<'a, T> {
    pub fn color_row(&self, i: usize) -> &'a [T] {
        let n = self.coeffs * self.channels;
        &self.colors[i * n..(i + 1) * n]
    }

    /// Panics with the offending field if a slice has the wrong length (internal invariant: the
    /// public API checks shapes before calling in).
    pub fn assert_shapes(&self) {
        let n = self.count;
        assert_eq!(self.means.len(), n * 3, "means");
        assert_eq!(self.quats.len(), n * 4, "quats");
        assert_eq!(self.log_scales.len(), n * 3, "log_scales");
        assert_eq!(self.opacity_logits.len(), n, "opacity_logits");
        assert_eq!(self.colors.len(), n * self.coeffs * self.channels, "colors");
        assert_eq!(self.screen_offsets.len(), n * 2, "screen_offsets");
    }
}

/// A forward pass: the image and the state its backward reuses.
pub struct Forward<T> {
    /// `[H, W, C + 2]`: colour, alpha, accumulated depth.
    pub image: Vec<T>,
    /// `[N, 8 + C]` projected splats.
    pub projected: Vec<T>,
    pub final_transmittance: Vec<T>,
    pub contributors: Vec<u32>,
}

/// Renders `splats` over `background` (`C` values).
pub fn forward<T: Real>(
    splats: &Splats<T>,
    background: &[T],
    settings: &RasterSettings,
) -> Forward<T> {
    splats.assert_shapes();
    let projected = project::project(splats, settings);
    let stride = proj_stride(splats.channels);
    let bins = bin::bin(
        &projected,
        stride,
        settings.camera.width as usize,
        settings.camera.height as usize,
    );
    let blended = blend::blend_forward(&projected, splats.channels, &bins, background, settings);
    Forward {
        image: blended.image,
        projected,
        final_transmittance: blended.final_transmittance,
        contributors: blended.contributors,
    }
}

/// Gradients of every input of `forward`.
pub struct Grads<T> {
    pub splats: SplatGrads<T>,
    pub background: Vec<T>,
}

/// Backward of `forward` given dL/d(image) `[H, W, C + 2]`. Binning is recomputed from
/// `projected` (cheaper than storing it, and it keeps the saved state a fixed size).
pub fn backward<T: Real>(
    splats: &Splats<T>,
    background: &[T],
    settings: &RasterSettings,
    projected: &[T],
    final_transmittance: &[T],
    contributors: &[u32],
    grad_image: &[T],
) -> Grads<T> {
    splats.assert_shapes();
    let stride = proj_stride(splats.channels);
    let bins = bin::bin(
        projected,
        stride,
        settings.camera.width as usize,
        settings.camera.height as usize,
    );
    let (grad_proj, grad_bg) = blend::blend_backward(
        projected,
        splats.channels,
        &bins,
        background,
        settings,
        final_transmittance,
        contributors,
        grad_image,
    );
    Grads {
        splats: project::project_backward(splats, settings, &grad_proj),
        background: grad_bg,
    }
}
