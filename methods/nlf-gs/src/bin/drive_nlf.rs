//! `drive-nlf`: generates an avatar with a trained NLF-GS network (a `train-nlf` checkpoint,
//! its format checked) from the three input views of a synthetic identity (or, for a network
//! trained on a capture, of a held-out subject of it, on the capture's body model), at the
//! resolution it was trained at, then drives it with a pose sequence (an AMASS `.npz` via `--poses`, z-up and
//! turned to the body's y-up unless `--up y`; or a built-in walk in place) and writes PNG frames
//! and a GIF, rendered from the 60° camera (front three-quarter, a view the inputs do not
//! have). The printed driving rate covers posing, re-anchoring, rasterizing and reading the
//! image back, not PNG writing.
//!
//! ```sh
//! cargo run --release --bin drive-nlf -- --checkpoint runs/nlf/default/checkpoint.safetensors
//! ```

use burn::tensor::{Tensor, TensorData};
use clap::Parser;
use splatzoo_datasets::pose_sequence::{PoseSequence, UpAxis, load_driving_sequence};
use splatzoo_datasets::synth::motion::{Motion, Start, generate};
use splatzoo_models::anchor::MeshAnchors;
use splatzoo_models::body::lbs::{BodyTensors, PoseInput, pose};
use splatzoo_models::body::{builtin_body, load_body_model};
use splatzoo_models::networks::weights::{WeightFile, load_module};
use splatzoo_nlf_gs::capture::capture_subjects;
use splatzoo_nlf_gs::data::{NlfSubject, posed_splats};
use splatzoo_nlf_gs::network::NlfGs;
use splatzoo_nlf_gs::trainer::NlfTrainer;
use splatzoo_rasterizer::{ColorMode, RasterSettings, rasterize};
use splatzoo_train::TrainError;
use splatzoo_train::backend::Backend;
use splatzoo_train::checkpoint::Checkpoint;
use splatzoo_train::harness::checkpoint_config;
use splatzoo_train::images::{srgb_image, write_gif, write_png};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

#[derive(Parser, Debug)]
#[command(about = "Generate an NLF-GS avatar and drive it with a pose sequence")]
struct Args {
    #[arg(long)]
    checkpoint: PathBuf,
    /// The identity whose input views generate the avatar: a synthetic seed, or, for a network
    /// trained on a capture (`data.test`), its held-out subjects numbered from `test_seed`
    /// (the default is the first).
    #[arg(long, default_value_t = 10_000)]
    subject: u64,
    /// AMASS-layout pose sequence (`poses`, `trans`, `betas`); the identity's shape is kept.
    #[arg(long)]
    poses: Option<PathBuf>,
    /// The up axis of the `--poses` file's world.
    #[arg(long, value_enum, default_value_t = UpAxis::Z)]
    up: UpAxis,
    /// Frames of the built-in walk (ignored with `--poses`).
    #[arg(long, default_value_t = 24)]
    frames: usize,
    /// Image side (default: the side the network was trained at).
    #[arg(long)]
    size: Option<u32>,
    #[arg(long, value_enum, default_value_t = Backend::Flex)]
    backend: Backend,
    #[arg(long, default_value = "runs/nlf-drive")]
    out: PathBuf,
}

fn main() -> ExitCode {
    splatzoo_train::harness::cli::exit(run(Args::parse()))
}

