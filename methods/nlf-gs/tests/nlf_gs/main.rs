//! NLF-GS's integration tests, one binary: the feature query and fusion (Eq. 2–4), the
//! generator and driver, the objective (Eq. 5–7), the ONNX export and the train-nlf and
//! drive-nlf commands.

mod cli;
mod loss;
mod network;
mod onnx;
mod query;
mod trainer;
