//! The training engine's integration tests, one binary: the train-3dgs and render commands,
//! losses, metrics, Adam and .ply files, and training on every backend.

mod commands;
mod losses_and_ply;
mod training;
