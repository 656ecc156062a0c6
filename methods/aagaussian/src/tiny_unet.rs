//! A tiny two-branch denoiser in Burn (spec S4's "Burn twin"): RGB and depth inputs joined on
//! channels as HumanGaussian's texture-structure model joins them, a 3 × 3 convolution, a
//! timestep embedding and a pooled text embedding added per channel, SiLU, a 3 × 3 convolution
//! per branch. With random weights it is no denoiser: it exists so the ONNX path
//! ([`crate::onnx_score::OnnxScore`] running its export in tract) can be checked against the same
//! network run by Burn ([`BurnScore`]), names, dtypes, shapes and the timestep cast included.
//! Built only from ops burn-onnx 0.22 lowers (no GroupNorm, no permute, no sin/cos, no
//! integer-to-float cast: its timestep input is a float).

use crate::error::AagError;
use crate::prompts::PromptEmbeddings;
use crate::schedule::NoiseSchedule;
use crate::score::{Conditioning, LatentBatch, Prediction, ScoreModel};
use burn::module::Module;
use burn::nn::conv::{Conv2d, Conv2dConfig};
use burn::nn::{Linear, LinearConfig, PaddingConfig2d};
use burn::tensor::activation::sigmoid;
use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_train::host_f32;

/// The exported graph's input and output names, in order.
pub const INPUTS: [&str; 4] = [
    "sample_rgb",
    "sample_depth",
    "timestep",
    "encoder_hidden_states",
];
pub const OUTPUTS: [&str; 2] = ["eps_rgb", "eps_depth"];

#[derive(Module, Debug)]
pub struct TinyDenoiser {
    conv_in: Conv2d,
    time: Linear,
    text: Linear,
    out_rgb: Conv2d,
    out_depth: Conv2d,
    /// Channels of the two branches (3 and 1 in pixel space; the latent width after a VAE).
    channels: [usize; 2],
}

impl TinyDenoiser {
    /// Random weights (the device's seed), `width` hidden channels, `channels`-wide text rows,
    /// pixel-space branches (RGB and depth).
    pub fn new(width: usize, channels: usize, device: &Device) -> Self {
        Self::with_branches([3, 1], width, channels, device)
    }

    /// As [`Self::new`] with `branches` channels in each branch.
    pub fn with_branches(
        branches: [usize; 2],
        width: usize,
        channels: usize,
        device: &Device,
    ) -> Self {
        let conv = |i, o| {
            Conv2dConfig::new([i, o], [3, 3])
                .with_padding(PaddingConfig2d::Explicit(1, 1, 1, 1))
                .init(device)
        };
        Self {
            conv_in: conv(branches[0] + branches[1], width),
            time: LinearConfig::new(1, width).init(device),
            text: LinearConfig::new(channels, width).init(device),
            out_rgb: conv(width, branches[0]),
            out_depth: conv(width, branches[1]),
            channels: branches,
        }
    }

    /// `([N, C₁, H, W], [N, C₂, H, W], [N] timesteps as floats, [N, L, D])` → the two branches'
    /// outputs.
    /// No op depends on N (the exported row axis stays dynamic).
    pub fn forward(
        &self,
        (rgb, depth, t, text): (Tensor<4>, Tensor<4>, Tensor<1>, Tensor<3>),
    ) -> (Tensor<4>, Tensor<4>) {
        let tokens = text.dims()[1];
        let hidden = self.conv_in.forward(Tensor::cat(vec![rgb, depth], 1));
        let time = sigmoid(
            self.time
                .forward(t.unsqueeze_dim::<2>(1).mul_scalar(1.0 / 1000.0)),
        );
        let pooled = text
            .sum_dim(1)
            .mul_scalar(1.0 / tokens as f64)
            .squeeze_dim::<2>(1);
        let context = self.text.forward(pooled);
        let shift = (time + context).unsqueeze_dim::<3>(2).unsqueeze_dim::<4>(3);
        let hidden = hidden + shift;
        let hidden = hidden.clone() * sigmoid(hidden);
        (
            self.out_rgb.forward(hidden.clone()),
            self.out_depth.forward(hidden),
        )
    }
}

/// [`TinyDenoiser`] as a [`ScoreModel`] run by Burn.
pub struct BurnScore {
    pub net: TinyDenoiser,
    pub schedule: NoiseSchedule,
    pub prediction: Prediction,
    pub prompts: PromptEmbeddings,
    pub device: Device,
}

