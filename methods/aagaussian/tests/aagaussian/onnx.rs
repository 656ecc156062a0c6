//! Spec S4 and acceptance check 6: a random-weight denoiser exported by burn-onnx and run in
//! tract through `OnnxScore` equals the same network run by Burn, alone and inside the SDS
//! driver; `train-aag`'s trainer takes steps guided by it; a TOML or an embeddings file that
//! does not fit is named in the error.

use crate::common::tiny_portrait;
use crate::sds::crate_seed;
use splatzoo_aagaussian::Aag;
use splatzoo_aagaussian::config::AagConfig;
use splatzoo_aagaussian::onnx_score::OnnxScore;
use splatzoo_aagaussian::prompts::PromptEmbeddings;
use splatzoo_aagaussian::schedule::NoiseSchedule;
use splatzoo_aagaussian::score::{
    Conditioning, LatentBatch, Prediction, PromptKind, ScoreModel, ViewClass,
};
use splatzoo_aagaussian::sds::{SdsConfig, SdsView};
use splatzoo_aagaussian::tiny_unet::{BurnScore, TinyDenoiser, write_guidance};
use splatzoo_datasets::synth::rng::Rng;
use splatzoo_rasterizer::Camera;
use splatzoo_train::backend::Backend;
use std::path::{Path, PathBuf};

const TOKENS: usize = 5;
pub const CHANNELS: usize = 6;

fn random_rows(rng: &mut Rng, count: usize) -> Vec<Vec<f32>> {
    (0..count)
        .map(|_| {
            (0..TOKENS * CHANNELS)
                .map(|_| rng.normal() as f32)
                .collect()
        })
        .collect()
}

pub fn prompts(rng: &mut Rng) -> PromptEmbeddings {
    PromptEmbeddings::from_rows(
        TOKENS,
        CHANNELS,
        random_rows(rng, 4),
        random_rows(rng, 4),
        random_rows(rng, 1).remove(0),
    )
}

/// Exports `net` for 8² inputs and writes its TOML and embeddings beside it.
pub fn write_model(net: &TinyDenoiser, prompts: &PromptEmbeddings, dir: &Path) -> PathBuf {
    write_guidance(net, prompts, 8, 1.0, dir).expect("exported")
}

fn camera() -> Camera {
    Camera::look_at([0.0, 0.0, 2.0], [0.0; 3], [0.0, 1.0, 0.0], 50.0, 8, 8)
}

#[test]
fn onnx_guidance_equals_its_burn_twin() {
    let seed = crate_seed();
    let device = Backend::Flex.device();
    device.seed(seed);
    let mut rng = Rng(seed);
    let net = TinyDenoiser::new(8, CHANNELS, &device);
    let prompts = prompts(&mut rng);
    let dir = tempfile::tempdir().expect("temp dir");
    let toml = write_model(&net, &prompts, dir.path());
    let onnx = OnnxScore::load(&toml).expect("loads");
    let burn = BurnScore {
        net,
        schedule: NoiseSchedule::sd2().zero_snr(),
        prediction: Prediction::Epsilon,
        prompts,
        device,
    };
    assert_eq!(onnx.branches(), 2);
    assert_eq!(onnx.schedule(), burn.schedule());

    // One direct call on 7 rows (the last chunk padded), every prompt kind and view.
    let rows = 7;
    let batch = |c: usize, rng: &mut Rng| LatentBatch {
        shape: [rows, c, 8, 8],
        data: (0..rows * c * 64).map(|_| rng.normal() as f32).collect(),
    };
    let noisy = vec![batch(3, &mut rng), batch(1, &mut rng)];
    let t: Vec<usize> = (0..rows).map(|_| (rng.next() * 999.0) as usize).collect();
    let views = [
        ViewClass::Front,
        ViewClass::Side,
        ViewClass::Back,
        ViewClass::Overhead,
    ];
    let kinds = [PromptKind::Cond, PromptKind::Negative, PromptKind::Null];
    let cond = Conditioning {
        prompts: (0..rows).map(|i| kinds[i % 3]).collect(),
        views: (0..rows).map(|i| views[i % 4]).collect(),
        cameras: vec![camera(); rows],
    };
    let a = onnx.predict(&noisy, &t, &cond).expect("tract runs");
    let b = burn.predict(&noisy, &t, &cond).expect("burn runs");
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(x.shape, y.shape);
        let scale = y.data.iter().fold(0.0f32, |m, v| m.max(v.abs()));
        let diff = x
            .data
            .iter()
            .zip(&y.data)
            .fold(0.0f32, |m, (p, q)| m.max((p - q).abs()));
        assert!(
            diff <= 1e-5 * scale.max(1.0),
            "max difference {diff} at scale {scale}"
        );
    }

    // The whole ANPG driver on both (same random state) gives the same gradients.
    let config = SdsConfig::default();
    let z = vec![
        batch(3, &mut rng).items(0..2),
        batch(1, &mut rng).items(0..2),
    ];
    let views = [
        SdsView {
            camera: camera(),
            view: ViewClass::Front,
        },
        SdsView {
            camera: camera(),
            view: ViewClass::Back,
        },
    ];
    let ga = config
        .guidance(&onnx, &z, &views, 10, &mut Rng(seed ^ 1))
        .expect("onnx guidance");
    let gb = config
        .guidance(&burn, &z, &views, 10, &mut Rng(seed ^ 1))
        .expect("burn guidance");
    assert_eq!(ga.t, gb.t);
    for (x, y) in ga.grads.iter().zip(&gb.grads) {
        for (p, q) in x.data.iter().zip(&y.data) {
            assert!((p - q).abs() <= 1e-4 * (1.0 + q.abs()), "{p} vs {q}");
        }
    }
}

