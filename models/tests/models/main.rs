//! The models crate's integration tests, one binary: mesh anchors, the built-in body, linear
//! blend skinning, vertex normals, shared networks (ResNet, FPN, hash encoding, SD's VAE encoder, weight files),
//! body-model files (npz, pkl), the keypoint body fit, skeleton priors, rotations, nearest faces and ray casting.

mod anchor;
mod builtin;
mod closest_face;
mod common;
mod fit;
mod hash_grid;
mod knn;
mod lbs;
mod marks;
mod networks;
mod normals;
mod npz;
mod pkl;
mod priors;
mod raycast;
mod rotation;
mod vae;
