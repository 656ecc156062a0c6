//! `ablate-prior4d`: the spec's ablation table from one binary. Stages A and B run once for
//! every arm that keeps the priors as they are; stage D then runs once per arm from that same
//! state (each arm one `--set` line apart from the full method), for each seed of stage D. An
//! arm that changes a prior (`scene.*`, `avatar.*`: without the scene or avatar prior, and the
//! ExAvatar-like baseline) trains its own stages A and B first. The table goes to
//! `<out>/ablation.csv` (with the stage-D start of each set of priors as a `priors_only` row)
//! and each arm's scores to `<out>/<arm>_seed<seed>.json`.
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
use splatzoo_train::checkpoint::Checkpoint;
use splatzoo_train::harness::{Method, MethodConfig, arms};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

/// Every arm: its name and the overrides that make it.
const ARMS: [(&str, &[&str]); 14] = [
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
    // Fig. 5: each prior trained on the acting video instead of its scan.
    ("no_scene_prior", &["scene.source=acting"]),
    ("no_avatar_prior", &["avatar.source=acting"]),
    // The spec's second internal baseline (§7): no priors, no contact, normal or Huber term,
    // no pose-dependent offsets, the cameras as given.
    (
        "exavatar_like",
        &[
            "scene.source=acting",
            "avatar.source=acting",
            "joint.contact=0.0",
            "joint.normal=0.0",
            "joint.huber=0.0",
            "joint.pose_offsets=false",
            "joint.camera_refinement=false",
        ],
    ),
];

/// An arm's overrides that change stage A or B (so it needs priors of its own).
fn prior_overrides(sets: &[&str]) -> Vec<String> {
    sets.iter()
        .filter(|s| s.starts_with("scene.") || s.starts_with("avatar."))
        .map(|s| s.to_string())
        .collect()
}

/// Whether an arm changes stage C's σ₀, so its stage-D start is not its priors' alone (the
/// loss weights and switches leave the start as it is: the offset heads and the camera
/// corrections start at zero).
fn moves_sigma0(sets: &[&str]) -> bool {
    sets.iter()
        .any(|s| s.starts_with("joint.sigma") || s.starts_with("joint.initial_sigma"))
}

/// Stages A and B under `base` with `overrides`: the checkpoint stage D starts from.
fn train_priors(
    base: &Prior4dConfig,
    overrides: &[String],
    device: &burn::tensor::Device,
) -> Result<Checkpoint, TrainError> {
    let config: Prior4dConfig = splatzoo_train::config::load(base, None, overrides)?;
    config.validate()?;
    let start = Instant::now();
    let mut method = Prior4d::new(config.clone(), device)?;
    while method.steps() < config.joint_start() {
        method.step()?;
    }
    eprintln!(
        "stages A and B [{}]: {:.0} s; stage D per arm from here",
        overrides.join(" "),
        start.elapsed().as_secs_f64()
    );
    Ok(with_step(&method.checkpoint(), config.joint_start()))
}

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

/// `v` to `precision` decimals, empty where the capture could not score it.
fn cell(v: Option<f64>, precision: usize) -> String {
    v.map_or(String::new(), |v| format!("{v:.precision$}"))
}

fn csv_row(arm: &str, seed: u64, s: &JointScores, seconds: f64) -> String {
    let t = s.truth.as_ref();
    format!(
        "{arm},{seed},{:.3},{},{:.4},{:.4},{},{},{:.4},{:.4},{},{},{},{},{},{},{},{},{seconds:.0}",
        s.psnr,
        cell(s.human_psnr, 3),
        s.ssim,
        s.one_minus_ssim,
        cell(s.normal_mean_degrees, 2),
        cell(s.normal_median_degrees, 2),
        s.mask_iou,
        s.sigma,
        cell(t.map(|t| t.sigma_error), 4),
        cell(t.map(|t| t.penetration_rate), 4),
        cell(t.map(|t| t.foot_distance_mm), 1),
        cell(t.map(|t| t.foot_height_mm), 1),
        cell(t.map(|t| t.camera_centre_rms_mm), 1),
        cell(t.map(|t| t.camera_rotation_degrees), 3),
        cell(t.map(|t| t.mpjpe_mm), 1),
        cell(t.map(|t| t.prior_mpjpe_mm), 1),
    )
}

fn run(args: &Args) -> Result<(), TrainError> {
    let base: Prior4dConfig =
        splatzoo_train::config::load(&Prior4dConfig::default(), None, &args.overrides)?;
    base.validate()?;
    let arms = arms::select(&ARMS, &args.arms)?;
    arms::create_dir(&args.out)?;
    let device = base.backend.device();
    // Each set of prior overrides, its stage-D start and (once run) that start's scores.
    let mut priors: Vec<(Vec<String>, Checkpoint, Option<JointScores>)> = Vec::new();
    let mut lines = vec![
        "arm,seed,psnr,human_psnr,ssim,one_minus_ssim,normal_mean_deg,normal_median_deg,mask_iou,sigma,sigma_error,penetration_rate,foot_distance_mm,foot_height_mm,camera_centre_rms_mm,camera_rotation_deg,mpjpe_mm,prior_mpjpe_mm,seconds"
            .to_owned(),
    ];
    for (name, sets) in arms {
        let key = prior_overrides(sets);
        let group = match priors.iter().position(|(k, _, _)| *k == key) {
            Some(group) => group,
            None => {
                let checkpoint = train_priors(&base, &key, &device)?;
                priors.push((key, checkpoint, None));
                priors.len() - 1
            }
        };
        for seed in 0..args.seeds {
            let mut overrides: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
            overrides.push(format!("joint.seed={seed}"));
            let config: Prior4dConfig = splatzoo_train::config::load(&base, None, &overrides)?;
            config.validate()?;
            let arm_start = Instant::now();
            let mut method = Prior4d::resume(config.clone(), &priors[group].1, &device)?;
            while method.steps() < config.iterations {
                method.step()?;
            }
            let scores = method.final_scores(None)?;
            let seconds = arm_start.elapsed().as_secs_f64();
            let row = csv_row(name, seed, &scores, seconds);
            eprintln!("{row}");
            lines.push(row);
            if priors[group].2.is_none() && !moves_sigma0(sets) {
                // Stage D's start: these priors alone.
                priors[group].2 = method.priors_only.clone();
            }
            let json = serde_json::to_string_pretty(&scores).expect("plain data");
            let path = args.out.join(format!("{name}_seed{seed}.json"));
            arms::write_text(&path, &json)?;
        }
    }
    for (key, _, scores) in &priors {
        if let Some(p) = scores {
            let name = match key.is_empty() {
                true => "priors_only".to_owned(),
                false => format!("priors_only[{}]", key.join(" ")),
            };
            lines.push(csv_row(&name, 0, p, 0.0));
        }
    }
    let path = args.out.join("ablation.csv");
    let table = lines.join("\n") + "\n";
    arms::write_text(&path, &table)?;
    println!("{table}wrote {}", path.display());
    Ok(())
}

/// The shared checkpoint with its step set (the harness writes `step`; here we do).
fn with_step(checkpoint: &Checkpoint, step: usize) -> Checkpoint {
    let mut c = checkpoint.clone();
    c.put_meta("step", step);
    c
}

fn main() -> ExitCode {
    splatzoo_train::harness::cli::exit(run(&Args::parse()))
}
