//! AAGaussian's error type: the engine's errors and what only this method can fail with.

use splatzoo_train::TrainError;

#[derive(Debug, thiserror::Error)]
pub enum AagError {
    #[error(transparent)]
    Train(#[from] TrainError),
    /// An input that cannot drive the method: what it is and what is wrong with it.
    #[error("{what}: {problem}")]
    Input { what: String, problem: String },
}

impl AagError {
    pub(crate) fn input(what: impl Into<String>, problem: impl Into<String>) -> Self {
        AagError::Input {
            what: what.into(),
            problem: problem.into(),
        }
    }
}

impl From<AagError> for TrainError {
    fn from(e: AagError) -> Self {
        match e {
            AagError::Train(e) => e,
            other => TrainError::Method(Box::new(other)),
        }
    }
}

impl From<splatzoo_rasterizer::RasterError> for AagError {
    fn from(e: splatzoo_rasterizer::RasterError) -> Self {
        AagError::Train(e.into())
    }
}
