//! `ablate-prior4d`: the spec's ablation table from one binary. Stages A and B run once; stage
//! D then runs once per arm from that same state (each arm one `--set` line apart from the
//! full method), for each seed of stage D; the table goes to `<out>/ablation.csv` and each
//! arm's scores to `<out>/<arm>.json`.
//!
//! ```sh
//! cargo run --release --bin ablate-prior4d -- --out runs/prior4d-ablation
//! cargo run --release --bin ablate-prior4d -- --arms full,no_contact --set iterations=3000
//! ```

use clap::Parser;
use splatzoo_prior_4d::Prior4d;
use splatzoo_prior_4d::config::Prior4dConfig;
use splatzoo_prior_4d::eval::JointScores;
use splatzoo_train::TrainError;
use splatzoo_train::harness::{Method, MethodConfig, arms};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

/// Every arm: its name and the overrides that make it.
const ARMS: [(&str, &[&str]); 11] = [
    ("full", &[]),
    ("no_normal", &["joint.normal=0.0"]),
    ("no_contact", &["joint.contact=0.0"]),
    ("no_huber", &["joint.huber=0.0"]),
    ("no_pose_offsets", &["joint.pose_offsets=false"]),
    ("no_camera_refinement", &["joint.camera_refinement=false"]),
    ("free_scene", &["joint.free_scene=true"]),
    ("sigma_x1.25", &["joint.sigma_scale=1.25"]),
    (
        "sigma_x1.25_no_contact",
        &["joint.sigma_scale=1.25", "joint.contact=0.0"],
    ),
    ("sigma_x0.7", &["joint.sigma_scale=0.7"]),
    (
        "sigma_x0.7_no_contact",
        &["joint.sigma_scale=0.7", "joint.contact=0.0"],
    ),
];

#[derive(Debug, Parser)]
#[command(about = "Prior-4D's ablations: stage D per arm from one shared stage A + B")]
struct Args {
    /// Arms to run (comma-separated names; all by default).
    #[arg(long, value_delimiter = ',')]
    arms: Vec<String>,
    /// Stage-D seeds per arm.
    #[arg(long, default_value_t = 1)]
    seeds: u64,
    /// `key=value` overrides of the base configuration (as `train-prior4d --set`).
    #[arg(long = "set")]
    overrides: Vec<String>,
    #[arg(long, default_value = "runs/prior4d-ablation")]
    out: PathBuf,
}

fn csv_row(arm: &str, seed: u64, s: &JointScores, seconds: f64) -> String {
    format!(
        "{arm},{seed},{:.3},{:.4},{:.4},{:.2},{:.2},{:.4},{:.4},{:.4},{:.4},{:.1},{:.1},{:.1},{:.3},{:.1},{:.1},{seconds:.0}",
        s.psnr,
        s.ssim,
        s.one_minus_ssim,
        s.normal_mean_degrees,
        s.normal_median_degrees,
        s.mask_iou,
        s.sigma,
        s.sigma_error,
        s.penetration_rate,
        s.foot_distance_mm,
        s.foot_height_mm,
        s.camera_centre_rms_mm,
        s.camera_rotation_degrees,
        s.mpjpe_mm,
        s.prior_mpjpe_mm,
    )
}

fn run(args: &Args) -> Result<(), TrainError> {
    let base: Prior4dConfig =
        splatzoo_train::config::load(&Prior4dConfig::default(), None, &args.overrides)?;
    base.validate()?;
    let arms = arms::select(&ARMS, &args.arms)?;
    arms::create_dir(&args.out)?;
    let device = base.backend.device();
    let start = Instant::now();
    let mut shared = Prior4d::new(base.clone(), &device)?;
    while shared.steps() < base.joint_start() {
        shared.step()?;
    }
    let priors = shared.checkpoint();
    eprintln!(
        "stages A and B: {:.0} s; stage D per arm from here",
        start.elapsed().as_secs_f64()
    );
    let mut lines = vec![
        "arm,seed,psnr,ssim,one_minus_ssim,normal_mean_deg,normal_median_deg,mask_iou,sigma,sigma_error,penetration_rate,foot_distance_mm,foot_height_mm,camera_centre_rms_mm,camera_rotation_deg,mpjpe_mm,prior_mpjpe_mm,seconds"
            .to_owned(),
    ];
    let mut priors_only = None;
    for (name, sets) in arms {
        for seed in 0..args.seeds {
            let mut overrides: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
            overrides.push(format!("joint.seed={seed}"));
            let config: Prior4dConfig = splatzoo_train::config::load(&base, None, &overrides)?;
            config.validate()?;
            let arm_start = Instant::now();
            let mut method = Prior4d::resume(
                config.clone(),
                &with_step(&priors, base.joint_start()),
                &device,
            )?;
            while method.steps() < config.iterations {
                method.step()?;
            }
            let scores = method.final_scores(None)?;
            let seconds = arm_start.elapsed().as_secs_f64();
            let row = csv_row(name, seed, &scores, seconds);
            eprintln!("{row}");
            lines.push(row);
            if sets.is_empty() && priors_only.is_none() {
                // The full method's stage-D start: the priors alone.
                priors_only = method.priors_only.clone();
            }
            let json = serde_json::to_string_pretty(&scores).expect("plain data");
            let path = args.out.join(format!("{name}_seed{seed}.json"));
            arms::write_text(&path, &json)?;
        }
    }
    if let Some(p) = priors_only {
        lines.push(csv_row("priors_only", 0, &p, 0.0));
    }
    let path = args.out.join("ablation.csv");
    let table = lines.join("\n") + "\n";
    arms::write_text(&path, &table)?;
    println!("{table}wrote {}", path.display());
    Ok(())
}

/// The shared checkpoint with its step set (the harness writes `step`; here we do).
fn with_step(
    checkpoint: &splatzoo_train::checkpoint::Checkpoint,
    step: usize,
) -> splatzoo_train::checkpoint::Checkpoint {
    let mut c = checkpoint.clone();
    c.put_meta("step", step);
    c
}

fn main() -> ExitCode {
    splatzoo_train::harness::cli::exit(run(&Args::parse()))
}
