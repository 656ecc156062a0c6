//! `inspect-dataset`: what a dataset folder holds, in our terms: its format (detected, or
//! `--format`), frames, cameras, people and their valid frames, splits, sparse points, image
//! sizes; then every image and mask decoded in parallel (bounded batches) and checked against
//! its camera. Prints the warnings (valid data worth saying: extra pose rows, subjects without a
//! body fit, empty dynamic masks; the first few, and how many), then the first problem, if any,
//! and exits non-zero only for problems.
//!
//! ```sh
//! cargo run --release --bin inspect-dataset -- path/to/CoreView_377
//! cargo run --release --bin inspect-dataset -- path/to/neuman/bike --limit 50
//! cargo run --release --bin inspect-dataset -- path/to/mipnerf360/garden --downscale 4
//! ```

use clap::Parser;
use splatzoo_datasets::formats::{Format, LoadOptions, check::check, load_with};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser, Debug)]
#[command(
    about = "Inspect a dataset folder (NeuMan, COLMAP, ZJU-MoCap, PeopleSnapshot, GHG THuman2.0, drivestudio Waymo, nerfstudio)"
)]
struct Args {
    root: PathBuf,
    /// The format (detected from the files when left out).
    #[arg(long, value_enum)]
    format: Option<Format>,
    /// Decode and check at most this many views.
    #[arg(long)]
    limit: Option<usize>,
    /// Cameras at 1/N resolution (COLMAP scenes: `images_N/` where present).
    #[arg(long, default_value_t = 1)]
    downscale: u32,
}

fn main() -> ExitCode {
    let args = Args::parse();
    let options = LoadOptions {
        downscale: args.downscale,
    };
    let dataset = match load_with(&args.root, args.format, &options) {
        Ok(d) => d,
        Err(e) => {
            println!("first problem: {e}");
            return ExitCode::FAILURE;
        }
    };
    let cameras = dataset.camera_names();
    println!("format: {:?}", dataset.format);
    println!("frames: {}", dataset.frame_count);
    let shown: Vec<&str> = cameras.iter().take(6).copied().collect();
    let more = if cameras.len() > 6 { ", …" } else { "" };
    println!("cameras: {} ({}{more})", cameras.len(), shown.join(", "));
    println!("views: {}", dataset.views.len());
    for person in &dataset.people {
        let valid = person.frames.iter().filter(|f| f.is_some()).count();
        println!(
            "person {}: valid in {valid} of {} frames",
            person.person,
            person.frames.len()
        );
    }
    for (name, views) in &dataset.splits {
        println!("split {name}: {} views", views.len());
    }
    if !dataset.points.is_empty() {
        println!("sparse points: {}", dataset.points.len());
    }
    if dataset.image_downscale > 1 {
        println!(
            "image files at full resolution: shrink by {} to the cameras' size",
            dataset.image_downscale
        );
    }
    let report = check(&dataset, args.limit);
    let sizes: Vec<String> = report
        .sizes
        .iter()
        .map(|(w, h)| format!("{w}×{h}"))
        .collect();
    println!(
        "decoded {} images and {} masks; resolution {}",
        report.images,
        report.masks,
        if sizes.is_empty() {
            "-".into()
        } else {
            sizes.join(", ")
        }
    );
    const SHOWN_WARNINGS: usize = 10;
    for (file, fact) in report.warnings.iter().take(SHOWN_WARNINGS) {
        println!("warning: {file}: {fact}");
    }
    if report.warnings.len() > SHOWN_WARNINGS {
        println!(
            "warning: … {} more ({} warnings in all)",
            report.warnings.len() - SHOWN_WARNINGS,
            report.warnings.len()
        );
    }
    match report.problems.first() {
        Some((file, problem)) => {
            println!(
                "first problem: {file}: {problem} ({} problems in all)",
                report.problems.len()
            );
            ExitCode::FAILURE
        }
        None => {
            match report.warnings.len() {
                0 => println!("no problems found"),
                1 => println!("no problems found (1 warning)"),
                n => println!("no problems found ({n} warnings)"),
            }
            ExitCode::SUCCESS
        }
    }
}
