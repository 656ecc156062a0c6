//! SD's VAE encoder (spec acceptance 7 of AAGaussian): diffusers-named weights written from a
//! random encoder load back to the same outputs (also under the older attention names); the
//! latent grid is the image's over 2^(blocks − 1); the pixel gradient of a latent functional
//! matches central finite differences; a missing or misshapen tensor is named.

use crate::common::values;
use burn::tensor::{Device, Distribution, Tensor};
use splatzoo_models::networks::vae::{VaeConfig, VaeEncoder};
use splatzoo_models::networks::weights::{WeightFile, write_safetensors};

fn tiny() -> VaeConfig {
    VaeConfig {
        block_out_channels: vec![8, 16],
        layers_per_block: 1,
        latent_channels: 4,
        norm_groups: 4,
        scaling_factor: 0.18215,
    }
}

fn seed() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .expect("after 1970")
        .as_nanos() as u64
}

#[test]
fn diffusers_weights_round_trip_and_misfits_are_named() {
    let device = Device::flex();
    device.seed(seed());
    let config = tiny();
    let vae = VaeEncoder::new(&config, &device);
    let x = Tensor::<4>::random([2, 3, 16, 16], Distribution::Uniform(-1.0, 1.0), &device);
    let z = vae.encode(x.clone());
    assert_eq!(z.dims(), [2, 4, 8, 8]);
    assert_eq!(config.downsampling(), 2);

    let tensors = vae.diffusers_tensors();
    assert!(tensors.contains_key("encoder.mid_block.attentions.0.to_out.0.weight"));
    assert!(tensors.contains_key("encoder.down_blocks.0.downsamplers.0.conv.weight"));
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("diffusion_pytorch_model.safetensors");
    write_safetensors(&path, &tensors).expect("written");
    let loaded =
        VaeEncoder::load(&config, &WeightFile::read(&path).expect("read"), &device).expect("loads");
    let (a, b) = (values(z), values(loaded.encode(x.clone())));
    let worst = a
        .iter()
        .zip(&b)
        .fold(0.0f32, |m, (p, q)| m.max((p - q).abs()));
    assert!(worst < 1e-5, "reloaded encoder differs by {worst}");

    // The older attention names load the same weights.
    let mut old = tensors.clone();
    for (new, legacy) in [
        ("to_q", "query"),
        ("to_k", "key"),
        ("to_v", "value"),
        ("to_out.0", "proj_attn"),
    ] {
        for part in ["weight", "bias"] {
            let from = format!("encoder.mid_block.attentions.0.{new}.{part}");
            let value = old.remove(&from).expect("written");
            old.insert(
                format!("encoder.mid_block.attentions.0.{legacy}.{part}"),
                value,
            );
        }
    }
    let legacy = VaeEncoder::load(&config, &WeightFile::new("legacy", old), &device)
        .expect("loads old names");
    assert_eq!(values(legacy.encode(x.clone())), a);

    let mut missing = tensors.clone();
    missing.remove("encoder.conv_out.weight");
    let err = VaeEncoder::load(
        &config,
        &WeightFile::new("vae.safetensors", missing),
        &device,
    )
    .expect_err("missing");
    let message = err.to_string();
    assert!(
        message.contains("vae.safetensors") && message.contains("encoder.conv_out.weight"),
        "{message}"
    );
    let mut misshapen = tensors;
    misshapen.insert("quant_conv.bias".into(), (vec![3], vec![0.0; 3]));
    let message = VaeEncoder::load(&config, &WeightFile::new("vae", misshapen), &device)
        .expect_err("misshapen")
        .to_string();
    assert!(
        message.contains("quant_conv.bias") && message.contains("[8]"),
        "{message}"
    );
}

#[test]
fn pixel_gradients_match_finite_differences() {
    let device = Device::flex().autodiff();
    device.seed(seed());
    let vae = VaeEncoder::new(&tiny(), &device);
    let x = Tensor::<4>::random([1, 3, 8, 8], Distribution::Uniform(-1.0, 1.0), &device);
    let w = Tensor::<4>::random([1, 4, 4, 4], Distribution::Normal(0.0, 1.0), &device);
    let objective = |x: Tensor<4>| (vae.encode(x) * w.clone()).sum();
    let leaf = x.clone().require_grad();
    let grads = objective(leaf.clone()).backward();
    let grad = values(leaf.grad(&grads).expect("a leaf"));
    let base = values(x.clone());
    let eps = 1e-2f32;
    for index in [0, 17, 64, 100, 150, 191] {
        let shifted = |delta: f32| {
            let mut v = base.clone();
            v[index] += delta;
            let t = Tensor::<4>::from_data(burn::tensor::TensorData::new(v, [1, 3, 8, 8]), &device);
            f64::from(values(objective(t))[0])
        };
        let numeric = (shifted(eps) - shifted(-eps)) / (2.0 * f64::from(eps));
        let analytic = f64::from(grad[index]);
        assert!(
            (numeric - analytic).abs() < 2e-3 + 5e-2 * analytic.abs(),
            "pixel {index}: {analytic} vs finite difference {numeric}"
        );
    }
}