impl ScoreModel for BurnScore {
    fn schedule(&self) -> &NoiseSchedule {
        &self.schedule
    }

    fn prediction(&self) -> Prediction {
        self.prediction
    }

    fn branches(&self) -> usize {
        2
    }

    fn predict(
        &self,
        noisy: &[LatentBatch],
        t: &[usize],
        cond: &Conditioning,
    ) -> Result<Vec<LatentBatch>, AagError> {
        let [rgb, depth] = noisy else {
            return Err(AagError::input(
                "tiny denoiser",
                format!("takes 2 branches, got {}", noisy.len()),
            ));
        };
        let n = rgb.shape[0];
        let tensor = |b: &LatentBatch| {
            Tensor::<4>::from_data(
                TensorData::new(b.data.clone(), b.shape.to_vec()),
                &self.device,
            )
        };
        let steps: Vec<f32> = t.iter().map(|&v| v as f32).collect();
        let steps = Tensor::<1>::from_data(TensorData::new(steps, [n]), &self.device);
        let text = Tensor::<3>::from_data(
            TensorData::new(
                self.prompts.stacked(cond),
                [n, self.prompts.tokens, self.prompts.channels],
            ),
            &self.device,
        );
        let (a, b) = self.net.forward((tensor(rgb), tensor(depth), steps, text));
        Ok(vec![
            LatentBatch {
                shape: a.dims(),
                data: host_f32(&a),
            },
            LatentBatch {
                shape: b.dims(),
                data: host_f32(&b),
            },
        ])
    }
}

/// The denoiser's TOML for [`crate::onnx_score::OnnxScore`] (graph `tiny.onnx`, embeddings
/// `prompts.safetensors` beside it; a fixed batch of [`EXPORT_ROWS`] rows).
pub fn guidance_toml(latent_scale: f64) -> String {
    format!(
        "graph = \"tiny.onnx\"\nprompt_embeddings = \"prompts.safetensors\"\n\
         prediction = \"epsilon\"\nbatch = {EXPORT_ROWS}\nlatent_scale = {latent_scale:?}\n\
         outputs = [\"eps_rgb\", \"eps_depth\"]\n\
         [inputs]\nsamples = [\"sample_rgb\", \"sample_depth\"]\ntimestep = \"timestep\"\n\
         timestep_type = \"float32\"\nencoder_hidden_states = \"encoder_hidden_states\"\n\
         [schedule]\nzero_snr = true\n"
    )
}

/// Rows of the exported graph: burn-onnx 0.22 cannot keep one symbolic axis shared by several
/// inputs, so the graph has a fixed row count and the TOML's `batch` chunks any call.
pub const EXPORT_ROWS: usize = 2;

/// Exports `net` (inputs `size`² pixels or latents, `prompts`' token shape) as `dir/tiny.onnx` with its
/// inputs and outputs named, writes `prompts` and the TOML beside it, and returns the TOML's
/// path (what `train-aag --guidance-config` takes).
pub fn write_guidance(
    net: &TinyDenoiser,
    prompts: &PromptEmbeddings,
    size: usize,
    latent_scale: f64,
    dir: &std::path::Path,
) -> Result<std::path::PathBuf, AagError> {
    let device = net.conv_in.weight.val().device();
    let rows = EXPORT_ROWS;
    let sample = (
        Tensor::<4>::zeros([rows, net.channels[0], size, size], &device),
        Tensor::<4>::zeros([rows, net.channels[1], size, size], &device),
        Tensor::<1>::ones([rows], &device),
        Tensor::<3>::zeros([rows, prompts.tokens, prompts.channels], &device),
    );
    let graph = dir.join("tiny.onnx");
    let model = burn_onnx::export::OnnxExporter::new()
        .export(net, sample, |m: &TinyDenoiser, x| m.forward(x))
        .map_err(|e| {
            AagError::input(graph.display().to_string(), format!("export failed ({e})"))
        })?;
    splatzoo_train::onnx::write_graph(model.as_bytes(), &INPUTS, &OUTPUTS, &graph)
        .map_err(|e| AagError::input(graph.display().to_string(), e.to_string()))?;
    prompts.write(&dir.join("prompts.safetensors"))?;
    let path = dir.join("guidance.toml");
    let text = guidance_toml(latent_scale);
    splatzoo_models::files::write_atomically(&path, |tmp| std::fs::write(tmp, &text))
        .map_err(|e| AagError::input(path.display().to_string(), e.to_string()))?;
    Ok(path)
}
