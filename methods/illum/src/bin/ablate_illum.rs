//! `ablate-illum`: Table 4 of the paper from one binary. Each arm is the full method one
//! `--set` line apart (the skinned-avatar baseline two), trained from the same seed on one
//! capture (built once; a seed override changes the networks' start, not the data) and scored
//! the same way; the table goes to `<out>/ablation.csv` and each
//! arm's scores to `<out>/<arm>_seed<k>.json`.
//!
//! ```sh
//! cargo run --release --bin ablate-illum -- --out runs/illum-ablation
//! cargo run --release --bin ablate-illum -- --arms full,no_shadow --seeds 2
//! ```

use clap::Parser;
use splatzoo_illum::config::IllumConfig;
use splatzoo_illum::eval::{IllumScores, TruthScores};
use splatzoo_illum::method::Illum;
use splatzoo_train::TrainError;
use splatzoo_train::harness::{Method, MethodConfig, arms};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

/// Every arm: its name and the overrides that make it.
const ARMS: [(&str, &[&str]); 6] = [
    ("full", &[]),
    ("no_light_volume", &["ablation.light_volume=false"]),
    ("no_shadow", &["ablation.shadow=false"]),
    ("no_probe_smoothness", &["weights.probe=0.0"]),
    ("no_two_stage", &["ablation.two_stage=false"]),
    (
        "skinned_avatar_baseline",
        &["ablation.light_volume=false", "ablation.shadow=false"],
    ),
];

#[derive(Debug, Parser)]
#[command(about = "Illum's Table-4 ablations and the skinned-avatar baseline, one run per arm")]
struct Args {
    /// Arms to run (comma-separated names; all by default).
    #[arg(long, value_delimiter = ',')]
    arms: Vec<String>,
    /// Seeds per arm (the configuration's `seed` + 0, 1, …).
    #[arg(long, default_value_t = 1)]
    seeds: u64,
    /// `key=value` overrides of the base configuration (as `train-illum --set`).
    #[arg(long = "set")]
    overrides: Vec<String>,
    #[arg(long, default_value = "runs/illum-ablation")]
    out: PathBuf,
}

const HEADER: &str = "arm,seed,psnr,ssim,human_psnr,human_ssim,albedo_psnr,relit_human_psnr,\
                      shadow_error,shadow_error_without_ao,novel_pose_psnr,probe_relative_error,seconds";

/// A cell of `digits` decimals, empty where the score is absent.
fn optional(value: Option<f64>, digits: usize) -> String {
    value.map_or_else(String::new, |v| format!("{v:.digits$}"))
}

/// One arm's row; the truth scores' cells stay empty on a capture on disk.
fn csv_row(arm: &str, seed: u64, s: &IllumScores, seconds: f64) -> String {
    let t = s.truth.as_ref();
    let truth = |f: fn(&TruthScores) -> Option<f64>, digits| optional(t.and_then(f), digits);
    format!(
        "{arm},{seed},{:.3},{:.4},{:.3},{:.4},{},{},{},{},{},{},{seconds:.0}",
        s.psnr,
        s.ssim,
        s.human_psnr,
        s.human_ssim,
        truth(|t| t.albedo_psnr, 4),
        truth(|t| Some(t.relit_human_psnr), 3),
        truth(|t| Some(t.shadow_error), 5),
        truth(|t| t.shadow_error_without_ao, 4),
        truth(|t| Some(t.novel_pose_psnr), 3),
        truth(|t| t.probe_relative_error, 4),
    )
}

fn run(args: &Args) -> Result<(), TrainError> {
    let base: IllumConfig =
        splatzoo_train::config::load(&IllumConfig::default(), None, &args.overrides)?;
    base.validate()?;
    let arms = arms::select(&ARMS, &args.arms)?;
    arms::create_dir(&args.out)?;
    let device = base.backend.device();
    device.seed(base.seed);
    let capture = base.data.build(&device).map_err(TrainError::from)?;
    let mut lines = vec![HEADER.to_owned()];
    for (name, sets) in arms {
        for k in 0..args.seeds {
            let mut overrides: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
            overrides.push(format!("seed={}", base.seed + k));
            let config: IllumConfig = splatzoo_train::config::load(&base, None, &overrides)?;
            config.validate()?;
            let start = Instant::now();
            let mut method = Illum::from_capture(config.clone(), capture.clone(), &device)?;
            while method.steps() < config.iterations {
                method.step()?;
            }
            let scores = method.trainer.evaluate(None)?;
            let row = csv_row(name, config.seed, &scores, start.elapsed().as_secs_f64());
            eprintln!("{row}");
            lines.push(row);
            let json = serde_json::to_string_pretty(&scores).expect("plain data");
            let path = args.out.join(format!("{name}_seed{}.json", config.seed));
            arms::write_text(&path, &json)?;
        }
    }
    let path = args.out.join("ablation.csv");
    let table = lines.join("\n") + "\n";
    arms::write_text(&path, &table)?;
    println!("{table}wrote {}", path.display());
    Ok(())
}

fn main() -> ExitCode {
    splatzoo_train::harness::cli::exit(run(&Args::parse()))
}
