//! AAGaussian's integration tests, one binary: the noise schedule's constants, SDS under the
//! point-mass oracle against its closed form, v- and ε-prediction agreeing, the clipping, the
//! guidance forms' fixed points, the surrogate's gradient, the U9 binding, the animation of a
//! reference avatar, and the ONNX guidance path against its Burn twin.

mod binding;
mod guidance;
mod onnx;
mod sds;
