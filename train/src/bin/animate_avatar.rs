//! `animate-avatar`: drives a trained `train-avatar` avatar (its checkpoint, format checked)
//! with a pose sequence (an AMASS-layout `.npz` via `--poses`, z-up and turned to the body's
//! y-up unless `--up y`; or a built-in walk) and writes `frame_XXXX.png`, `animation.gif` and a
//! posed INRIA `frame_XXXX.ply` per frame, seen by a camera that follows the body from the
//! front. The avatar keeps its trained shape; the driving sequence's shape is ignored. The
//! printed rate covers posing, skinning, rasterizing and reading the image back, not writing
//! files.
//!
//! ```sh
//! cargo run --release --bin animate-avatar -- --checkpoint runs/avatar/default/checkpoint.safetensors
//! ```

use clap::Parser;
use splatzoo_datasets::pose_sequence::{PoseSequence, UpAxis, load_driving_sequence};
use splatzoo_datasets::synth::motion::{Motion, Start, generate};
use splatzoo_datasets::synth::scene::standing_height;
use splatzoo_rasterizer::{Camera, ColorMode, RasterSettings, rasterize};
use splatzoo_train::TrainError;
use splatzoo_train::avatar::{AvatarTrainer, HUMAN};
use splatzoo_train::backend::Backend;
use splatzoo_train::checkpoint::Checkpoint;
use splatzoo_train::densify::{DensifyConfig, Strategy};
use splatzoo_train::gaussians::GaussianSet;
use splatzoo_train::harness::checkpoint_config;
use splatzoo_train::images::{srgb_image, write_gif, write_png};
use splatzoo_train::ply::write_ply;
use splatzoo_train::scene::SkinnedGaussianNode;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

#[derive(Parser, Debug)]
#[command(about = "Drive a trained train-avatar avatar with a pose sequence")]
struct Args {
    #[arg(long)]
    checkpoint: PathBuf,
    /// AMASS-layout pose sequence (`poses`, `trans`).
    #[arg(long)]
    poses: Option<PathBuf>,
    /// The up axis of the `--poses` file's world.
    #[arg(long, value_enum, default_value_t = UpAxis::Z)]
    up: UpAxis,
    /// Frames of the built-in walk (ignored with `--poses`).
    #[arg(long, default_value_t = 24)]
    frames: usize,
    #[arg(long, default_value_t = 256)]
    width: u32,
    #[arg(long, default_value_t = 256)]
    height: u32,
    /// Skip the per-frame `.ply` files.
    #[arg(long)]
    no_ply: bool,
    #[arg(long, value_enum, default_value_t = Backend::Flex)]
    backend: Backend,
    #[arg(long, default_value = "runs/avatar-animate")]
    out: PathBuf,
}

fn main() -> ExitCode {
    splatzoo_train::harness::cli::exit(run(Args::parse()))
}

fn run(args: Args) -> Result<(), TrainError> {
    let checkpoint = Checkpoint::read(&args.checkpoint)?;
    let config = checkpoint_config::<AvatarTrainer>(&checkpoint)?;
    let device = args.backend.device();
    let body = &config.body()?;
    // The trained shape, for the built-in walk's standing height.
    let betas: burn::tensor::Tensor<2> = checkpoint.tensor(
        &format!("{HUMAN}.betas"),
        [Some(1), Some(body.shape_count())],
        &device,
    )?;
    let avatar_shape: Vec<f64> = splatzoo_train::host_f32(&betas)
        .into_iter()
        .map(f64::from)
        .collect();
    let sequence: PoseSequence = match &args.poses {
        Some(path) => load_driving_sequence(path, body.joint_count(), body.shape_count(), args.up)?,
        None => generate(
            &[Motion::Walk {
                seconds: args.frames as f64 / 24.0,
                speed: 1.2,
                turn_rate: 0.4,
            }],
            Start {
                position: [0.0, 0.0],
                heading: 0.0,
                standing_height: standing_height(&avatar_shape, &device),
            },
            24.0,
        ),
    };
    // A node over the driving motion: no frame trained, so every pose is the motion's own.
    let fixed = DensifyConfig {
        strategy: Strategy::None,
        ..config.densify.clone()
    };
    let mut node = SkinnedGaussianNode::new(
        HUMAN,
        body,
        &sequence,
        vec![false; sequence.frames()],
        &config.node,
        config.rates,
        &fixed,
        1.0,
        0,
        &device,
    )?;
    node.load_avatar(&checkpoint, HUMAN, &device)?;
    std::fs::create_dir_all(&args.out).map_err(|e| {
        splatzoo_datasets::DatasetError::file(&args.out, format!("cannot create ({e})"))
    })?;
    let background = burn::tensor::Tensor::<1>::from_floats(config.background.as_slice(), &device);
    let canonical = node.canonical_set().splats();
    let (mut frames, mut driving) = (Vec::new(), 0.0);
    for t in 0..sequence.frames() {
        let start = Instant::now();
        let posed = node.posed(canonical.clone(), t).splats;
        let pelvis = sequence.translation(t).map(|v| v as f32);
        let target = [pelvis[0], pelvis[1], pelvis[2]];
        let camera = Camera::look_at(
            [target[0], target[1] + 0.2, target[2] + 3.0],
            target,
            [0.0, 1.0, 0.0],
            45.0,
            args.width,
            args.height,
        );
        let render = rasterize(
            &posed,
            background.clone(),
            &RasterSettings::new(
                camera,
                ColorMode::Sh {
                    degree: config.sh_degree,
                },
            ),
        )?;
        let image = srgb_image(&render.color);
        driving += start.elapsed().as_secs_f64();
        write_png(&args.out.join(format!("frame_{t:04}.png")), &image)?;
        if !args.no_ply {
            write_ply(
                &args.out.join(format!("frame_{t:04}.ply")),
                &GaussianSet::from_splats(&posed),
            )?;
        }
        frames.push(image);
    }
    write_gif(&args.out.join("animation.gif"), &frames, 24)?;
    println!(
        "drove {} frames of {} Gaussians at {}×{} at {:.1} fps (posing, skinning, rasterizing, \
         read-back); wrote {}",
        frames.len(),
        node.canonical_set().len(),
        args.width,
        args.height,
        frames.len() as f64 / driving.max(1e-9),
        args.out.display()
    );
    Ok(())
}
