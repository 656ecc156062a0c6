//! `transfer-illum`: human A moved into reconstructed scene B (spec §5(b), the paper's Fig. 8).
//! A's Gaussians, albedo, F_m and F_vis are posed by B's body track and lit by **B's** light
//! volume; B's shadow decoder darkens B's scene Gaussians under them; one render call per
//! frame. On the synthetic captures B's video films the same person doing the same walk in
//! room B, so B's frames are the ground truth of the transfer: the human-crop PSNR is printed
//! for A lit by B's probes and, as the control, for A keeping A's own light.
//!
//! ```sh
//! cargo run --release --bin train-illum -- --name room-b --set data.room='"b"'
//! cargo run --release --bin transfer-illum -- \
//!     --human runs/illum/default/checkpoint.safetensors \
//!     --scene runs/illum/room-b/checkpoint.safetensors
//! ```

use clap::Parser;
use splatzoo_illum::IllumError;
use splatzoo_illum::eval::{person_box, untracked};
use splatzoo_illum::method::Illum;
use splatzoo_illum::render::{HumanLayer, SceneLayer, render_joint};
use splatzoo_illum::steps::Nets;
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
    let (mut sums, mut count, mut frames) = ([0.0f64; 2], 0usize, Vec::new());
    for frame in b.capture.frames.iter().step_by(args.stride.max(1)) {
        let query = FrameQuery {
            camera: &frame.camera,
            frame: frame.frame,
            time: 0.0,
        };
        let pose = a.pose_of(b.track(), frame.frame, true);
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
            if let Some((rows, cols)) = person_box(frame) {
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
    println!(
        "{} frames (transfer | A's own light | B's truth) to {}; human-crop PSNR against B's \
         truth: lit by B's probes {:.2} dB, keeping A's light {:.2} dB",
        frames.len(),
        out.display(),
        sums[0] / n,
        sums[1] / n
    );
    Ok(())
}

fn main() -> ExitCode {
    splatzoo_train::harness::cli::exit(run(&Args::parse()))
}