#[test]
fn mismatched_guidance_files_are_named() {
    let device = Backend::Flex.device();
    let mut rng = Rng(crate_seed() ^ 2);
    let net = TinyDenoiser::new(4, CHANNELS, &device);
    let dir = tempfile::tempdir().expect("temp dir");
    let toml = write_model(&net, &prompts(&mut rng), dir.path());
    let text = std::fs::read_to_string(&toml).expect("read");

    let wrong_input = dir.path().join("wrong_input.toml");
    std::fs::write(
        &wrong_input,
        text.replace("\"sample_depth\"]", "\"depth\"]"),
    )
    .expect("w");
    let err = OnnxScore::load(&wrong_input)
        .err()
        .expect("a graph input is unnamed");
    let message = err.to_string();
    assert!(
        message.contains("tiny.onnx") && message.contains("sample_depth"),
        "{message}"
    );

    let wrong_output = dir.path().join("wrong_output.toml");
    std::fs::write(&wrong_output, text.replace("\"eps_depth\"]", "\"noise\"]")).expect("w");
    let message = OnnxScore::load(&wrong_output)
        .err()
        .expect("no such output")
        .to_string();
    assert!(message.contains("no graph output `noise`"), "{message}");

    let mut partial =
        splatzoo_train::checkpoint::Checkpoint::read(&dir.path().join("prompts.safetensors"))
            .expect("read");
    partial.tensors.remove("null");
    partial
        .write(&dir.path().join("prompts.safetensors"))
        .expect("rewritten");
    let message = OnnxScore::load(&toml)
        .err()
        .expect("no null row")
        .to_string();
    assert!(
        message.contains("prompts.safetensors") && message.contains("`null`"),
        "{message}"
    );

    let unknown = dir.path().join("unknown.toml");
    std::fs::write(&unknown, format!("{text}\nguidance_scale = 7.5\n")).expect("w");
    let message = OnnxScore::load(&unknown)
        .err()
        .expect("unknown key")
        .to_string();
    assert!(message.contains("unknown.toml"), "{message}");
}

/// Acceptance check 6: the trainer takes steps guided by the ONNX model.
#[test]
fn the_trainer_steps_with_the_onnx_model() {
    let device = Backend::Flex.device();
    let mut rng = Rng(crate_seed() ^ 3);
    let dir = tempfile::tempdir().expect("temp dir");
    let toml = write_model(
        &TinyDenoiser::new(4, CHANNELS, &device),
        &prompts(&mut rng),
        dir.path(),
    );
    let config = AagConfig {
        guidance_model: Some(toml),
        gaussians: 400,
        batch: 2,
        render_size: 8,
        data: tiny_portrait(8),
        ..AagConfig::default()
    };
    let mut method = Aag::assemble(config, &device).expect("assembles");
    for _ in 0..3 {
        let record = method.trainer.train_step().expect("a step");
        assert!(
            record.loss.is_finite() && record.sds_rgb > 0.0,
            "{record:?}"
        );
        assert_eq!(record.nonfinite, 0);
    }
}

