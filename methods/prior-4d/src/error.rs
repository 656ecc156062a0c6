//! Prior-4D's error type: the engine's errors and what only this method can fail with.

use splatzoo_train::TrainError;

#[derive(Debug, thiserror::Error)]
pub enum Prior4dError {
    #[error(transparent)]
    Train(#[from] TrainError),
    /// An input that cannot drive the method: what it is and what is wrong with it.
    #[error("{what}: {problem}")]
    Input { what: String, problem: String },
}

impl Prior4dError {
    pub(crate) fn input(what: impl Into<String>, problem: impl Into<String>) -> Self {
        Prior4dError::Input {
            what: what.into(),
            problem: problem.into(),
        }
    }
}

impl From<Prior4dError> for TrainError {
    fn from(e: Prior4dError) -> Self {
        match e {
            Prior4dError::Train(e) => e,
            other => TrainError::Method(Box::new(other)),
        }
    }
}
