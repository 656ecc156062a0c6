//! The encoder half of Stable Diffusion's VAE (diffusers' `AutoencoderKL`) as a Burn module, so
//! a latent-space denoiser can guide score distillation with an exact `∂z/∂x` (an ONNX encoder
//! run elsewhere would give no gradient): `conv_in`; per block `layers_per_block` ResNet blocks
//! (GroupNorm, SiLU, 3 × 3 convolution, twice, with a 1 × 1 shortcut where the width changes)
//! and, except after the last, a stride-2 convolution after padding one pixel right and below;
//! the middle's ResNet block, single-head self-attention and ResNet block; GroupNorm, SiLU,
//! `conv_out` to `2 · latent` channels and the 1 × 1 `quant_conv`. [`VaeEncoder::encode`]
//! returns the posterior's mean times the scaling factor (SD's 0.18215), the latents a UNet
//! was trained on.
//!
//! Weights load by diffusers' names (`encoder.down_blocks.0.resnets.1.norm2.weight`,
//! `encoder.mid_block.attentions.0.to_q.weight` — or the older `query`/`key`/`value`/
//! `proj_attn` —, `quant_conv.weight`, …) from `diffusion_pytorch_model.safetensors`; a missing
//! or misshapen tensor is an error naming the file and tensor. Linear weights are transposed
//! from PyTorch's `[out, in]`.

use super::weights::{Tensors, WeightFile, WeightsError};
use burn::module::{Module, Param};
use burn::nn::conv::{Conv2d, Conv2dConfig};
use burn::nn::{GroupNorm, GroupNormConfig, Linear, LinearConfig, PaddingConfig2d};
use burn::tensor::activation::{silu, softmax};
use burn::tensor::{Device, Tensor};

/// The encoder's shape (SD's VAE: `[128, 256, 512, 512]`, 2 layers, 4 latents, 32 groups).
#[derive(Debug, Clone, PartialEq)]
pub struct VaeConfig {
    pub block_out_channels: Vec<usize>,
    pub layers_per_block: usize,
    pub latent_channels: usize,
    pub norm_groups: usize,
    pub scaling_factor: f64,
}

impl VaeConfig {
    /// Stable Diffusion 1.x/2.x's VAE (`sd-vae-ft-mse`).
    pub fn stable_diffusion() -> Self {
        Self {
            block_out_channels: vec![128, 256, 512, 512],
            layers_per_block: 2,
            latent_channels: 4,
            norm_groups: 32,
            scaling_factor: 0.18215,
        }
    }

    /// Each image side is divided by this.
    pub fn downsampling(&self) -> usize {
        1 << self.block_out_channels.len().saturating_sub(1)
    }
}

fn conv(i: usize, o: usize, k: usize, device: &Device) -> Conv2d {
    let p = k / 2;
    Conv2dConfig::new([i, o], [k, k])
        .with_padding(PaddingConfig2d::Explicit(p, p, p, p))
        .init(device)
}

fn norm(groups: usize, channels: usize, device: &Device) -> GroupNorm {
    GroupNormConfig::new(groups, channels)
        .with_epsilon(1e-6)
        .init(device)
}

#[derive(Module, Debug)]
struct ResnetBlock {
    norm1: GroupNorm,
    conv1: Conv2d,
    norm2: GroupNorm,
    conv2: Conv2d,
    conv_shortcut: Option<Conv2d>,
}

impl ResnetBlock {
    fn new(i: usize, o: usize, groups: usize, device: &Device) -> Self {
        Self {
            norm1: norm(groups, i, device),
            conv1: conv(i, o, 3, device),
            norm2: norm(groups, o, device),
            conv2: conv(o, o, 3, device),
            conv_shortcut: (i != o).then(|| conv(i, o, 1, device)),
        }
    }

    fn forward(&self, x: Tensor<4>) -> Tensor<4> {
        let h = self.conv1.forward(silu(self.norm1.forward(x.clone())));
        let h = self.conv2.forward(silu(self.norm2.forward(h)));
        let skip = match &self.conv_shortcut {
            Some(c) => c.forward(x),
            None => x,
        };
        skip + h
    }

