//! The body-model layer: a parametric body as data ([`BodyModel`]), its loaders, and
//! differentiable forward kinematics and linear blend skinning ([`lbs`]).

pub mod lbs;
pub mod model;
pub mod npz;
pub mod priors;
pub mod skeleton;

pub use lbs::{BodyTensors, PoseInput, Posed};
pub use model::{BodyKind, BodyModel, BodyModelError};
pub use npz::load_npz;
