//! A differentiable, tile-based 3D Gaussian splatting rasterizer as one Burn backend op.
//!
//! [`rasterize`] renders a set of [`Splats`] (means, quaternions, log-scales, opacity logits and
//! SH or feature colours) from a pinhole [`Camera`] into colour, alpha and depth, and, under
//! autodiff, hands every input its gradient, so any Burn module upstream trains end to end.
//!
//! # Conventions (those of INRIA 3DGS and gsplat, so their `.ply` files render identically)
//! - Camera axes: OpenCV, +x right, +y down, +z forward; `world_to_camera` maps world points
//!   into that frame. Depth is camera-space z.
//! - Pixels: pixel `(i, j)` has its centre at `(i + 0.5, j + 0.5)`; a camera-space point projects
//!   to `(fx x/z + cx, fy y/z + cy)`.
//! - Quaternions are (w, x, y, z), normalised inside the op (zero means identity).
//! - Scales are natural logs of standard deviations; opacity is `sigmoid(logit)`.
//! - SH: the real basis and signs of INRIA 3DGS up to degree 3, coefficient 0 the DC term;
//!   colour = `max(Σ Y_k(d) c_k + 0.5, 0)` with `d` the unit vector from the camera centre to
//!   the splat's mean. The constants and the basis as differentiable Burn ops are public in
//!   [`sh`] (for colour evaluated outside the op, e.g. in a world frame under refined cameras).
//! - Footprint: EWA with the Jacobian clamped to 1.3× the field of view, dilated by
//!   `eps2d = 0.3` px² (classic) or low-pass filtered with opacity compensation (anti-aliased,
//!   Mip-Splatting / gsplat `antialiased`).
//! - Compositing: 16×16 tiles, per-tile depth order, `alpha = min(0.99, o·exp(-σ))`, contributions
//!   below `alpha_min` (1/255) skipped, a pixel stops before its transmittance would drop
//!   under 1e-4.
//! - One difference from INRIA: a splat reaches only pixels within `clip_sigmas` (3) standard
//!   deviations (Mahalanobis), rather than every pixel of every tile its bounding square
//!   touches; the image then does not depend on the tile size, and the reference can match it.
//!
//! # Non-finite and extreme inputs
//! Splats with a NaN or ±∞ in any parameter, behind the near plane or beyond the far plane,
//! with a footprint that overflows, or entirely off screen, are culled: radius 0, no
//! contribution, zero gradient. Camera, settings and background are validated up front.
//!
//! # Backends
//! - CPU: `NdArray` and `Flex` from one implementation ([`cpu`], rayon, tile rows in parallel,
//!   bit-for-bit deterministic).
//! - GPU: every CubeCL runtime (`Cube`: wgpu, and CUDA with the `cuda` feature) and Burn's
//!   default fused wgpu backend (`Fusion`), from the kernels in [`kernels`]: projection, tile
//!   histogram, prefix sums, intersection scatter, per-tile bitonic sort, blending forward and
//!   backward (per-tile shared-memory reductions, no float atomics), projection backward. One
//!   host read-back per call (the intersection count). At most 16 colour channels.
//! - `Autodiff` over any of them: the image is the tracked output; the backward is the op's own.
//!
//! The dense [`reference`](mod@reference) in plain Burn tensor ops is the oracle the tests hold the fast paths
//! to; the CPU kernels are also checked against f64 finite differences of themselves.

pub mod api;
pub mod autodiff;
pub mod backend;
pub mod camera;
pub mod cpu;
mod cpu_backend;
mod cube_backend;
pub mod error;
pub mod kernels;
pub mod reference;
pub mod sh;
pub mod testing;

pub use api::{Render, Splats, rasterize};
pub use camera::{Camera, ColorMode, RasterMode, RasterSettings};
pub use error::RasterError;
