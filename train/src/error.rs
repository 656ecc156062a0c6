//! The training engine's one error type: everything a trainer, a scene node or the CLI harness
//! can fail with, each variant naming the file, field or knob at fault.

use crate::checkpoint::CheckpointError;
use crate::config::ConfigError;
use crate::ply::PlyError;
use crate::views::DataError;
use splatzoo_datasets::DatasetError;
use splatzoo_models::body::BodyModelError;
use splatzoo_models::networks::weights::WeightsError;
use splatzoo_rasterizer::RasterError;

#[derive(Debug, thiserror::Error)]
pub enum TrainError {
    #[error(transparent)]
    Data(#[from] DataError),
    #[error(transparent)]
    Dataset(#[from] DatasetError),
    #[error(transparent)]
    Raster(#[from] RasterError),
    #[error(transparent)]
    Checkpoint(#[from] CheckpointError),
    #[error(transparent)]
    ConfigFile(#[from] ConfigError),
    #[error(transparent)]
    Ply(#[from] PlyError),
    #[error(transparent)]
    Weights(#[from] WeightsError),
    #[error(transparent)]
    Body(#[from] BodyModelError),
    #[error(transparent)]
    Onnx(#[from] crate::onnx::OnnxError),
    /// A knob out of its range: the key and what it must be.
    #[error("configuration: {0}")]
    Config(String),
    /// The loss (or a metric) stopped being finite: the step and the value.
    #[error("step {step}: the loss is {value}")]
    NonFinite { step: usize, value: f64 },
    /// An operating-system failure outside file writes (the Ctrl-C handler).
    #[error("{what}: {source}")]
    System {
        what: String,
        source: std::io::Error,
    },
    /// A method's own failure (its crate's error type).
    #[error(transparent)]
    Method(Box<dyn std::error::Error + Send + Sync>),
}
