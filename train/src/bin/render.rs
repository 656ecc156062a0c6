//! `render`: Gaussians from a `.ply` (INRIA layout) or a training checkpoint, seen from the
//! cameras of a nerfstudio-style `transforms.json` → PNG colour, 16-bit depth (millimetres) and
//! alpha per camera; and/or an orbit (turntable) around the Gaussians → an animated GIF.
//!
//! ```sh
//! cargo run --release --bin render -- --ply runs/3dgs/default/point_cloud.ply \
//!     --cameras runs/synth/static/transforms.json --out runs/render
//! cargo run --release --bin render -- --checkpoint runs/3dgs/default/checkpoint.safetensors \
//!     --turntable 48 --out runs/render
//! ```
//!
//! The orbit circles the Gaussians' median, about the cameras' mean up direction where cameras
//! are given (else +y), at the cameras' mean distance and height (else twice the extent of the
//! central 90 % of the Gaussians, 20° above).

use burn::tensor::Tensor;
use clap::Parser;
use splatzoo_datasets::DatasetError;
use splatzoo_datasets::nerfstudio::read_transforms;
use splatzoo_rasterizer::{Camera, ColorMode, RasterSettings, rasterize};
use splatzoo_train::TrainError;
use splatzoo_train::backend::Backend;
use splatzoo_train::checkpoint::Checkpoint;
use splatzoo_train::gaussians::GaussianSet;
use splatzoo_train::harness::{Method, check_format};
use splatzoo_train::images::{srgb_image, write_alpha_png, write_depth_png, write_gif, write_png};
use splatzoo_train::ply::read_ply;
use splatzoo_train::static_scene::{BACKGROUND, StaticTrainer};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(Parser, Debug)]
#[command(about = "Render Gaussians (.ply or checkpoint) from cameras or on a turntable")]
struct Args {
    /// INRIA-layout Gaussians.
    #[arg(
        long,
        conflicts_with = "checkpoint",
        required_unless_present = "checkpoint"
    )]
    ply: Option<PathBuf>,
    /// A `train-3dgs` checkpoint (its `background.splats.*` tensors).
    #[arg(long)]
    checkpoint: Option<PathBuf>,
    /// A nerfstudio-style transforms.json: one PNG set per frame.
    #[arg(long)]
    cameras: Option<PathBuf>,
    /// Frames of an orbit GIF (0: none).
    #[arg(long, default_value_t = 0)]
    turntable: usize,
    /// Orbit image side in pixels.
    #[arg(long, default_value_t = 256)]
    size: u32,
    /// Orbit horizontal field of view in degrees.
    #[arg(long, default_value_t = 50.0)]
    fov: f32,
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(0..=3))]
    sh_degree: u32,
    /// Background, sRGB in [0, 1].
    #[arg(long, value_delimiter = ',', num_args = 3, default_values_t = [0.0, 0.0, 0.0])]
    background: Vec<f32>,
    #[arg(long, value_enum, default_value_t = Backend::Flex)]
    backend: Backend,
    #[arg(long, default_value = "runs/render")]
    out: PathBuf,
}

fn main() -> ExitCode {
    splatzoo_train::harness::cli::exit(run(Args::parse()))
}

