//! Errors of the public rasterizer API: each names the input and what was expected.

/// Why a render could not be made.
#[derive(Debug, thiserror::Error)]
pub enum RasterError {
    #[error("camera: {0}")]
    Camera(String),
    #[error("settings: {0}")]
    Settings(String),
    #[error("input `{name}`: expected shape {expected}, got {got:?}")]
    Shape {
        name: &'static str,
        expected: String,
        got: Vec<usize>,
    },
    #[error("input `{name}`: {problem}")]
    Value { name: &'static str, problem: String },
}
