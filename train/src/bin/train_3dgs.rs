//! `train-3dgs`: static-scene 3D Gaussian splatting on the synthetic static preset (a yard seen by
//! 48 cameras; every 8th held out), the scene-prior stage other methods reuse.
//!
//! ```sh
//! cargo run --release --bin train-3dgs                 # embedded default
//! cargo run --release --bin train-3dgs -- --iterations 3000 --size 128
//! ```
//!
//! So far: initialisation from back-projected depth of the training views (an RGB-D stand-in
//! for SfM points), Adam with the 3DGS per-group learning rates and exponential position decay
//! ([`splatzoo_train::optimizer`]),
//! the L1 + D-SSIM loss, SH degree raised every 1000 steps, held-out PSNR/SSIM, an INRIA `.ply`
//! and `metrics.json` in `runs/3dgs/<name>/`. Densification, checkpoints and configs come next.

use burn::tensor::{Device, Tensor, TensorData};
use clap::Parser;
use splatzoo_datasets::image_io::linear_to_srgb;
use splatzoo_datasets::synth::{Preset, SceneConfig};
use splatzoo_rasterizer::{Camera, ColorMode, RasterSettings, rasterize};
use splatzoo_train::gaussians::GaussianSet;
use splatzoo_train::loss::{photometric, psnr, scalar, ssim};
use splatzoo_train::optimizer::{GaussianOptimizer, LearningRates};
use splatzoo_train::ply::write_ply;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

#[derive(Parser, Debug)]
#[command(about = "Train static 3D Gaussian splatting on the synthetic static scene")]
struct Args {
    #[arg(long, default_value_t = 2000)]
    iterations: usize,
    /// Image side in pixels.
    #[arg(long, default_value_t = 96)]
    size: u32,
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Back-project every N-th pixel of each training view's depth to initialise.
    #[arg(long, default_value_t = 4)]
    init_stride: usize,
    /// Run name under runs/3dgs/.
    #[arg(long, default_value = "default")]
    name: String,
}

struct View {
    camera: Camera,
    /// `[H, W, 3]` sRGB in [0, 1].
    image: Tensor<3>,
}

