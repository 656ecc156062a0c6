//! `pose-body`: load a body model, pose it with a pose sequence, write posed OBJ meshes and a
//! PNG preview, so you can check that your SMPL file and poses load and look right.
//!
//! ```sh
//! cargo run --release --bin pose-body -- --model SMPL_NEUTRAL.npz --poses walk.npz
//! cargo run --release --bin pose-body            # built-in body and demo poses
//! ```

use burn::tensor::Device;
use clap::Parser;
use splatzoo_datasets::image_io::write_rgb_png;
use splatzoo_datasets::obj::{ObjUv, write_obj};
use splatzoo_datasets::pose_sequence::{PoseSequence, load_pose_sequence};
use splatzoo_datasets::posing::{contact_sheet, pose_frames, weight_colours};
use splatzoo_models::body::{BodyKind, builtin_body, load_body_model};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser, Debug)]
#[command(about = "Pose a body model with a pose sequence; write OBJ meshes and a PNG preview")]
struct Args {
    /// Body model (.npz or .pkl: SMPL, SMPL-H, SMPL-X). Default: the built-in body.
    #[arg(long)]
    model: Option<PathBuf>,
    /// Pose sequence .npz (`poses` `[T, 3J]`, `trans` `[T, 3]`, `betas` `[S]` or `[T, S]`).
    /// Default: a few demonstration poses.
    #[arg(long)]
    poses: Option<PathBuf>,
    /// Output folder.
    #[arg(long, default_value = "runs/pose-body")]
    out: PathBuf,
    /// Write an OBJ for every N-th frame.
    #[arg(long, default_value_t = 1)]
    every: usize,
    /// Frames shown in the preview (evenly spaced).
    #[arg(long, default_value_t = 6)]
    preview_frames: usize,
    /// Preview cell size in pixels.
    #[arg(long, default_value_t = 256)]
    cell: usize,
}

/// Rest, A-pose, a walking step, a wave, a squat and a turn, for the built-in default.
fn demo_sequence() -> PoseSequence {
    let frames: Vec<Vec<(usize, [f64; 3])>> = vec![
        vec![],
        vec![(16, [0.0, 0.0, -1.1]), (17, [0.0, 0.0, 1.1])],
        vec![
            (1, [-0.5, 0.0, 0.0]),
            (2, [0.35, 0.0, 0.0]),
            (4, [0.2, 0.0, 0.0]),
            (5, [0.6, 0.0, 0.0]),
            (16, [0.0, 0.0, -1.2]),
            (17, [0.0, 0.0, 1.2]),
            (18, [0.0, -0.4, 0.0]),
            (19, [0.0, 0.4, 0.0]),
        ],
        vec![
            (16, [0.0, 0.0, 0.9]),
            (18, [0.0, -1.4, 0.0]),
            (17, [0.0, 0.0, 1.2]),
            (15, [0.0, 0.3, 0.0]),
        ],
        vec![
            (1, [-1.4, 0.0, 0.0]),
            (2, [-1.4, 0.0, 0.0]),
            (4, [1.9, 0.0, 0.0]),
            (5, [1.9, 0.0, 0.0]),
            (7, [-0.5, 0.0, 0.0]),
            (8, [-0.5, 0.0, 0.0]),
            (3, [0.4, 0.0, 0.0]),
            (16, [0.0, 0.6, -0.3]),
            (17, [0.0, -0.6, 0.3]),
        ],
        vec![
            (0, [0.0, 1.2, 0.0]),
            (12, [0.0, -0.4, 0.0]),
            (16, [0.0, 0.0, -1.1]),
            (17, [0.0, 0.0, 1.1]),
        ],
    ];
    let t = frames.len();
    let mut poses = vec![0.0; t * 72];
    for (f, joints) in frames.iter().enumerate() {
        for &(j, aa) in joints {
            poses[f * 72 + 3 * j..f * 72 + 3 * j + 3].copy_from_slice(&aa);
        }
    }
    PoseSequence {
        joints: 24,
        poses,
        translations: vec![0.0; 3 * t],
        betas: vec![0.0; 0],
        shape_count: 0,
        fps: Some(1.0),
    }
}

fn run(args: Args) -> Result<(), Box<dyn std::error::Error>> {
    let (model, uv) = match &args.model {
        Some(path) => (load_body_model(path)?, None),
        None => {
            let body = builtin_body();
            (body.model.clone(), Some(&body.uv))
        }
    };
    let (seq, source) = match &args.poses {
        Some(path) => (load_pose_sequence(path)?, path.clone()),
        None => (demo_sequence(), PathBuf::from("<demo poses>")),
    };
    if seq.joints != model.joint_count() {
        eprintln!(
            "note: {} has {} joints per frame; the model has {} (mapping body joints, hands at rest)",
            source.display(),
            seq.joints,
            model.joint_count()
        );
    }
    let seq = seq.for_model(model.joint_count(), model.shape_count(), &source)?;
    std::fs::create_dir_all(&args.out)
        .map_err(|e| format!("{}: cannot create ({e})", args.out.display()))?;
    let device = Device::flex();
    let frames = pose_frames(&model, &seq, &device);
    let faces: Vec<[u32; 3]> = model.faces.chunks(3).map(|f| [f[0], f[1], f[2]]).collect();
    let uv_coords: Vec<[f32; 2]>;
    let uv_corners: Vec<[u32; 3]>;
    let obj_uv = match uv {
        Some(uv) => {
            uv_coords = uv.coords.chunks(2).map(|c| [c[0], c[1]]).collect();
            uv_corners = uv.faces.chunks(3).map(|f| [f[0], f[1], f[2]]).collect();
            Some(ObjUv {
                coords: &uv_coords,
                corners: &uv_corners,
            })
        }
        None => None,
    };
    let mut written = 0;
    for (t, vertices) in frames.iter().enumerate().step_by(args.every.max(1)) {
        write_obj(
            &args.out.join(format!("frame_{t:05}.obj")),
            vertices,
            &faces,
            obj_uv.as_ref(),
        )?;
        written += 1;
    }
    let k = args.preview_frames.clamp(1, frames.len());
    let chosen: Vec<&[[f32; 3]]> = (0..k)
        .map(|i| {
            frames[if k == 1 {
                0
            } else {
                i * (frames.len() - 1) / (k - 1)
            }]
            .as_slice()
        })
        .collect();
    let (w, h, sheet) = contact_sheet(&chosen, &faces, &weight_colours(&model), args.cell);
    let preview = args.out.join("preview.png");
    write_rgb_png(&preview, w, h, &sheet)?;
    let kind = match model.kind {
        BodyKind::Smpl => "SMPL",
        BodyKind::SmplH => "SMPL-H",
        BodyKind::SmplX => "SMPL-X",
        BodyKind::Builtin => "built-in",
    };
    println!(
        "{kind} body: {} vertices, {} joints, {} shape coefficients; {} frames from {}",
        model.vertex_count(),
        model.joint_count(),
        model.shape_count(),
        seq.frames(),
        source.display()
    );
    println!(
        "wrote {written} OBJ files and {} to {}",
        preview.display(),
        args.out.display()
    );
    Ok(())
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
