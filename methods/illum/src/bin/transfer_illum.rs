//! `transfer-illum`: human A moved into reconstructed scene B (spec §5(b), the paper's Fig. 8).
//! A's Gaussians, albedo, F_m and F_vis are posed by B's body track and lit by **B's** light
//! volume; B's shadow decoder darkens B's scene Gaussians under them; one render call per
//! frame. On the synthetic captures B's video films the same person doing the same walk in
//! room B, so B's frames are the ground truth of the transfer: the human-crop PSNR is printed
//! for A lit by B's probes and, as the control, for A keeping A's own light.
//!
//!
//! `--poses` drives A by another motion (an AMASS-layout `.npz`; `--up y` for files already
//! y-up), looped over B's frames with A's own body shape; `--place X,Z` stands its first frame
//! at that floor point of B (default: where B's person starts) and `--yaw` turns the walk about
//! the vertical. A moved or re-driven human has no ground truth in B's video, so no PSNR is
//! printed for it.
//!
//! ```sh
//! cargo run --release --bin train-illum -- --name room-b --set data.room='"b"'
//! cargo run --release --bin transfer-illum -- \
//!     --human runs/illum/default/checkpoint.safetensors \
//!     --scene runs/illum/room-b/checkpoint.safetensors
//! cargo run --release --bin transfer-illum -- --human … --scene … \
//!     --poses walk.npz --place 0.5,-1.0 --yaw 90
//! ```

use clap::Parser;
use splatzoo_datasets::pose_sequence::{PoseSequence, UpAxis, load_driving_sequence};
use splatzoo_illum::IllumError;
use splatzoo_illum::eval::{person_box, untracked};
use splatzoo_illum::method::Illum;
use splatzoo_illum::render::{HumanLayer, SceneLayer, render_joint};
use splatzoo_illum::steps::Nets;
use splatzoo_illum::trainer::IllumTrainer;
use splatzoo_rasterizer::{ColorMode, RasterSettings};
use splatzoo_train::TrainError;
use splatzoo_train::checkpoint::Checkpoint;
use splatzoo_train::harness::{Method, checkpoint_config};
use splatzoo_train::host_f32;
use splatzoo_train::images::{side_by_side, srgb_image, write_gif, write_png};
use splatzoo_train::loss::psnr;
use splatzoo_train::scene::{FrameContext, FrameQuery, SceneNode};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(Debug, Parser)]
#[command(about = "Move a trained Illum human into another reconstructed scene")]
struct Args {
    /// The human's run (its checkpoint).
    #[arg(long)]
    human: PathBuf,
    /// The scene's run (its checkpoint).
    #[arg(long)]
    scene: PathBuf,
    /// Every this many frames of the scene's video is rendered.
    #[arg(long, default_value_t = 5)]
    stride: usize,
    /// Where the images go (default: `transfer/` beside the scene's checkpoint).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Another motion for A (an AMASS-layout `.npz`), looped over B's frames.
    #[arg(long)]
    poses: Option<PathBuf>,
    /// The up axis of `--poses` (AMASS: z).
    #[arg(long, value_enum, default_value_t = UpAxis::Z)]
    up: UpAxis,
    /// The floor point `X,Z` (metres, B's world) where A's first frame stands (default: where
    /// B's person starts).
    #[arg(long, value_parser = floor_point)]
    place: Option<[f64; 2]>,
    /// Turns A's walk about the vertical, degrees.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    yaw: f64,
}

/// `X,Z` as two finite numbers.
fn floor_point(text: &str) -> Result<[f64; 2], String> {
    let values: Vec<f64> = text
        .split(',')
        .map(|v| v.trim().parse::<f64>().map_err(|e| format!("`{v}`: {e}")))
        .collect::<Result<_, _>>()?;
    match values[..] {
        [x, z] if x.is_finite() && z.is_finite() => Ok([x, z]),
        _ => Err(format!("expected `X,Z` (two finite numbers), got `{text}`")),
    }
}

/// A's motion in B: B's body track, or `--poses` / `--place` / `--yaw` applied to it; `true`
/// when it is B's own track (so B's frames are its ground truth).
fn motion_in_b(
    args: &Args,
    a: &IllumTrainer,
    b: &IllumTrainer,
) -> Result<(PoseSequence, bool), TrainError> {
    let track = b.track();
    if args.poses.is_none() && args.place.is_none() && args.yaw == 0.0 {
        return Ok((track.clone(), true));
    }
    let model = &a.mesh.model;
    let source = match &args.poses {
        Some(path) => {
            load_driving_sequence(path, model.joint_count(), model.shape_count(), args.up)?
        }
        None => track.clone(),
    };
    let start = track.translation(0);
    let at = args.place.unwrap_or([start[0], start[2]]);
    let betas = a.track().frame_betas(0).to_vec();
    let motion = source
        .placed(at, args.yaw)
        .looped(track.frames(), &betas)
        .ok_or_else(|| IllumError::Input {
            what: args
                .poses
                .as_ref()
                .map_or("--poses".into(), |p| p.display().to_string()),
            problem: "the pose sequence has no frames".into(),
        })?;
    Ok((motion, false))
}

