//! `sweep`: runs a method's sweep file and writes its table and Pareto figures (see
//! `splatzoo_train::sweep`).

use clap::Parser;
use splatzoo_train::TrainError;
use splatzoo_train::harness::cli::exit;
use splatzoo_train::sweep::{self, SweepOptions, SweepSpec, Trainer};
use std::path::PathBuf;
use std::process::ExitCode;

/// Measures a method's speed/accuracy trade: every point of a sweep file (a grid or list of
/// `--set` overrides) trained by `train-<method>` with the same data and evaluation, then
/// `sweep.csv`, `sweep.json` and the Pareto fronts (quality against training time and render
/// FPS) as PNG and SVG. Resumable: finished runs are skipped.
#[derive(Parser, Debug)]
struct Args {
    /// The sweep file, e.g. `methods/aagaussian/configs/sweep.toml`.
    #[arg(long)]
    grid: PathBuf,
    /// The method (`train-<method>`); must agree with the file's `method` when given.
    #[arg(long)]
    method: Option<String>,
    /// Seeds per point (`--set seed=0..N`; 1 keeps the configuration's seed).
    #[arg(long, default_value_t = 1)]
    seeds: u64,
    /// Another override for every point (repeatable; after the file's `base`).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    overrides: Vec<String>,
    /// Sweep name: writes to `<runs>/sweep/<method>/<name>/` (default: the grid file's stem, so
    /// two sweep files of one method keep apart).
    #[arg(long)]
    name: Option<String>,
    #[arg(long, default_value = "runs")]
    runs: PathBuf,
    /// Where `train-<method>` is (default: beside this binary).
    #[arg(long)]
    bin_dir: Option<PathBuf>,
    /// Keeps runs recorded as failed instead of running them again.
    #[arg(long)]
    keep_failed: bool,
    /// Runs everything again, whatever is recorded (after a rebuild, say).
    #[arg(long)]
    rerun: bool,
    /// Lists the points and their overrides (each checked by the trainer) and exits.
    #[arg(long)]
    dry_run: bool,
}

fn main() -> ExitCode {
    exit(run(&Args::parse()))
}

fn run(args: &Args) -> Result<(), TrainError> {
    let spec = SweepSpec::read(&args.grid)?;
    if let Some(method) = &args.method
        && *method != spec.method
    {
        return Err(TrainError::Config(format!(
            "--method {method}, but {} sweeps `{}`",
            args.grid.display(),
            spec.method
        )));
    }
    let bin_dir = match &args.bin_dir {
        Some(dir) => dir.clone(),
        None => std::env::current_exe()
            .ok()
            .and_then(|p| p.parent().map(PathBuf::from))
            .unwrap_or_default(),
    };
    let trainer = Trainer::find(&bin_dir, &spec.method)?;
    let name = match &args.name {
        Some(name) => name.clone(),
        None => args
            .grid
            .file_stem()
            .map_or("sweep".into(), |s| s.to_string_lossy().into_owned()),
    };
    let options = SweepOptions {
        seeds: args.seeds,
        out: args.runs.join("sweep").join(&spec.method).join(name),
        base: args.overrides.clone(),
        retry_failed: !args.keep_failed,
        rerun: args.rerun,
    };
    let mut say = |line: &str| println!("{line}");
    if args.dry_run {
        for planned in sweep::plan(&spec, &trainer, &options, &mut say)? {
            let run = &planned.runs[0].spec;
            println!("{}: {}", planned.point.id, run.set.join(" "));
        }
        return Ok(());
    }
    let report = sweep::run(&spec, &trainer, &options, &mut say)?;
    println!("{}", sweep::table(&report));
    Ok(())
}
