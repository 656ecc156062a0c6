//! `prior4d-write-neuman`: the synthetic capture's acting video written as a NeuMan scene folder
//! (images, person masks, COLMAP cameras and points, SMPL fits and alignments), to try
//! `train-prior4d`'s real-capture path (`data.capture`) without NeuMan's data. Every
//! `--test-every`-th frame goes into `test_split.txt`; `--with-priors` adds the external priors
//! NeuMan lacks (`splatzoo_prior_4d::data::given`).
//!
//! ```sh
//! cargo run --release --bin prior4d-write-neuman -- --out runs/neuman-synthetic
//! cargo run --release --bin train-prior4d -- --set data.capture=\"runs/neuman-synthetic\"
//! ```

use clap::Parser;
use splatzoo_prior_4d::config::Prior4dConfig;
use splatzoo_prior_4d::data::neuman::write_acting_as_neuman;
use splatzoo_train::TrainError;
use splatzoo_train::harness::MethodConfig;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Debug, Parser)]
#[command(about = "Writes the synthetic Prior-4D acting video as a NeuMan scene folder")]
struct Args {
    /// The folder to write.
    #[arg(long)]
    out: PathBuf,
    /// Every this many frames is listed in `test_split.txt` (held out by `train-prior4d`).
    #[arg(long, default_value_t = 8)]
    test_every: usize,
    /// Also the capture's noisy keypoints, normal maps, monocular depth and ground masks
    /// (`keypoints/`, `normals/`, `mono_depth/`, `ground/`), which NeuMan itself lacks.
    #[arg(long)]
    with_priors: bool,
    /// `key=value` overrides of the configuration whose `data` is rendered (as
    /// `train-prior4d --set`).
    #[arg(long = "set")]
    overrides: Vec<String>,
}

fn run(args: &Args) -> Result<(), TrainError> {
    let config: Prior4dConfig =
        splatzoo_train::config::load(&Prior4dConfig::default(), None, &args.overrides)?;
    config.validate()?;
    let capture = config.data.build(&config.backend.device())?;
    let every = args.test_every.max(2);
    let test: Vec<usize> = (0..capture.acting.len())
        .filter(|k| k % every == every - 1)
        .collect();
    write_acting_as_neuman(&capture, &args.out, &test, args.with_priors)?;
    println!(
        "wrote {}: {} frames ({} in test_split.txt), {} points",
        args.out.display(),
        capture.acting.len(),
        test.len(),
        capture.acting_points.len()
    );
    Ok(())
}

fn main() -> ExitCode {
    splatzoo_train::harness::cli::exit(run(&Args::parse()))
}
