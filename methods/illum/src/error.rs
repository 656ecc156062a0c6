//! Illum's error type: what only this method can fail with, each naming the input and what is
//! wrong with it.

use splatzoo_rasterizer::RasterError;
use splatzoo_train::TrainError;

#[derive(Debug, thiserror::Error)]
pub enum IllumError {
    #[error(transparent)]
    Raster(#[from] RasterError),
    #[error(transparent)]
    Train(#[from] TrainError),
    /// An input that cannot drive the method: what it is and what is wrong with it.
    #[error("{what}: {problem}")]
    Input { what: String, problem: String },
}

impl IllumError {
    pub(crate) fn input(what: impl Into<String>, problem: impl Into<String>) -> Self {
        IllumError::Input {
            what: what.into(),
            problem: problem.into(),
        }
    }
}

impl From<IllumError> for TrainError {
    fn from(e: IllumError) -> Self {
        match e {
            IllumError::Train(e) => e,
            IllumError::Raster(e) => TrainError::Raster(e),
            other => TrainError::Method(Box::new(other)),
        }
    }
}
