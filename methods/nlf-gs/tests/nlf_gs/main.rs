//! NLF-GS's integration tests, one binary: the feature query and fusion (Eq. 2–4), the
//! generator and driver, the objective (Eq. 5–7), the ONNX export, subjects from a real capture's
//! layout and the train-nlf and drive-nlf commands.

mod capture;
mod cli;
mod extremes;
mod loss;
mod network;
mod onnx;
mod query;
mod trainer;

/// A seed from the clock, so each run draws fresh random inputs (print it on failure).
pub fn fresh_seed() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .expect("the clock is past 1970")
        .as_nanos() as u64
}
