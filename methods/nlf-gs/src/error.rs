//! NLF-GS's error type: the engine's errors and what only this method can fail with (its ONNX
//! export).

use splatzoo_train::TrainError;

#[derive(Debug, thiserror::Error)]
pub enum NlfError {
    #[error(transparent)]
    Train(#[from] TrainError),
    /// Exporting, writing or running an ONNX graph: the file and what went wrong.
    #[error("{file}: {problem}")]
    Onnx { file: String, problem: String },
    /// The exported graphs disagree with Burn on their own test vectors.
    #[error(
        "the exported ONNX graphs disagree with Burn: relative error {encoder:.1e} (encoder), \
         {decoder:.1e} (decoder), above 1e-3"
    )]
    OnnxMismatch { encoder: f64, decoder: f64 },
}

impl From<splatzoo_train::onnx::OnnxError> for NlfError {
    fn from(e: splatzoo_train::onnx::OnnxError) -> Self {
        NlfError::Onnx {
            file: e.file,
            problem: e.problem,
        }
    }
}

impl NlfError {
    pub(crate) fn onnx(file: &std::path::Path, problem: impl std::fmt::Display) -> Self {
        NlfError::Onnx {
            file: file.display().to_string(),
            problem: problem.to_string(),
        }
    }
}

impl From<NlfError> for TrainError {
    fn from(e: NlfError) -> Self {
        match e {
            NlfError::Train(e) => e,
            other => TrainError::Method(Box::new(other)),
        }
    }
}
