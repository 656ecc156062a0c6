//! The synthetic scene generator: the embedded default data of every method, rendered with
//! full ground truth by the independent mesh renderer.
//!
//! - content: procedural identities ([`identity`]) and their clothing relief ([`clothing`]),
//!   motion ([`motion`]), accessories attached to joints ([`accessory`]), static surroundings
//!   ([`environment`], built from [`mesh`] boxes and quads);
//! - capture: camera rigs ([`rig`]), perturbed and corrupted body priors ([`prior`]), a LiDAR
//!   stand-in and coarse-mask variants ([`sensors`]), a 2-D keypoint detector stand-in
//!   ([`keypoints`]);
//! - assembly: a scene in memory and its per-view ground truth ([`scene`]), the presets each
//!   method trains on ([`preset`]), and writing a scene to disk ([`export`]).

pub mod accessory;
pub mod clothing;
pub mod environment;
pub mod export;
pub mod identity;
pub mod keypoints;
pub mod mesh;
pub mod motion;
pub mod preset;
pub mod prior;
pub mod rig;
pub mod rng;
pub mod scene;
pub mod sensors;

pub use preset::SceneConfig;
pub use scene::{Preset, Scene, ViewTruth};
