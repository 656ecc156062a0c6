//! The models crate's integration tests, one binary: mesh anchors, the built-in body, linear
//! blend skinning, vertex normals, shared networks (ResNet, FPN, weight files), body-model files (npz, pkl),
//! skeleton priors and rotations.

mod anchor;
mod builtin;
mod common;
mod lbs;
mod networks;
mod normals;
mod npz;
mod pkl;
mod priors;
mod rotation;
