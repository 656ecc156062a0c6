//! `train-apf`: APF-GS on a driving scene (the synthetic `driving` preset by default).

use splatzoo_apf_gs::trainer::ApfTrainer;
use splatzoo_train::harness::cli;
use std::process::ExitCode;

fn main() -> ExitCode {
    cli::main::<ApfTrainer>()
}
