//! `aag-write-photo`: the synthetic capture's prompted identity written as a user's portrait
//! (`portrait.png` and OpenPose's `portrait_keypoints.json`: body, face and hands), to try
//! `train-aag --photo` without a photo of one's own. `--tiny-guidance` also writes a
//! random-weight two-branch ONNX denoiser with random prompt embeddings (`tiny_guidance/`): it
//! checks the plumbing of a user's guidance model, and guides toward nothing.
//!
//! ```sh
//! cargo run --release --bin aag-write-photo -- --out runs/aag-photo --tiny-guidance
//! cargo run --release --bin train-aag -- --photo runs/aag-photo/portrait.png \
//!     --guidance-config runs/aag-photo/tiny_guidance/guidance.toml
//! ```

use clap::Parser;
use splatzoo_aagaussian::config::AagConfig;
use splatzoo_aagaussian::data::PortraitCapture;
use splatzoo_aagaussian::prompts::PromptEmbeddings;
use splatzoo_aagaussian::synthetic_photo::write_synthetic_photo;
use splatzoo_aagaussian::tiny_unet::{TinyDenoiser, write_guidance};
use splatzoo_datasets::synth::rng::Rng;
use splatzoo_train::TrainError;
use splatzoo_train::harness::MethodConfig;
use std::path::PathBuf;
use std::process::ExitCode;

/// The tiny denoiser's prompt tokens and channels, and its hidden width.
const TOKENS: usize = 4;
const CHANNELS: usize = 8;
const WIDTH: usize = 8;

#[derive(Debug, Parser)]
#[command(
    about = "Writes the synthetic AAGaussian identity as a user's portrait and its OpenPose JSON"
)]
struct Args {
    /// The folder to write.
    #[arg(long)]
    out: PathBuf,
    /// The photo's side, pixels.
    #[arg(long, default_value_t = 512)]
    size: u32,
    /// Pixel noise of the keypoints.
    #[arg(long, default_value_t = 1.0)]
    noise: f64,
    /// Also a random-weight ONNX denoiser for `--guidance-config` (plumbing only).
    #[arg(long)]
    tiny_guidance: bool,
    /// `key=value` overrides of the configuration whose `data` is photographed and whose
    /// `render_size` the tiny denoiser takes (as `train-aag --set`).
    #[arg(long = "set")]
    overrides: Vec<String>,
}

fn run(args: &Args) -> Result<(), TrainError> {
    let config: AagConfig =
        splatzoo_train::config::load(&AagConfig::default(), None, &args.overrides)?;
    config.validate()?;
    let device = config.backend.device();
    let capture = PortraitCapture::build(&config.data, &device)?;
    let photo = write_synthetic_photo(
        &capture,
        &args.out,
        args.size,
        args.noise,
        config.seed ^ 0x9407,
        &device,
    )?;
    println!(
        "wrote {} and its keypoints (identity {} of seed {}, {} px noise)",
        photo.display(),
        config.data.prompt,
        config.data.seed,
        args.noise
    );
    if args.tiny_guidance {
        let mut rng = Rng(config.seed ^ 0x7172);
        let mut rows = |count: usize| -> Vec<Vec<f32>> {
            (0..count)
                .map(|_| {
                    (0..TOKENS * CHANNELS)
                        .map(|_| rng.normal() as f32)
                        .collect()
                })
                .collect()
        };
        let prompts =
            PromptEmbeddings::from_rows(TOKENS, CHANNELS, rows(4), rows(4), rows(1).remove(0));
        let dir = args.out.join("tiny_guidance");
        std::fs::create_dir_all(&dir).map_err(|e| {
            splatzoo_datasets::DatasetError::file(&dir, format!("cannot create ({e})"))
        })?;
        let net = TinyDenoiser::new(WIDTH, CHANNELS, &device);
        let toml = write_guidance(&net, &prompts, config.render_size as usize, 1.0, &dir)?;
        println!(
            "wrote {} (random weights: checks the plumbing, guides toward nothing)",
            toml.display()
        );
    }
    Ok(())
}

fn main() -> ExitCode {
    splatzoo_train::harness::cli::exit(run(&Args::parse()))
}