fn run(args: Args) -> Result<(), TrainError> {
    let checkpoint = Checkpoint::read(&args.checkpoint)?;
    let config = checkpoint_config::<NlfTrainer>(&checkpoint)?;
    let network = &config.network;
    let size = args.size.unwrap_or(config.size);
    let device = args.backend.device();
    let file = WeightFile::read(&args.checkpoint)?;
    let model = load_module(NlfGs::new(network, &device), &file)?;
    let (subject, body) = match &config.data.test {
        // A capture-trained network drives a held-out subject of its capture, on its body.
        Some(test) => {
            let body = match &config.data.body_model {
                Some(path) => load_body_model(path)?,
                None => builtin_body().model.clone(),
            };
            let index = args
                .subject
                .checked_sub(config.test_seed)
                .unwrap_or(u64::MAX) as usize;
            let dataset = splatzoo_datasets::formats::load(test, None)?;
            let (mut subjects, _) =
                capture_subjects(&dataset, &body, size, index.saturating_add(1), &device)?;
            if index >= subjects.len() {
                return Err(TrainError::Config(format!(
                    "--subject {}: {} has {} subject(s) with a fit, numbered from test_seed {}",
                    args.subject,
                    test.display(),
                    subjects.len(),
                    config.test_seed
                )));
            }
            (subjects.swap_remove(index), body)
        }
        None => (
            NlfSubject::synthetic(args.subject, size, &device),
            builtin_body().model.clone(),
        ),
    };
    let body = &body;
    let faces = body.faces.clone();
    let anchors = MeshAnchors::per_face(faces.len() / 3, network.gaussians_per_face);
    let inputs = subject.nlf_inputs(&faces, &anchors);
    let start = Instant::now();
    let avatar = model.generate(&inputs, network.fusion, network.occlusion_tolerance);
    let generated = start.elapsed().as_secs_f64();
    let sequence: PoseSequence = match &args.poses {
        Some(path) => load_driving_sequence(path, body.joint_count(), body.shape_count(), args.up)?,
        None => generate(
            &[Motion::Walk {
                seconds: args.frames as f64 / 24.0,
                speed: 1.2,
                turn_rate: 0.0,
            }],
            Start {
                position: [0.0, 0.0],
                heading: 0.0,
                standing_height: subject.translation[1],
            },
            24.0,
        ),
    };
    let tensors = BodyTensors::new(body, &device);
    let betas: Vec<f32> = subject.betas.iter().map(|&b| b as f32).collect();
    let betas = Tensor::<2>::from_data(TensorData::new(betas.clone(), [1, betas.len()]), &device);
    let camera = subject.targets[0].camera;
    let background = subject.background_tensor();
    std::fs::create_dir_all(&args.out).map_err(|e| {
        splatzoo_datasets::DatasetError::file(&args.out, format!("cannot create ({e})"))
    })?;
    let joints = body.joint_count();
    let first_height = sequence.translation(0)[1];
    let mut frames = Vec::new();
    let mut driving = 0.0;
    for t in 0..sequence.frames() {
        let drive_start = Instant::now();
        let p: Vec<f32> = sequence.pose(t).iter().map(|&v| v as f32).collect();
        // In place: keep the body where the inputs saw it; only the vertical motion relative
        // to the first frame is kept.
        let trans = [
            subject.translation[0] as f32,
            (subject.translation[1] + sequence.translation(t)[1] - first_height) as f32,
            subject.translation[2] as f32,
        ];
        let input = PoseInput::from_axis_angle(
            betas.clone(),
            Tensor::from_data(TensorData::new(p, [1, 3 * joints]), &device),
            Tensor::from_data(TensorData::new(trans.to_vec(), [1, 3]), &device),
        );
        let posed = avatar.drive(pose(&tensors, &input).vertices, &faces, &anchors);
        let render = rasterize(
            &posed_splats(posed),
            background.clone(),
            &RasterSettings::new(camera, ColorMode::Sh { degree: 0 }),
        )?;
        let image = srgb_image(&render.color);
        driving += drive_start.elapsed().as_secs_f64();
        write_png(&args.out.join(format!("frame_{t:04}.png")), &image)?;
        frames.push(image);
    }
    write_gif(&args.out.join("drive.gif"), &frames, 12)?;
    println!(
        "generated in {:.2} s at {size}²; drove {} frames at {:.1} fps (posing, anchoring, \
         rasterizing, read-back); wrote {}",
        generated,
        frames.len(),
        frames.len() as f64 / driving.max(1e-9),
        args.out.display()
    );
    Ok(())
}