fn run(args: Args) -> Result<(), TrainError> {
    if args.cameras.is_none() && args.turntable == 0 {
        return Err(TrainError::Config(
            "nothing to render: give --cameras and/or --turntable N".into(),
        ));
    }
    let device = args.backend.device();
    let set = match (&args.ply, &args.checkpoint) {
        (Some(ply), _) => read_ply(ply, &device)?,
        (None, Some(path)) => {
            let checkpoint = Checkpoint::read(path)?;
            check_format(&checkpoint, StaticTrainer::FORMAT)?;
            GaussianSet::load(&checkpoint, &format!("{BACKGROUND}.splats"), &device)?
        }
        (None, None) => unreachable!("clap requires one"),
    };
    if set.is_empty() {
        return Err(TrainError::Config("the Gaussian set is empty".into()));
    }
    std::fs::create_dir_all(&args.out)
        .map_err(|e| DatasetError::file(&args.out, format!("cannot create ({e})")))?;
    let background = Tensor::<1>::from_floats(args.background.as_slice(), &device);
    let splats = set.splats();
    let render = |camera: Camera| {
        let settings = RasterSettings::new(
            camera,
            ColorMode::Sh {
                degree: args.sh_degree,
            },
        );
        rasterize(&splats, background.clone(), &settings)
    };
    let mut cameras = Vec::new();
    if let Some(path) = &args.cameras {
        let frames = read_transforms(path)?;
        for (k, frame) in frames.iter().enumerate() {
            let stem = Path::new(&frame.file_path).file_stem().map_or_else(
                || format!("frame_{k:05}"),
                |s| s.to_string_lossy().into_owned(),
            );
            let r = render(frame.camera)?;
            let out = |suffix: &str| args.out.join(format!("{stem}{suffix}.png"));
            write_png(&out(""), &srgb_image(&r.color))?;
            write_depth_png(&out("_depth"), &r.depth, &r.alpha)?;
            write_alpha_png(&out("_alpha"), &r.alpha)?;
            cameras.push(frame.camera);
        }
        println!(
            "rendered {} cameras into {}",
            frames.len(),
            args.out.display()
        );
    }
    if args.turntable > 0 {
        let orbit = orbit(&set, &cameras, args.turntable, args.size, args.fov);
        let frames = orbit
            .into_iter()
            .map(|camera| render(camera).map(|r| srgb_image(&r.color)))
            .collect::<Result<Vec<_>, _>>()?;
        let path = args.out.join("turntable.gif");
        write_gif(&path, &frames, 24)?;
        println!("wrote {} ({} frames)", path.display(), frames.len());
    }
    Ok(())
}

fn percentile(mut values: Vec<f32>, q: f32) -> f32 {
    values.sort_by(f32::total_cmp);
    values[((values.len() - 1) as f32 * q) as usize]
}

/// `frames` cameras evenly around the Gaussians (see the module doc).
fn orbit(set: &GaussianSet, cameras: &[Camera], frames: usize, size: u32, fov: f32) -> Vec<Camera> {
    let rows = set.to_rows();
    let n = rows.len();
    let centre: [f32; 3] =
        std::array::from_fn(|k| percentile((0..n).map(|i| rows.means[3 * i + k]).collect(), 0.5));
    let sub = |a: [f32; 3], b: [f32; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let dot = |a: [f32; 3], b: [f32; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let normalize = |a: [f32; 3]| {
        let l = dot(a, a).sqrt().max(1e-12);
        a.map(|v| v / l)
    };
    let (up, radius, height) = if cameras.is_empty() {
        let spread = percentile(
            (0..n)
                .map(|i| dot(sub(rows.mean(i), centre), sub(rows.mean(i), centre)).sqrt())
                .collect(),
            0.9,
        );
        let distance = 2.0 * spread.max(1e-3);
        let elevation = 20f32.to_radians();
        (
            [0.0, 1.0, 0.0],
            distance * elevation.cos(),
            distance * elevation.sin(),
        )
    } else {
        // A camera's up in the world is −(row 1 of R) (OpenCV: y points down).
        let up = normalize(std::array::from_fn(|k| {
            -cameras.iter().map(|c| c.world_to_camera[1][k]).sum::<f32>()
        }));
        let (mut radius, mut height) = (0.0, 0.0);
        for c in cameras {
            let d = sub(c.position(), centre);
            let h = dot(d, up);
            height += h;
            radius += (dot(d, d) - h * h).max(0.0).sqrt();
        }
        let count = cameras.len() as f32;
        (up, radius / count, height / count)
    };
    // Two directions perpendicular to `up`.
    let helper = if up[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 0.0, 1.0]
    };
    let a = normalize(sub(helper, up.map(|u| u * dot(helper, up))));
    let b = [
        up[1] * a[2] - up[2] * a[1],
        up[2] * a[0] - up[0] * a[2],
        up[0] * a[1] - up[1] * a[0],
    ];
    (0..frames)
        .map(|f| {
            let t = std::f32::consts::TAU * f as f32 / frames as f32;
            let position: [f32; 3] = std::array::from_fn(|k| {
                centre[k] + radius * (t.cos() * a[k] + t.sin() * b[k]) + height * up[k]
            });
            Camera::look_at(position, centre, up, fov, size, size)
        })
        .collect()
}
