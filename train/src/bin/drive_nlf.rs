//! `drive-nlf`: generates an avatar with a trained NLF-GS network (a `train-nlf` checkpoint) from
//! the three input views of a synthetic identity, then drives it with a pose sequence (an AMASS
//! `.npz` via `--poses`, or a built-in walk in place) and writes PNG frames and a GIF.
//!
//! ```sh
//! cargo run --release --bin drive-nlf -- --checkpoint runs/nlf/default/checkpoint.safetensors
//! ```

use burn::tensor::{Tensor, TensorData};
use clap::Parser;
use splatzoo_datasets::pose_sequence::load_pose_sequence;
use splatzoo_datasets::synth::motion::{Motion, Start, generate};
use splatzoo_models::anchor::MeshAnchors;
use splatzoo_models::body::builtin_body;
use splatzoo_models::body::lbs::{BodyTensors, PoseInput, pose};
use splatzoo_models::networks::nlf::{NlfConfig, NlfGs};
use splatzoo_models::networks::weights::{WeightFile, load_module};
use splatzoo_rasterizer::{ColorMode, RasterSettings, rasterize};
use splatzoo_train::backend::Backend;
use splatzoo_train::checkpoint::Checkpoint;
use splatzoo_train::images::{srgb_image, write_gif, write_png};
use splatzoo_train::nlf_data::NlfSubject;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

#[derive(Parser, Debug)]
#[command(about = "Generate an NLF-GS avatar and drive it with a pose sequence")]
struct Args {
    #[arg(long)]
    checkpoint: PathBuf,
    /// The synthetic identity whose input views generate the avatar.
    #[arg(long, default_value_t = 10_000)]
    subject: u64,
    /// AMASS-layout pose sequence (`poses`, `trans`, `betas`); the identity's shape is kept.
    #[arg(long)]
    poses: Option<PathBuf>,
    /// Frames of the built-in walk (ignored with `--poses`).
    #[arg(long, default_value_t = 24)]
    frames: usize,
    #[arg(long, default_value_t = 128)]
    size: u32,
    #[arg(long, value_enum, default_value_t = Backend::Flex)]
    backend: Backend,
    #[arg(long, default_value = "runs/nlf-drive")]
    out: PathBuf,
}

fn main() -> ExitCode {
    match run(Args::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(args: Args) -> Result<(), String> {
    let checkpoint = Checkpoint::read(&args.checkpoint).map_err(|e| e.to_string())?;
    let network: NlfConfig = toml::from_str(checkpoint.meta("network").map_err(|e| e.to_string())?)
        .map_err(|e| format!("{}: `network`: {e}", args.checkpoint.display()))?;
    let device = args.backend.device();
    let file = WeightFile::read(&args.checkpoint).map_err(|e| e.to_string())?;
    let model = load_module(NlfGs::new(&network, &device), &file).map_err(|e| e.to_string())?;
    let subject = NlfSubject::synthetic(args.subject, args.size, &device);
    let body = &builtin_body().model;
    let faces = body.faces.clone();
    let anchors = MeshAnchors::per_face(faces.len() / 3, network.gaussians_per_face);
    let inputs = subject.nlf_inputs(&faces, &anchors);
    let start = Instant::now();
    let avatar = model.generate(&inputs, network.fusion, network.occlusion_tolerance);
    let generated = start.elapsed().as_secs_f64();
    let sequence = match &args.poses {
        Some(path) => load_pose_sequence(path).map_err(|e| e.to_string())?,
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
    let camera = subject.targets[1].camera;
    let background = Tensor::<1>::from_floats(subject.background.as_slice(), &device);
    std::fs::create_dir_all(&args.out).map_err(|e| format!("{}: {e}", args.out.display()))?;
    let mut frames = Vec::new();
    let drive_start = Instant::now();
    for t in 0..sequence.frames() {
        let p: Vec<f32> = sequence
            .pose(t)
            .iter()
            .take(72)
            .map(|&v| v as f32)
            .collect();
        if p.len() != 72 {
            return Err(format!(
                "{}: poses need 72 SMPL values per frame",
                args.poses
                    .as_ref()
                    .map_or("walk".into(), |p| p.display().to_string())
            ));
        }
        // Walk in place: keep the body where the inputs saw it (vertical motion kept).
        let tr = sequence.translation(t);
        let trans = [
            subject.translation[0] as f32,
            tr[1] as f32,
            subject.translation[2] as f32,
        ];
        let input = PoseInput::from_axis_angle(
            betas.clone(),
            Tensor::from_data(TensorData::new(p, [1, 72]), &device),
            Tensor::from_data(TensorData::new(trans.to_vec(), [1, 3]), &device),
        );
        let posed = avatar.drive(pose(&tensors, &input).vertices, &faces, &anchors);
        let splats = splatzoo_train::nlf_data::posed_splats(posed);
        let render = rasterize(
            &splats,
            background.clone(),
            &RasterSettings::new(camera, ColorMode::Sh { degree: 0 }),
        )
        .map_err(|e| e.to_string())?;
        let image = srgb_image(&render.color);
        write_png(&args.out.join(format!("frame_{t:04}.png")), &image)
            .map_err(|e| e.to_string())?;
        frames.push(image);
    }
    let driving = drive_start.elapsed().as_secs_f64() / frames.len().max(1) as f64;
    write_gif(&args.out.join("drive.gif"), &frames, 12).map_err(|e| e.to_string())?;
    println!(
        "generated in {:.2} s; drove {} frames at {:.1} fps; wrote {}",
        generated,
        frames.len(),
        1.0 / driving,
        args.out.display()
    );
    Ok(())
}
