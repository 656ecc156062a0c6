//! The one error type of the datasets crate: every message names the file, and the field and
//! expected shape where there is one.

use std::path::Path;

#[derive(Debug, thiserror::Error)]
pub enum DatasetError {
    #[error("{file}: `{key}`: {problem}")]
    Field {
        file: String,
        key: String,
        problem: String,
    },
    #[error("{file}: {problem}")]
    File { file: String, problem: String },
    #[error(transparent)]
    Body(#[from] splatzoo_models::body::BodyModelError),
}

impl DatasetError {
    pub fn field(file: &Path, key: &str, problem: impl Into<String>) -> Self {
        Self::Field {
            file: file.display().to_string(),
            key: key.to_owned(),
            problem: problem.into(),
        }
    }

    pub fn file(file: &Path, problem: impl Into<String>) -> Self {
        Self::File {
            file: file.display().to_string(),
            problem: problem.into(),
        }
    }
}
