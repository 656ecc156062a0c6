//! `ablate-aag`: AAGaussian's ablations from one binary, each arm the default configuration
//! plus the `--set` lines listed below, for each seed; the table goes to
//! `<out>/ablation.csv` and each arm's scores to `<out>/<arm>_seed<k>.json`.
//!
//! - The paper's Fig. 5 as numbers, on a face swap (the oracle is identity 0, the face crop is
//!   identity 2's, so the face loss has something SDS does not already give): no face loss,
//!   ×1, ×100, ×1 without the line-of-sight term (U6).
//! - The face loss against a view-inconsistent oracle (`view_variants`: the prompted identity
//!   with other skin and hair tones from its sides), with the face crop the identity's own.
//! - The guidance forms (classic CFG, ANPG, HumanGaussian's rescaled form, plain SDS), the
//!   body-prior init against a random box (§3.2), and the depth branch off (λ₂ = 0).
//!
//! ```sh
//! cargo run --release --bin ablate-aag -- --out runs/aag-ablation
//! cargo run --release --bin ablate-aag -- --arms swap_no_face,swap_face_x1 --seeds 2
//! ```

use clap::Parser;
use splatzoo_aagaussian::Aag;
use splatzoo_aagaussian::config::AagConfig;
use splatzoo_aagaussian::eval::AagScores;
use splatzoo_train::TrainError;
use splatzoo_train::harness::{Method, MethodConfig, arms};
use splatzoo_train::lpips::Lpips;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

const SWAP: &str = "data.face_identity=2";

/// Every arm: its name and the overrides that make it.
const VARIANTS: &str = "data.view_variants=true";

const ARMS: [(&str, &[&str]); 12] = [
    ("full", &[]),
    ("anpg", &["sds.guidance=\"anpg\""]),
    ("human_gaussian", &["sds.guidance=\"human_gaussian\""]),
    ("plain", &["sds.guidance=\"plain\""]),
    ("box_init", &["init=\"box\""]),
    ("no_depth", &["sds.lambda_depth=0.0"]),
    ("swap_no_face", &[SWAP, "face.weight=0.0"]),
    ("swap_face_x1", &[SWAP]),
    ("swap_face_x100", &[SWAP, "face.weight=100.0"]),
    ("swap_face_x1_no_los", &[SWAP, "face.line_of_sight=0.0"]),
    ("variants_no_face", &[VARIANTS, "face.weight=0.0"]),
    ("variants_face_x100", &[VARIANTS, "face.weight=100.0"]),
];

#[derive(Debug, Parser)]
#[command(about = "AAGaussian's ablations (Fig. 5 as numbers, guidance, init, depth branch)")]
struct Args {
    /// Arms to run (comma-separated names; all by default).
    #[arg(long, value_delimiter = ',')]
    arms: Vec<String>,
    /// Seeds per arm.
    #[arg(long, default_value_t = 1)]
    seeds: u64,
    /// `key=value` overrides of the base configuration (as `train-aag --set`).
    #[arg(long = "set")]
    overrides: Vec<String>,
    #[arg(long, default_value = "runs/aag-ablation")]
    out: PathBuf,
}

const HEADER: &str = "arm,seed,psnr,ssim,lpips,clip_score,prompt_alignment,face_psnr,\
                      face_asymmetry,floater_mass,gaussians,seconds";

/// One arm's row; the held-out columns are blank for a user's photo (no truth).
fn csv_row(arm: &str, seed: u64, s: &AagScores, seconds: f64) -> String {
    let held_out = s.held_out.as_ref();
    let blank_or = |v: Option<String>| v.unwrap_or_default();
    format!(
        "{arm},{seed},{},{},{},{},{},{:.3},{:.4},{:.3},{},{seconds:.0}",
        blank_or(held_out.map(|h| format!("{:.3}", h.psnr))),
        blank_or(held_out.map(|h| format!("{:.4}", h.ssim))),
        blank_or(held_out.and_then(|h| h.lpips).map(|l| format!("{l:.4}"))),
        blank_or(s.clip_score.map(|c| format!("{c:.2}"))),
        blank_or(held_out.map(|h| format!("{:.3}", h.prompt_alignment))),
        s.face_psnr,
        s.face_asymmetry,
        s.floater_mass,
        s.gaussians
    )
}

fn run(args: &Args) -> Result<(), TrainError> {
    let base: AagConfig =
        splatzoo_train::config::load(&AagConfig::default(), None, &args.overrides)?;
    base.validate()?;
    let arms = arms::select(&ARMS, &args.arms)?;
    arms::create_dir(&args.out)?;
    let device = base.backend.device();
    let lpips = base
        .lpips_weights
        .as_deref()
        .map(|path| Lpips::load(path, &device))
        .transpose()?;
    let mut lines = vec![HEADER.to_owned()];
    for (name, sets) in arms {
        for seed in 0..args.seeds {
            let mut overrides: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
            overrides.push(format!("seed={}", base.seed + seed));
            let config: AagConfig = splatzoo_train::config::load(&base, None, &overrides)?;
            config.validate()?;
            let start = Instant::now();
            let mut method = Aag::new(config.clone(), &device)?;
            while method.steps() < config.iterations {
                method.step()?;
            }
            let scores = method.trainer.evaluate(lpips.as_ref())?;
            let row = csv_row(name, seed, &scores, start.elapsed().as_secs_f64());
            eprintln!("{row}");
            lines.push(row);
            let json = serde_json::to_string_pretty(&scores).expect("plain data");
            arms::write_text(&args.out.join(format!("{name}_seed{seed}.json")), &json)?;
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
