//! The training engine every method builds on; it names no paper.
//!
//! - Contracts: the [`harness::Method`] trait and the one command line every `train-<method>`
//!   binary runs ([`harness::cli`]); the scene graph and its nodes' lifecycle ([`scene`]).
//! - Parameters and optimisers: Gaussian sets and their initialisation ([`gaussians`]), Adam
//!   ([`adam`]), the 3DGS per-group optimiser ([`optimizer`]), Adam over network parameters by
//!   path ([`module_adam`]), density control and its strategies ([`densify`]).
//! - Objectives and metrics: image losses, plain and masked, and PSNR ([`loss`]), LPIPS
//!   ([`lpips`]), the CLIP score of renders against a prompt ([`clip_score`]).
//! - Data and files: training views of static scenes ([`views`]), checkpoints
//!   ([`checkpoint`]), configuration files ([`config`]), backends ([`backend`]), run
//!   directories ([`run_dir`]), image outputs ([`images`]), INRIA-layout `.ply` ([`ply`]),
//!   ONNX graphs checked in tract ([`onnx`]).
//! - Animatable avatars from video on the skinned node ([`avatar`]; the `train-avatar` binary).
//! - Static-scene 3D Gaussian splatting, the scene-prior stage the methods reuse
//!   ([`static_scene`]; the `train-3dgs` and `render` binaries).
//!
//! - The speed/accuracy sweep over any `train-<method>` binary, with Pareto figures ([`sweep`];
//!   the `sweep` binary).
//!
//! Errors: [`TrainError`].

pub mod adam;
pub mod avatar;
pub mod backend;
pub mod checkpoint;
pub mod clip_score;
pub mod config;
pub mod densify;
mod error;
pub mod gaussians;
pub mod harness;
pub mod images;
pub mod loss;
pub mod lpips;
pub mod module_adam;
pub mod onnx;
pub mod optimizer;
pub mod ply;
pub mod run_dir;
pub mod scene;
pub mod static_scene;
pub mod sweep;
pub mod views;

pub use error::TrainError;

use burn::tensor::Tensor;

/// A tensor's values on the host as `f32`, row-major.
pub fn host_f32<const D: usize>(tensor: &Tensor<D>) -> Vec<f32> {
    tensor
        .to_data()
        .convert::<f32>()
        .try_into_vec::<f32>()
        .expect("converted to f32")
}
