//! APF-GS's error type: the engine's errors and what only this method can fail with.

use splatzoo_train::TrainError;

#[derive(Debug, thiserror::Error)]
pub enum ApfError {
    #[error(transparent)]
    Train(#[from] TrainError),
    /// An input that cannot drive the method: what it is and what is wrong with it.
    #[error("{what}: {problem}")]
    Input { what: String, problem: String },
}

impl ApfError {
    pub(crate) fn input(what: impl Into<String>, problem: impl Into<String>) -> Self {
        ApfError::Input {
            what: what.into(),
            problem: problem.into(),
        }
    }
}

impl From<ApfError> for TrainError {
    fn from(e: ApfError) -> Self {
        match e {
            ApfError::Train(e) => e,
            other => TrainError::Method(Box::new(other)),
        }
    }
}
