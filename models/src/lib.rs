//! Shared blocks below the methods: body models and skinning, rotations, network blocks, mesh
//! utilities and file readers; none of it names a paper.
//!
//! - [`body`]: SMPL/SMPL-H/SMPL-X loaders and the built-in procedural body, forward kinematics
//!   and linear blend skinning, skeleton priors;
//! - [`rotation`] (Burn ops) and [`rotation_scalar`] (f64): axis-angle, matrices, quaternions,
//!   6-D;
//! - [`anchor`]: Gaussians anchored on mesh faces, face frames, subdivision, surface sampling;
//! - [`normals`]: differentiable area-weighted vertex normals and their f64 reference;
//! - [`closest_face`]: a point's nearest face of a mesh (barycentrics, distance), beside a
//!   brute-force loop;
//! - [`raycast`]: a triangle BVH for shadow and visibility rays, beside a brute-force loop;
//! - [`laplacian`]: the uniform mesh Laplacian and its smoothness energy;
//! - [`knn`]: exact k-nearest-neighbour queries over a point cloud (a bucket grid);
//! - [`networks`]: ResNet/FPN encoders, frequency and hash encodings, MLPs, safetensors weight
//!   files;
//! - [`pickle`] (Python pickles, joblib, numpy objects) and [`files`] (the one atomic writer).

pub mod anchor;
pub mod body;
pub mod closest_face;
pub mod files;
pub mod knn;
pub mod laplacian;
pub mod networks;
pub mod normals;
pub mod pickle;
pub mod raycast;
pub mod rotation;
pub mod rotation_scalar;