fn load(path: &Path) -> Result<Illum, TrainError> {
    let checkpoint = Checkpoint::read(path)?;
    let config = checkpoint_config::<Illum>(&checkpoint)?;
    let device = config.backend.device();
    let method = Illum::resume(config, &checkpoint, &device)?;
    if method.trainer.stage2.is_none() {
        return Err(IllumError::Input {
            what: path.display().to_string(),
            problem: "the run ended before stage 2: no PBR human or probes to transfer".into(),
        }
        .into());
    }
    Ok(method)
}

fn run(args: &Args) -> Result<(), TrainError> {
    let (a, b) = (load(&args.human)?, load(&args.scene)?);
    let (a, b) = (&a.trainer, &b.trainer);
    if !a.config.ablation.light_volume {
        return Err(IllumError::Input {
            what: args.human.display().to_string(),
            problem: "trained without the light volume: its colours are baked, not relightable"
                .into(),
        }
        .into());
    }
    let out = args.out.clone().unwrap_or_else(|| {
        args.scene
            .parent()
            .unwrap_or(Path::new("."))
            .join("transfer")
    });
    std::fs::create_dir_all(&out).map_err(|source| TrainError::System {
        what: format!("cannot create {}", out.display()),
        source,
    })?;
    let (a_volume, _, a_materials) = a.frozen();
    let (b_volume, b_decoder, _) = b.frozen();
    let lit_by_b = Nets {
        volume: &b_volume,
        decoder: &b_decoder,
        materials: &a_materials,
    };
    let lit_by_a = Nets {
        volume: &a_volume,
        decoder: &b_decoder,
        materials: &a_materials,
    };
    let context = FrameContext { outputs: &[] };
    let human_a = a.stage2.as_ref().expect("checked");
    let sampling = a.config.stage2.sampling(false);
    let (motion, truth) = motion_in_b(args, a, b)?;
    let (mut sums, mut count, mut frames) = ([0.0f64; 2], 0usize, Vec::new());
    for frame in b.capture.frames.iter().step_by(args.stride.max(1)) {
        let query = FrameQuery {
            camera: &frame.camera,
            frame: frame.frame,
            time: 0.0,
        };
        let pose = a.pose_of(&motion, frame.frame, true);
        let canonical = untracked(human_a.human.render(&query, &context).splats);
        let scene = untracked(b.scene.render(&query, &context).splats);
        let settings = RasterSettings::new(frame.camera, ColorMode::Features);
        let mut images = Vec::new();
        for (k, nets) in [lit_by_b, lit_by_a].into_iter().enumerate() {
            let (human, [colour, material, albedo, normals]) =
                a.stage2_human(nets, &canonical, &pose, &frame.camera, sampling, None);
            let points: Vec<[f64; 3]> = host_f32(&human.means)
                .chunks(3)
                .map(|p| [p[0], p[1], p[2]].map(f64::from))
                .collect();
            let (ao, _) = b.scene_ao(nets, &scene.means, &points)?;
            let maps = render_joint(
                Some(SceneLayer {
                    splats: &scene,
                    degree: b.scene_degree(b.step),
                    ao,
                }),
                Some(HumanLayer {
                    splats: &human,
                    colour,
                    material,
                    albedo,
                    normals,
                }),
                &settings,
                b.capture.background,
            )?;
            if let Some((rows, cols)) = person_box(frame).filter(|_| truth) {
                let crop = |t: burn::tensor::Tensor<3>| t.slice([rows.clone(), cols.clone(), 0..3]);
                sums[k] += psnr(
                    crop(maps.colour.clone()),
                    crop(frame.image.clone().autodiff()),
                );
                count += usize::from(k == 0);
            }
            images.push(srgb_image(&maps.colour.inner().clamp(0.0, 1.0)));
        }
        images.push(srgb_image(&frame.image));
        write_png(
            &out.join(format!("transfer_{:04}.png", frame.frame)),
            &side_by_side(&images),
        )?;
        frames.push(images.swap_remove(0));
    }
    write_gif(&out.join("transfer.gif"), &frames, 5)?;
    let n = count.max(1) as f64;
    if truth {
        println!(
            "{} frames (transfer | A's own light | B's truth) to {}; human-crop PSNR against \
             B's truth: lit by B's probes {:.2} dB, keeping A's light {:.2} dB",
            frames.len(),
            out.display(),
            sums[0] / n,
            sums[1] / n
        );
    } else {
        let t = motion.translation(0);
        println!(
            "{} frames (transfer | A's own light | B's video) to {}; A placed with its first \
             root at ({:.2}, {:.2}, {:.2}) m, turned {:.0}°: no ground truth in B's video, so \
             no PSNR",
            frames.len(),
            out.display(),
            t[0],
            t[1],
            t[2],
            args.yaw
        );
    }
    Ok(())
}

fn main() -> ExitCode {
    splatzoo_train::harness::cli::exit(run(&Args::parse()))
}
