//! CubeCL kernels of the GPU rasterizer (wgpu, CUDA), launched by `crate::cube_backend`.
//!
//! They mirror the CPU kernels in `crate::cpu` step for step and share their data layouts (a
//! projected splat is a row of `8 + C` floats), so each can be tested against the other.

pub mod bin;
pub mod blend;
pub mod camera;
pub mod project;
pub mod scan;
