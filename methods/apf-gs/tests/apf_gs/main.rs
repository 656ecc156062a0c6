//! APF-GS's integration tests, one binary: the gate and Eq. 4's algebra against scalar
//! formulas, the networks' initial state, Eq. 3's per-instance decoupling, Eq. 8's attachment,
//! the trainer end to end on a tiny driving scene (gradients, scene decisions, leakage-free
//! held-out frames, exact resume), `M_kine` refreshed from refined poses ([`refresh`]), and a
//! drivestudio scene on disk read and trained ([`disk`]).

mod accessory;
mod decouple;
mod disk;
mod extremes;
mod gate;
mod objective;
mod onnx;
mod refresh;
mod residual;
mod trainer;

/// A seed from the clock, so each run draws fresh random inputs (print it on failure).
pub fn fresh_seed() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .expect("the clock is past 1970")
        .as_nanos() as u64
}