fn main() -> ExitCode {
    let args = Args::parse();
    if args.iterations == 0 || args.size < 16 || args.init_stride == 0 {
        eprintln!("error: --iterations ≥ 1, --size ≥ 16 and --init-stride ≥ 1");
        return ExitCode::FAILURE;
    }
    let device = Device::flex();
    let start = Instant::now();
    let scene = SceneConfig {
        width: args.size,
        height: args.size,
        ..SceneConfig::new(Preset::Static, args.seed)
    }
    .build(&device);
    let rendered = scene.render_frame(0);
    let background_srgb = scene.environment.background.map(linear_to_srgb);
    let mut train = Vec::new();
    let mut test = Vec::new();
    let (mut positions, mut colours, mut sigmas) = (Vec::new(), Vec::new(), Vec::new());
    for (k, view) in rendered.iter().enumerate() {
        let r = &view.render;
        let (w, h) = (r.width, r.height);
        let srgb: Vec<f32> = r.color.iter().flat_map(|c| c.map(linear_to_srgb)).collect();
        let image = Tensor::<3>::from_data(TensorData::new(srgb.clone(), [h, w, 3]), &device);
        let held_out = k % 8 == 0;
        if !held_out {
            let cam = view.camera;
            let m = cam.world_to_camera;
            for y in (0..h).step_by(args.init_stride) {
                for x in (0..w).step_by(args.init_stride) {
                    let d = r.depth[y * w + x];
                    if !d.is_finite() {
                        continue;
                    }
                    let c = [
                        d * (x as f32 + 0.5 - cam.cx) / cam.fx,
                        d * (y as f32 + 0.5 - cam.cy) / cam.fy,
                        d,
                    ];
                    // World = Rᵀ (c − t).
                    let p: [f32; 3] =
                        std::array::from_fn(|j| (0..3).map(|i| m[i][j] * (c[i] - m[i][3])).sum());
                    positions.push(p);
                    colours.push([
                        srgb[3 * (y * w + x)],
                        srgb[3 * (y * w + x) + 1],
                        srgb[3 * (y * w + x) + 2],
                    ]);
                    sigmas.push(0.5 * args.init_stride as f32 * d / cam.fx);
                }
            }
        }
        let v = View {
            camera: view.camera,
            image,
        };
        if held_out {
            test.push(v)
        } else {
            train.push(v)
        }
    }
    let mut set = GaussianSet::from_points(&positions, &colours, &sigmas, &device);
    println!(
        "static scene seed {}: {} train / {} test views at {}², {} Gaussians; ready in {:.1} s",
        args.seed,
        train.len(),
        test.len(),
        args.size,
        set.len(),
        start.elapsed().as_secs_f64()
    );
    let extent = 3.5f64;
    let mut optimizer = GaussianOptimizer::new(&set, LearningRates::default(), extent);
    let background = Tensor::<1>::from_floats(background_srgb.as_slice(), &device);
    let train_start = Instant::now();
    let mut order: Vec<usize> = Vec::new();
    let mut rng_state = args.seed ^ 0x3D65;
    for it in 0..args.iterations {
        if order.is_empty() {
            order = (0..train.len()).collect();
            // Fisher–Yates with a SplitMix64 stream.
            for i in (1..order.len()).rev() {
                rng_state = rng_state.wrapping_add(0x9E37_79B9_7F4A_7C15);
                let mut z = rng_state;
                z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
                z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
                order.swap(i, ((z ^ (z >> 31)) % (i as u64 + 1)) as usize);
            }
        }
        let view = &train[order.pop().expect("refilled")];
        let degree = (it / 1000).min(3) as u32;
        let settings = RasterSettings::new(view.camera, ColorMode::Sh { degree });
        let leaves = set.leaves();
        let render = match rasterize(&leaves.splats(), background.clone().autodiff(), &settings) {
            Ok(r) => r,
            Err(e) => {
                eprintln!("error: step {it}: {e}");
                return ExitCode::FAILURE;
            }
        };
        let loss = photometric(render.color, view.image.clone().autodiff(), 0.2);
        let grads = loss.backward();
        optimizer.step(
            &mut set,
            &leaves,
            &grads,
            it as f64 / args.iterations as f64,
        );
        if (it + 1) % 200 == 0 || it + 1 == args.iterations {
            println!(
                "step {:>5}: loss {:.4}, {:.1} it/s",
                it + 1,
                scalar(loss.inner()),
                (it + 1) as f64 / train_start.elapsed().as_secs_f64()
            );
        }
    }
    let (mut psnr_sum, mut ssim_sum) = (0.0, 0.0);
    for view in &test {
        let settings = RasterSettings::new(view.camera, ColorMode::Sh { degree: 3 });
        let render =
            rasterize(&set.splats(), background.clone(), &settings).expect("validated above");
        let image = render.color.clamp(0.0, 1.0);
        psnr_sum += psnr(image.clone(), view.image.clone());
        ssim_sum += scalar(ssim(image, view.image.clone()));
    }
    let (test_psnr, test_ssim) = (psnr_sum / test.len() as f64, ssim_sum / test.len() as f64);
    let seconds = start.elapsed().as_secs_f64();
    println!("held-out PSNR {test_psnr:.2} dB, SSIM {test_ssim:.4}; {seconds:.0} s in all");
    let dir = PathBuf::from("runs/3dgs").join(&args.name);
    if let Err(e) = std::fs::create_dir_all(&dir) {
        eprintln!("error: {}: {e}", dir.display());
        return ExitCode::FAILURE;
    }
    if let Err(e) = write_ply(&dir.join("point_cloud.ply"), &set) {
        eprintln!("error: {e}");
        return ExitCode::FAILURE;
    }
    let metrics = serde_json::json!({
        "iterations": args.iterations, "size": args.size, "seed": args.seed,
        "gaussians": set.len(), "test_psnr": test_psnr, "test_ssim": test_ssim, "seconds": seconds,
    });
    if let Err(e) = std::fs::write(dir.join("metrics.json"), metrics.to_string()) {
        eprintln!("error: {e}");
        return ExitCode::FAILURE;
    }
    println!("wrote {}", dir.display());
    ExitCode::SUCCESS
}
