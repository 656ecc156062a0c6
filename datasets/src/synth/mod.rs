//! The synthetic scene generator: the embedded default data of every method, rendered with
//! full ground truth by the independent mesh renderer.
//!
//! - content: procedural identities ([`identity`]), motion ([`motion`]), accessories rigidly
//!   attached to joints ([`accessory`]), static surroundings ([`environment`], built from
//!   [`mesh`] boxes and quads);
//! - capture: camera rigs ([`rig`]), perturbed body priors ([`prior`]);
//! - assembly: a scene in memory and its per-view ground truth ([`scene`]), the presets each
//!   method trains on ([`preset`]), and writing a scene to disk ([`export`]).

pub mod accessory;
pub mod environment;
pub mod export;
pub mod identity;
pub mod mesh;
pub mod motion;
pub mod preset;
pub mod prior;
pub mod rig;
pub mod rng;
pub mod scene;

pub use preset::SceneConfig;
pub use scene::{Preset, Scene, ViewTruth};
