//! `train-prior4d`: the four stages of Prior-4D on the synthetic capture (scene prior, avatar
//! prior, initialisation, joint optimisation). See the crate's README.

use splatzoo_prior_4d::Prior4d;
use std::process::ExitCode;

fn main() -> ExitCode {
    splatzoo_train::harness::cli::main::<Prior4d>()
}
