//! `relight-illum`: a trained Illum human under a new environment (spec §5(a), the paper's
//! Fig. 9). The environment — a user's Radiance `.hdr` or a procedural sky with a sun — is
//! projected onto the probes' SH, scaled by `--exposure`, optionally turned about the up
//! axis, and written into every probe; the human is PBR-shaded by it while the scene stays as
//! trained (its light is baked). Writes `relit_<frame>.png` (relit | as trained) per held-out
//! frame and `relit.gif`; with `--spin N`, N frames of one view as the environment turns once.
//!
//! ```sh
//! cargo run --release --bin relight-illum -- --checkpoint runs/illum/default/checkpoint.safetensors
//! cargo run --release --bin relight-illum -- --checkpoint … --hdr studio.hdr --rotate 90
//! cargo run --release --bin relight-illum -- --checkpoint … --sun-elevation 15 --spin 24
//! ```

use burn::module::Module;
use burn::tensor::{Tensor, TensorData};
use clap::Parser;
use splatzoo_illum::IllumError;
use splatzoo_illum::environment::{EquirectMap, Sky};
use splatzoo_illum::method::Illum;
use splatzoo_illum::steps::Nets;
use splatzoo_train::TrainError;
use splatzoo_train::checkpoint::Checkpoint;
use splatzoo_train::harness::{Method, checkpoint_config};
use splatzoo_train::images::{side_by_side, srgb_image, write_gif, write_png};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Debug, Parser)]
#[command(about = "Relight a trained Illum human under a new environment")]
struct Args {
    /// The run's checkpoint (`runs/illum/<name>/checkpoint.safetensors`).
    #[arg(long)]
    checkpoint: PathBuf,
    /// A Radiance `.hdr` environment (equirectangular, +y up); without it, a procedural sky.
    #[arg(long)]
    hdr: Option<PathBuf>,
    /// The procedural sun's elevation and azimuth in degrees, and its irradiance.
    #[arg(long, default_value_t = 40.0)]
    sun_elevation: f64,
    #[arg(long, default_value_t = 60.0)]
    sun_azimuth: f64,
    #[arg(long, default_value_t = 2.5)]
    sun: f32,
    /// Multiplies the environment's radiance.
    #[arg(long, default_value_t = 1.0)]
    exposure: f64,
    /// Turns the environment about the up axis, degrees.
    #[arg(long, default_value_t = 0.0)]
    rotate: f64,
    /// Instead of the held-out frames: this many views of the first held-out frame while the
    /// environment turns once.
    #[arg(long)]
    spin: Option<usize>,
    /// Where the images go (default: `relit/` beside the checkpoint).
    #[arg(long)]
    out: Option<PathBuf>,
}

fn run(args: &Args) -> Result<(), TrainError> {
    let checkpoint = Checkpoint::read(&args.checkpoint)?;
    let config = checkpoint_config::<Illum>(&checkpoint)?;
    let device = config.backend.device();
    let method = Illum::resume(config, &checkpoint, &device)?;
    let t = &method.trainer;
    if t.stage2.is_none() {
        return Err(IllumError::Input {
            what: args.checkpoint.display().to_string(),
            problem: "the run ended before stage 2: its human has no materials to relight".into(),
        }
        .into());
    }
    let out = args.out.clone().unwrap_or_else(|| {
        args.checkpoint
            .parent()
            .unwrap_or(std::path::Path::new("."))
            .join("relit")
    });
    std::fs::create_dir_all(&out).map_err(|source| TrainError::System {
        what: format!("cannot create {}", out.display()),
        source,
    })?;
    let map = args.hdr.as_deref().map(EquirectMap::read_hdr).transpose()?;
    let sky = Sky {
        sun_elevation: args.sun_elevation,
        sun_azimuth: args.sun_azimuth,
        sun: [args.sun; 3],
        ..Sky::default()
    };
    let degree = t.volume.degree();
    let environment = |rotation: f64| -> Tensor<2> {
        let sh = match &map {
            Some(map) => map.project(degree, rotation),
            None => sky.project(degree, rotation),
        };
        let k = sh.len();
        let flat: Vec<f32> = sh
            .iter()
            .flat_map(|c| c.map(|v| (v * args.exposure) as f32))
            .collect();
        Tensor::from_data(TensorData::new(flat, [k, 3]), &t.autodiff)
    };
    let (trained, decoder, materials) = t.frozen();
    let as_trained = Nets {
        volume: &trained,
        decoder: &decoder,
        materials: &materials,
    };
    let tests: Vec<_> = t.capture.test_frames().collect();
    let first = tests.first().ok_or_else(|| {
        TrainError::from(IllumError::Input {
            what: "capture".into(),
            problem: "no held-out frame to relight".into(),
        })
    })?;
    let views: Vec<(usize, f64)> = match args.spin {
        Some(n) => (0..n.max(1))
            .map(|i| (0, args.rotate + 360.0 * i as f64 / n.max(1) as f64))
            .collect(),
        None => (0..tests.len()).map(|k| (k, args.rotate)).collect(),
    };
    let mut frames = Vec::new();
    for (i, (k, rotation)) in views.into_iter().enumerate() {
        let frame = if args.spin.is_some() {
            first
        } else {
            &tests[k]
        };
        let mut relit = trained.clone();
        relit.set_environment(environment(rotation));
        let relit = relit.no_grad();
        let nets = Nets {
            volume: &relit,
            ..as_trained
        };
        let pose = t.frame_pose(frame.frame, true);
        let lit = t.render_view(nets, &frame.camera, &pose, true)?;
        let before = t.render_view(as_trained, &frame.camera, &pose, true)?;
        let image = srgb_image(&lit.colour.inner().clamp(0.0, 1.0));
        let pair = side_by_side(&[
            image.clone(),
            srgb_image(&before.colour.inner().clamp(0.0, 1.0)),
        ]);
        write_png(&out.join(format!("relit_{i:04}.png")), &pair)?;
        frames.push(image);
    }
    write_gif(&out.join("relit.gif"), &frames, 8)?;
    println!(
        "wrote {} relit frames and relit.gif to {}",
        frames.len(),
        out.display()
    );
    Ok(())
}

fn main() -> ExitCode {
    splatzoo_train::harness::cli::exit(run(&Args::parse()))
}
