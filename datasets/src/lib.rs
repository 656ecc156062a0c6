//! Scenes, cameras and poses in; loaders for public formats; the synthetic scene generator and
//! its mesh renderer.
//!
//! So far: the CPU mesh renderer ([`render`]), the synthetic scene generator ([`synth`], the
//! `synth` command), SMPL-layout pose sequences in the AMASS `.npz` layout ([`pose_sequence`]),
//! nerfstudio `transforms.json` ([`nerfstudio`]) and the PLY point clouds it names
//! ([`point_ply`]), public dataset formats ([`formats`]) and tiny datasets written in each
//! one's layout for tests ([`fixtures`]), OBJ and PNG writers ([`obj`], [`image_io`]), posing
//! a body model for inspection ([`posing`], the `pose-body` command) and binary-mask operations
//! for APF-GS's decoupling of accessories from the body ([`masks`]).

pub mod error;
pub mod files;
pub mod fixtures;
pub mod formats;
pub mod image_io;
pub mod masks;
pub mod nerfstudio;
pub mod obj;
pub mod openpose;
pub mod point_ply;
pub mod pose_sequence;
pub mod posing;
pub mod render;

pub use error::DatasetError;
pub mod synth;
