//! Scenes, cameras and poses in; loaders for public formats; the synthetic scene generator and
//! its mesh renderer.
//!
//! So far: the CPU mesh renderer ([`render`]), the synthetic scene generator ([`synth`], the
//! `synth` command), SMPL-layout pose sequences in the AMASS `.npz` layout ([`pose_sequence`]),
//! nerfstudio `transforms.json` ([`nerfstudio`]), OBJ and PNG writers ([`obj`], [`image_io`])
//! and posing a body model for inspection ([`posing`], the `pose-body` command).

pub mod error;
pub mod files;
pub mod formats;
pub mod image_io;
pub mod nerfstudio;
pub mod obj;
pub mod pose_sequence;
pub mod posing;
pub mod render;

pub use error::DatasetError;
pub mod synth;
