//! `train-illum`: Illum's two stages on the synthetic lighting capture (the refined body, then
//! the PBR human lit by the light volume with the shadow decoder). See the crate's README.

use splatzoo_illum::method::Illum;
use std::process::ExitCode;

fn main() -> ExitCode {
    splatzoo_train::harness::cli::main::<Illum>()
}
