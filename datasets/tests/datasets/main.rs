//! The datasets crate's integration tests, one binary: public-format loaders on written
//! fixtures (and on the real releases' awkward parts, [`real_layouts`]; COLMAP scenes and
//! nerfstudio's PLY points, [`colmap_scenes`]), the pose-body command,
//! pose sequences, the CPU mesh renderer, synthetic scenes and their export.

mod colmap_scenes;
mod fixtures;
mod formats;
mod pose_body_cli;
mod pose_sequence;
mod real_layouts;
mod render;
mod scenes;
mod synth;
mod synth_export;
