//! The rasterizer's integration tests, one binary: every backend against the dense reference
//! (values and gradients), CPU gradients against finite differences, determinism and camera
//! pose handling, numerical extremes, and the wgpu (CubeCL) kernels.

mod against_reference;
mod common;
mod cpu_gradients;
mod determinism_and_pose;
mod extremes;
mod gpu;
mod sh_basis;
