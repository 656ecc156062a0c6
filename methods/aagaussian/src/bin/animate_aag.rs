//! `animate-aag`: drives a trained `train-aag` avatar (its checkpoint, format checked) zero-shot
//! with a pose sequence (an AMASS-layout `.npz` via `--poses`, poses fitted to a video's
//! OpenPose JSON via `--keypoints`, or the built-in walk then wave)
//! through the U9 surface binding, and writes `frame_XXXX.png` (avatar | the prompted identity
//! posed alike), `animation.gif`, a posed INRIA `frame_XXXX.ply` per frame and `scores.json`
//! (PSNR/SSIM to the identity per frame, the canonical-pose PSNR, the gap, culled rows, fps).
//!
//! ```sh
//! cargo run --release --bin animate-aag -- --checkpoint runs/aag/default/checkpoint.safetensors
//! ```

use clap::Parser;
use splatzoo_aagaussian::Aag;
use splatzoo_aagaussian::animate::{FrameOutput, JOINTS, animate, builtin_motion};
use splatzoo_aagaussian::data::PortraitCapture;
use splatzoo_aagaussian::trainer::AVATAR;
use splatzoo_aagaussian::video_poses::{VideoCamera, poses_from_keypoints};
use splatzoo_datasets::files::write_atomically;
use splatzoo_datasets::pose_sequence::{UpAxis, load_driving_sequence, write_pose_sequence};
use splatzoo_train::TrainError;
use splatzoo_train::backend::Backend;
use splatzoo_train::checkpoint::Checkpoint;
use splatzoo_train::gaussians::GaussianSet;
use splatzoo_train::harness::checkpoint_config;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser, Debug)]
#[command(about = "Drive a trained train-aag avatar with a pose sequence")]
struct Args {
    #[arg(long)]
    checkpoint: PathBuf,
    /// AMASS-layout pose sequence (`poses`, `trans`); only its 21 body joints drive.
    #[arg(long)]
    poses: Option<PathBuf>,
    /// The up axis of the `--poses` file's world (matters with `--root`).
    #[arg(long, value_enum, default_value_t = UpAxis::Z)]
    up: UpAxis,
    /// A motion video's OpenPose JSON, one file per frame: its poses are fitted frame by
    /// frame and drive the avatar (written as `poses.npz`).
    #[arg(long, conflicts_with = "poses")]
    keypoints: Option<PathBuf>,
    /// The video's focal length and image size, pixels (with `--keypoints`).
    #[arg(long, default_value_t = 1000.0)]
    focal: f64,
    #[arg(long, default_value_t = 720)]
    image_width: u32,
    #[arg(long, default_value_t = 1280)]
    image_height: u32,
    /// Keep the sequence's root orientation.
    #[arg(long)]
    root: bool,
    /// Frames of the built-in motion (ignored with `--poses`).
    #[arg(long)]
    frames: Option<usize>,
    /// Square frame side in pixels.
    #[arg(long)]
    size: Option<u32>,
    /// Skip the per-frame `.ply` files.
    #[arg(long)]
    no_ply: bool,
    #[arg(long, value_enum, default_value_t = Backend::Flex)]
    backend: Backend,
    #[arg(long, default_value = "runs/aag-animate")]
    out: PathBuf,
}

fn main() -> ExitCode {
    splatzoo_train::harness::cli::exit(run(Args::parse()))
}

fn run(args: Args) -> Result<(), TrainError> {
    let checkpoint = Checkpoint::read(&args.checkpoint)?;
    let config = checkpoint_config::<Aag>(&checkpoint)?;
    let device = args.backend.device();
    let set = GaussianSet::load(&checkpoint, &format!("{AVATAR}.splats"), &device)?;
    let capture = PortraitCapture::build(&config.data, &device).map_err(TrainError::from)?;
    let mut animation = config.animation.clone();
    animation.root |= args.root;
    if let Some(size) = args.size {
        animation.size = size;
    }
    std::fs::create_dir_all(&args.out).map_err(|e| {
        splatzoo_datasets::DatasetError::file(&args.out, format!("cannot create ({e})"))
    })?;
    let sequence = match (&args.poses, &args.keypoints) {
        (Some(path), _) => {
            let shapes = splatzoo_models::body::builtin_body().model.shape_count();
            load_driving_sequence(path, JOINTS, shapes, args.up)?
        }
        (None, Some(dir)) => {
            let camera = VideoCamera {
                focal_px: args.focal,
                width: args.image_width,
                height: args.image_height,
            };
            let (sequence, fits) =
                poses_from_keypoints(&capture.body, dir, camera, animation.fps, &device)
                    .map_err(TrainError::from)?;
            let worst = fits
                .iter()
                .map(|f| f.reprojection_rms_px)
                .fold(0.0, f64::max);
            println!(
                "fitted {} frames of {} (worst reprojection {worst:.2} px)",
                fits.len(),
                dir.display()
            );
            write_pose_sequence(&args.out.join("poses.npz"), &sequence)?;
            sequence
        }
        (None, None) => builtin_motion(args.frames.unwrap_or(animation.frames), animation.fps),
    };
    let scores = animate(
        &set,
        &capture,
        &sequence,
        &animation,
        Some(FrameOutput {
            dir: &args.out,
            ply: !args.no_ply,
        }),
    )
    .map_err(TrainError::from)?;
    let json = serde_json::to_string_pretty(&scores).expect("plain data");
    write_atomically(&args.out.join("scores.json"), |tmp| {
        std::fs::write(tmp, &json)
    })?;
    println!(
        "drove {} frames of {} Gaussians ({} culled) at {}² at {:.1} fps (posing, \
         rasterizing){}; wrote {}",
        scores.frames,
        scores.gaussians,
        scores.culled,
        animation.size,
        scores.fps,
        scores
            .identity
            .as_ref()
            .map_or_else(String::new, |kept| kept.line()),
        args.out.display()
    );
    Ok(())
}
