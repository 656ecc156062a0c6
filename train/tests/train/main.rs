//! The training engine's integration tests, one binary: the train-3dgs and render commands,
//! losses, metrics, Adam and .ply files, training on every backend, and the skinned-Gaussian
//! node, the sweep, and the hash encoding's ONNX graph.

mod avatar;
mod capture_pieces;
mod captures;
mod commands;
mod extremes;
mod kl_density;
mod losses_and_ply;
mod modules;
mod onnx_hash;
mod skinned;
mod sweep;
mod training;
