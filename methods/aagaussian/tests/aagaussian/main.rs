//! AAGaussian's integration tests, one binary: the noise schedule's constants, SDS under the
//! point-mass oracle against its closed form, v- and ε-prediction agreeing, the clipping, the
//! guidance forms' fixed points, the surrogate's gradient, the U9 binding, the animation of a
//! reference avatar, the ONNX guidance path against its Burn twin,
//! the Monte-Carlo moments of SDS under the mixture, and the trainer's schedule and resume,
//! the portrait's body fit, poses fitted to a synthetic video's keypoints, and
//! three steps on NdArray and wgpu against Flex, the extremes, a user's body model, and a
//! user's own photo.

mod backends;
mod binding;
mod common;
mod extremes;
mod face_crop;
mod guidance;
mod onnx;
mod photo;
mod sds;
mod trainer;
mod user_body;
mod video;
