//! The training engine's integration tests, one binary: the train-3dgs and render commands,
//! losses, metrics, Adam and .ply files, training on every backend, and the skinned-Gaussian
//! node, the sweep, the hash encoding's ONNX graph and the CLIP score.

mod avatar;
mod capture_pieces;
mod captures;
mod clip_score;
mod commands;
mod extremes;
mod kl_density;
mod losses_and_ply;
mod modules;
mod onnx_hash;
mod skinned;
mod sweep;
mod training;