    fn load(&mut self, file: &WeightFile, prefix: &str) -> Result<(), WeightsError> {
        load_norm(file, &format!("{prefix}.norm1"), &mut self.norm1)?;
        load_conv(file, &format!("{prefix}.conv1"), &mut self.conv1)?;
        load_norm(file, &format!("{prefix}.norm2"), &mut self.norm2)?;
        load_conv(file, &format!("{prefix}.conv2"), &mut self.conv2)?;
        if let Some(c) = &mut self.conv_shortcut {
            load_conv(file, &format!("{prefix}.conv_shortcut"), c)?;
        }
        Ok(())
    }
}

#[derive(Module, Debug)]
struct Attention {
    group_norm: GroupNorm,
    to_q: Linear,
    to_k: Linear,
    to_v: Linear,
    to_out: Linear,
}

impl Attention {
    fn new(c: usize, groups: usize, device: &Device) -> Self {
        let linear = || LinearConfig::new(c, c).init(device);
        Self {
            group_norm: norm(groups, c, device),
            to_q: linear(),
            to_k: linear(),
            to_v: linear(),
            to_out: linear(),
        }
    }

    fn forward(&self, x: Tensor<4>) -> Tensor<4> {
        let [n, c, h, w] = x.dims();
        let tokens = self
            .group_norm
            .forward(x.clone())
            .reshape([n, c, h * w])
            .swap_dims(1, 2); // [N, HW, C]
        let q = self.to_q.forward(tokens.clone());
        let k = self.to_k.forward(tokens.clone());
        let v = self.to_v.forward(tokens);
        let weights = softmax(
            q.matmul(k.swap_dims(1, 2))
                .mul_scalar(1.0 / (c as f64).sqrt()),
            2,
        );
        let out = self.to_out.forward(weights.matmul(v)); // [N, HW, C]
        x + out.swap_dims(1, 2).reshape([n, c, h, w])
    }

    fn load(&mut self, file: &WeightFile, prefix: &str) -> Result<(), WeightsError> {
        load_norm(file, &format!("{prefix}.group_norm"), &mut self.group_norm)?;
        for (new, old, layer) in [
            ("to_q", "query", &mut self.to_q),
            ("to_k", "key", &mut self.to_k),
            ("to_v", "value", &mut self.to_v),
            ("to_out.0", "proj_attn", &mut self.to_out),
        ] {
            let name = if file.tensors.contains_key(&format!("{prefix}.{new}.weight")) {
                new
            } else if file.tensors.contains_key(&format!("{prefix}.{old}.weight")) {
                old
            } else {
                new
            };
            load_linear(file, &format!("{prefix}.{name}"), layer)?;
        }
        Ok(())
    }
}

#[derive(Module, Debug)]
struct DownBlock {
    resnets: Vec<ResnetBlock>,
    downsampler: Option<Conv2d>,
}

/// The encoder (see the module doc).
#[derive(Module, Debug)]
pub struct VaeEncoder {
    conv_in: Conv2d,
    down_blocks: Vec<DownBlock>,
    mid_first: ResnetBlock,
    mid_attention: Attention,
    mid_second: ResnetBlock,
    conv_norm_out: GroupNorm,
    conv_out: Conv2d,
    quant_conv: Conv2d,
    latent_channels: usize,
    scaling_factor: f64,
}

