//! `illum-write-neuman`: the synthetic lighting capture's video written as a NeuMan scene
//! folder (images, person masks, COLMAP cameras and points, depth maps, SMPL fits and
//! alignments, the held-out frames as `test_split.txt`) in a COLMAP world of `--scale` units a
//! metre, to try `train-illum`'s capture path (`data.capture`, [`splatzoo_illum::disk`])
//! without NeuMan's data.
//!
//! ```sh
//! cargo run --release --bin illum-write-neuman -- --out runs/illum-neuman
//! cargo run --release --bin train-illum -- --set data.capture=\"runs/illum-neuman\"
//! ```

use clap::Parser;
use splatzoo_illum::config::IllumConfig;
use splatzoo_illum::disk::write_as_neuman;
use splatzoo_train::TrainError;
use splatzoo_train::harness::MethodConfig;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Debug, Parser)]
#[command(about = "Writes the synthetic Illum capture's video as a NeuMan scene folder")]
struct Args {
    /// The folder to write.
    #[arg(long)]
    out: PathBuf,
    /// COLMAP units per metre of the written world (a reconstruction's unit is arbitrary).
    #[arg(long, default_value_t = 2.5)]
    scale: f64,
    /// `key=value` overrides of the configuration whose `data` is rendered (as
    /// `train-illum --set`).
    #[arg(long = "set")]
    overrides: Vec<String>,
}

fn run(args: &Args) -> Result<(), TrainError> {
    let config: IllumConfig =
        splatzoo_train::config::load(&IllumConfig::default(), None, &args.overrides)?;
    config.validate()?;
    let capture = config.data.build(&config.backend.device())?;
    write_as_neuman(&capture, &args.out, args.scale)?;
    println!(
        "wrote {}: {} frames ({} in test_split.txt), {} points, {} COLMAP units a metre",
        args.out.display(),
        capture.frames.len(),
        capture.test_frames().count(),
        capture.scene_points.len(),
        args.scale
    );
    Ok(())
}

fn main() -> ExitCode {
    splatzoo_train::harness::cli::exit(run(&Args::parse()))
}