/// A latent-space model: renders go through a (random, diffusers-named) VAE encoder scaled by
/// the model's `latent_scale`, the ONNX denoiser works on 4-channel latents, and the gradient
/// reaches the Gaussians through the encoder.
#[test]
fn the_trainer_steps_with_a_latent_model_behind_a_vae() {
    use splatzoo_aagaussian::config::VaeSpec;
    use splatzoo_models::networks::vae::{VaeConfig, VaeEncoder};
    use splatzoo_models::networks::weights::write_safetensors;
    use splatzoo_train::host_f32;

    let device = Backend::Flex.device();
    let mut rng = Rng(crate_seed() ^ 4);
    let dir = tempfile::tempdir().expect("temp dir");
    let vae_config = VaeConfig {
        block_out_channels: vec![8, 16],
        layers_per_block: 1,
        latent_channels: 4,
        norm_groups: 4,
        scaling_factor: 1.0,
    };
    let weights = dir.path().join("vae.safetensors");
    write_safetensors(
        &weights,
        &VaeEncoder::new(&vae_config, &device).diffusers_tensors(),
    )
    .expect("written");
    let net = TinyDenoiser::with_branches([4, 4], 4, CHANNELS, &device);
    // 16² renders → 8² latents.
    let toml = write_guidance(&net, &prompts(&mut rng), 8, 0.18215, dir.path()).expect("exported");
    let config = AagConfig {
        guidance_model: Some(toml),
        vae: Some(VaeSpec {
            weights,
            block_out_channels: vec![8, 16],
            layers_per_block: 1,
            latent_channels: 4,
            norm_groups: 4,
        }),
        gaussians: 400,
        batch: 2,
        render_size: 16,
        data: tiny_portrait(8),
        ..AagConfig::default()
    };
    let mut method = Aag::assemble(config.clone(), &device).expect("assembles");
    let before = host_f32(&method.trainer.node.set.sh_dc);
    for _ in 0..2 {
        let record = method.trainer.train_step().expect("a step");
        assert!(
            record.loss.is_finite() && record.sds_rgb > 0.0,
            "{record:?}"
        );
    }
    assert_ne!(host_f32(&method.trainer.node.set.sh_dc), before);

    let odd = AagConfig {
        render_size: 15,
        ..config
    };
    let message = Aag::assemble(odd, &device)
        .err()
        .expect("odd size")
        .to_string();
    assert!(message.contains("downsampling"), "{message}");
}

/// Prompt embeddings a text encoder got wrong are named by file, key and shape: a row of
/// another shape than the others, a row that is not `[L, D]`, a non-finite value.
#[test]
fn bad_prompt_embeddings_are_named() {
    let mut rng = Rng(crate_seed() ^ 3);
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("prompts.safetensors");
    let good = prompts(&mut rng);
    good.write(&path).expect("written");
    assert_eq!(PromptEmbeddings::read(&path).expect("read back"), good);
    let broken = |key: &str, shape: Vec<usize>, values: Vec<f32>| -> String {
        let mut file = splatzoo_train::checkpoint::Checkpoint::read(&path).expect("read");
        file.tensors.insert(key.to_owned(), (shape, values));
        let bad = dir.path().join("bad.safetensors");
        file.write(&bad).expect("written");
        PromptEmbeddings::read(&bad)
            .expect_err("refused")
            .to_string()
    };
    let message = broken(
        "null",
        vec![TOKENS + 1, CHANNELS],
        vec![0.0; (TOKENS + 1) * CHANNELS],
    );
    assert!(
        message.contains("bad.safetensors")
            && message.contains("`null`")
            && message.contains(&format!("[{}, {CHANNELS}]", TOKENS + 1))
            && message.contains(&format!("[{TOKENS}, {CHANNELS}]")),
        "{message}"
    );
    let message = broken(
        "cond.side",
        vec![TOKENS * CHANNELS],
        vec![0.0; TOKENS * CHANNELS],
    );
    assert!(
        message.contains("`cond.side`") && message.contains("expected [L, D]"),
        "{message}"
    );
    let mut values = vec![0.5; TOKENS * CHANNELS];
    values[7] = f32::NAN;
    let message = broken("negative.back", vec![TOKENS, CHANNELS], values);
    assert!(
        message.contains("`negative.back`") && message.contains("non-finite value at flat index 7"),
        "{message}"
    );
}