impl VaeEncoder {
    /// Random weights (the device's seed) of the shape `config` gives.
    pub fn new(config: &VaeConfig, device: &Device) -> Self {
        let channels = &config.block_out_channels;
        assert!(!channels.is_empty(), "a VAE needs at least one block");
        let g = config.norm_groups;
        let mut down_blocks = Vec::with_capacity(channels.len());
        let mut width = channels[0];
        for (b, &out) in channels.iter().enumerate() {
            let resnets = (0..config.layers_per_block)
                .map(|l| ResnetBlock::new(if l == 0 { width } else { out }, out, g, device))
                .collect();
            width = out;
            let downsampler = (b + 1 < channels.len()).then(|| {
                Conv2dConfig::new([out, out], [3, 3])
                    .with_stride([2, 2])
                    .with_padding(PaddingConfig2d::Explicit(0, 0, 1, 1))
                    .init(device)
            });
            down_blocks.push(DownBlock {
                resnets,
                downsampler,
            });
        }
        let z = config.latent_channels;
        Self {
            conv_in: conv(3, channels[0], 3, device),
            down_blocks,
            mid_first: ResnetBlock::new(width, width, g, device),
            mid_attention: Attention::new(width, g, device),
            mid_second: ResnetBlock::new(width, width, g, device),
            conv_norm_out: norm(g, width, device),
            conv_out: conv(width, 2 * z, 3, device),
            quant_conv: conv(2 * z, 2 * z, 1, device),
            latent_channels: z,
            scaling_factor: config.scaling_factor,
        }
    }

    /// The encoder of `config`'s shape with diffusers-named weights from `file`.
    pub fn load(
        config: &VaeConfig,
        file: &WeightFile,
        device: &Device,
    ) -> Result<Self, WeightsError> {
        let mut vae = Self::new(config, device);
        load_conv(file, "encoder.conv_in", &mut vae.conv_in)?;
        for (b, block) in vae.down_blocks.iter_mut().enumerate() {
            for (l, resnet) in block.resnets.iter_mut().enumerate() {
                resnet.load(file, &format!("encoder.down_blocks.{b}.resnets.{l}"))?;
            }
            if let Some(d) = &mut block.downsampler {
                load_conv(
                    file,
                    &format!("encoder.down_blocks.{b}.downsamplers.0.conv"),
                    d,
                )?;
            }
        }
        vae.mid_first.load(file, "encoder.mid_block.resnets.0")?;
        vae.mid_attention
            .load(file, "encoder.mid_block.attentions.0")?;
        vae.mid_second.load(file, "encoder.mid_block.resnets.1")?;
        load_norm(file, "encoder.conv_norm_out", &mut vae.conv_norm_out)?;
        load_conv(file, "encoder.conv_out", &mut vae.conv_out)?;
        load_conv(file, "quant_conv", &mut vae.quant_conv)?;
        Ok(vae)
    }

    /// Images `[N, 3, H, W]` in [−1, 1] (H, W multiples of the downsampling) → latents
    /// `[N, latent, H / f, W / f]`: the posterior mean times the scaling factor.
    pub fn encode(&self, images: Tensor<4>) -> Tensor<4> {
        let mut h = self.conv_in.forward(images);
        for block in &self.down_blocks {
            for resnet in &block.resnets {
                h = resnet.forward(h);
            }
            if let Some(d) = &block.downsampler {
                h = d.forward(h);
            }
        }
        h = self
            .mid_second
            .forward(self.mid_attention.forward(self.mid_first.forward(h)));
        let h = self.conv_out.forward(silu(self.conv_norm_out.forward(h)));
        let moments = self.quant_conv.forward(h);
        let [n, _, hh, ww] = moments.dims();
        moments
            .slice([0..n, 0..self.latent_channels, 0..hh, 0..ww])
            .mul_scalar(self.scaling_factor)
    }

