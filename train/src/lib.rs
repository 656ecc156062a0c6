//! Training machinery shared by every `train-<method>` binary: Gaussian parameter sets and
//! their initialisation ([`gaussians`]), Adam ([`adam`]), the 3DGS per-group optimiser
//! ([`optimizer`]) and Adam over network parameters ([`module_adam`]), density control
//! ([`densify`]), image losses and metrics ([`loss`], [`lpips`]), NLF-GS's objective, data,
//! baseline, training loop and ONNX export ([`nlf_loss`], [`nlf_data`], [`nlf_baseline`],
//! [`nlf_trainer`], [`nlf_onnx`]), scene graphs ([`scene_graph`]), training data for static
//! scenes ([`views`]), the
//! static-scene loop ([`static_scene`]), checkpoints ([`checkpoint`]), configuration files
//! ([`config`]), backends ([`backend`]), run directories ([`run_dir`]), image outputs
//! ([`images`]) and INRIA-layout `.ply` files ([`ply`]).

pub mod adam;
pub mod backend;
pub mod checkpoint;
pub mod config;
pub mod densify;
pub mod gaussians;
pub mod images;
pub mod loss;
pub mod lpips;
pub mod module_adam;
pub mod nlf_baseline;
pub mod nlf_data;
pub mod nlf_loss;
pub mod nlf_onnx;
pub mod nlf_trainer;
pub mod optimizer;
pub mod ply;
pub mod run_dir;
pub mod scene_graph;
pub mod static_scene;
pub mod views;

use burn::tensor::Tensor;

/// A tensor's values on the host as `f32`, row-major.
pub fn host_f32<const D: usize>(tensor: &Tensor<D>) -> Vec<f32> {
    tensor
        .to_data()
        .convert::<f32>()
        .try_into_vec::<f32>()
        .expect("converted to f32")
}
