//! The body-model layer: a parametric body as data ([`BodyModel`]), its loaders, and
//! differentiable forward kinematics and linear blend skinning ([`lbs`]).

pub mod builtin;
pub mod fit;
pub mod lbs;
pub mod marks;
pub mod model;
pub mod npz;
pub mod pkl;
pub mod priors;
pub mod skeleton;

pub use builtin::{BuiltinBody, builtin_body};
pub use lbs::{BodyTensors, PoseInput, Posed};
pub use marks::SurfaceMarks;
pub use model::{BodyKind, BodyModel, BodyModelError, FaceLandmark};
pub use npz::{load_npz, save_npz};
pub use pkl::load_pkl;

use std::path::Path;

/// Loads a body model from `.npz` or `.pkl` by the file's extension.
pub fn load_body_model(path: &Path) -> Result<BodyModel, BodyModelError> {
    match path.extension().and_then(|e| e.to_str()) {
        Some("pkl") => load_pkl(path),
        Some("npz") => load_npz(path),
        _ => Err(BodyModelError::File {
            file: path.display().to_string(),
            problem: "expected a .npz or .pkl body model".into(),
        }),
    }
}