    /// Every weight under its diffusers name, PyTorch layout (what [`Self::load`] reads).
    pub fn diffusers_tensors(&self) -> Tensors {
        let mut out = Tensors::new();
        put_conv(&mut out, "encoder.conv_in", &self.conv_in);
        for (b, block) in self.down_blocks.iter().enumerate() {
            for (l, r) in block.resnets.iter().enumerate() {
                put_resnet(&mut out, &format!("encoder.down_blocks.{b}.resnets.{l}"), r);
            }
            if let Some(d) = &block.downsampler {
                put_conv(
                    &mut out,
                    &format!("encoder.down_blocks.{b}.downsamplers.0.conv"),
                    d,
                );
            }
        }
        put_resnet(&mut out, "encoder.mid_block.resnets.0", &self.mid_first);
        let a = &self.mid_attention;
        let prefix = "encoder.mid_block.attentions.0";
        put_norm(&mut out, &format!("{prefix}.group_norm"), &a.group_norm);
        put_linear(&mut out, &format!("{prefix}.to_q"), &a.to_q);
        put_linear(&mut out, &format!("{prefix}.to_k"), &a.to_k);
        put_linear(&mut out, &format!("{prefix}.to_v"), &a.to_v);
        put_linear(&mut out, &format!("{prefix}.to_out.0"), &a.to_out);
        put_resnet(&mut out, "encoder.mid_block.resnets.1", &self.mid_second);
        put_norm(&mut out, "encoder.conv_norm_out", &self.conv_norm_out);
        put_conv(&mut out, "encoder.conv_out", &self.conv_out);
        put_conv(&mut out, "quant_conv", &self.quant_conv);
        out
    }
}

fn host<const D: usize>(t: Tensor<D>) -> Vec<f32> {
    t.to_data()
        .convert::<f32>()
        .try_into_vec::<f32>()
        .expect("converted to f32")
}

fn put_conv(out: &mut Tensors, name: &str, c: &Conv2d) {
    let w = c.weight.val();
    out.insert(format!("{name}.weight"), (w.dims().to_vec(), host(w)));
    if let Some(b) = &c.bias {
        let b = b.val();
        out.insert(format!("{name}.bias"), (b.dims().to_vec(), host(b)));
    }
}

fn put_norm(out: &mut Tensors, name: &str, g: &GroupNorm) {
    if let (Some(w), Some(b)) = (&g.gamma, &g.beta) {
        out.insert(format!("{name}.weight"), (w.dims().to_vec(), host(w.val())));
        out.insert(format!("{name}.bias"), (b.dims().to_vec(), host(b.val())));
    }
}

fn put_linear(out: &mut Tensors, name: &str, l: &Linear) {
    // Burn keeps [in, out]; PyTorch [out, in].
    let w = l.weight.val().transpose();
    out.insert(format!("{name}.weight"), (w.dims().to_vec(), host(w)));
    if let Some(b) = &l.bias {
        out.insert(format!("{name}.bias"), (b.dims().to_vec(), host(b.val())));
    }
}

fn put_resnet(out: &mut Tensors, prefix: &str, r: &ResnetBlock) {
    put_norm(out, &format!("{prefix}.norm1"), &r.norm1);
    put_conv(out, &format!("{prefix}.conv1"), &r.conv1);
    put_norm(out, &format!("{prefix}.norm2"), &r.norm2);
    put_conv(out, &format!("{prefix}.conv2"), &r.conv2);
    if let Some(c) = &r.conv_shortcut {
        put_conv(out, &format!("{prefix}.conv_shortcut"), c);
    }
}

fn load_conv(file: &WeightFile, name: &str, c: &mut Conv2d) -> Result<(), WeightsError> {
    file.load_into(&format!("{name}.weight"), &mut c.weight)?;
    if let Some(b) = &mut c.bias {
        file.load_into(&format!("{name}.bias"), b)?;
    }
    Ok(())
}

fn load_norm(file: &WeightFile, name: &str, g: &mut GroupNorm) -> Result<(), WeightsError> {
    if let Some(w) = &mut g.gamma {
        file.load_into(&format!("{name}.weight"), w)?;
    }
    if let Some(b) = &mut g.beta {
        file.load_into(&format!("{name}.bias"), b)?;
    }
    Ok(())
}

fn load_linear(file: &WeightFile, name: &str, l: &mut Linear) -> Result<(), WeightsError> {
    let current = l.weight.val();
    let [i, o] = current.dims();
    let torch = file.tensor::<2>(&format!("{name}.weight"), [o, i], &current.device())?;
    l.weight = Param::from_tensor(torch.transpose());
    if let Some(b) = &mut l.bias {
        file.load_into(&format!("{name}.bias"), b)?;
    }
    Ok(())
}
