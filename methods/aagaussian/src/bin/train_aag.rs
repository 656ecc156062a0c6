//! `train-aag`: an avatar by dual-branch score distillation on the embedded synthetic portrait
//! (guidance by the mixture oracle; see the crate README).

use std::process::ExitCode;

fn main() -> ExitCode {
    splatzoo_train::harness::cli::main::<splatzoo_aagaussian::Aag>()
}
