//! The datasets crate's integration tests, one binary: public-format loaders on written
//! fixtures (and on the real releases' awkward parts, [`real_layouts`]; drivestudio's LiDAR,
//! [`drivestudio_lidar`]; COLMAP scenes and
//! nerfstudio's PLY points, [`colmap_scenes`]), the pose-body command,
//! pose sequences, the CPU mesh renderer, synthetic scenes and their export (the driving
//! preset's APF-GS measurements, [`driving`]), binary masks for APF-GS's decoupling
//! ([`masks`]), and OpenPose keypoint JSON ([`openpose`]).

mod colmap_scenes;
mod drivestudio_lidar;
mod driving;
mod fixtures;
mod formats;
mod masks;
mod openpose;
mod pose_body_cli;
mod pose_sequence;
mod real_layouts;
mod render;
mod scenes;
mod synth;
mod synth_export;
