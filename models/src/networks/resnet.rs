//! ResNet encoders (He et al. 2016) in torchvision's layout and naming, returning the four stage
//! outputs C2–C5 (strides 4, 8, 16, 32) that a feature pyramid consumes. Depth is a
//! speed/accuracy knob: 18 and 34 use basic blocks (C5 has 512 channels), 50 uses bottlenecks
//! (2048). Batch normalisation is frozen, as in torchvision's detection backbones: each BN is
//! folded into a per-channel scale and shift (trainable), which keeps small multi-view batches
//! from corrupting the statistics.

use super::weights::{WeightFile, WeightsError};
use burn::module::{Module, Param};
use burn::nn::PaddingConfig2d;
use burn::nn::conv::{Conv2d, Conv2dConfig};
use burn::tensor::module::max_pool2d;
use burn::tensor::ops::MaxPoolOptions;
use burn::tensor::{Device, Tensor};

/// The depths torchvision publishes with these layouts.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize, clap::ValueEnum,
)]
pub enum Depth {
    #[serde(rename = "18")]
    #[value(name = "18")]
    R18,
    #[serde(rename = "34")]
    #[value(name = "34")]
    R34,
    #[serde(rename = "50")]
    #[value(name = "50")]
    R50,
}

impl Depth {
    fn blocks(self) -> [usize; 4] {
        match self {
            Depth::R18 => [2, 2, 2, 2],
            Depth::R34 | Depth::R50 => [3, 4, 6, 3],
        }
    }

    fn bottleneck(self) -> bool {
        self == Depth::R50
    }

    /// Channels of C2, C3, C4, C5.
    pub fn channels(self) -> [usize; 4] {
        let e = if self.bottleneck() { 4 } else { 1 };
        [64 * e, 128 * e, 256 * e, 512 * e]
    }
}

/// Batch normalisation with frozen statistics: `y = x · scale + shift` per channel.
#[derive(Module, Debug)]
pub struct FrozenBatchNorm {
    pub scale: Param<Tensor<1>>,
    pub shift: Param<Tensor<1>>,
}

impl FrozenBatchNorm {
    fn new(channels: usize, device: &Device) -> Self {
        Self {
            scale: Param::from_tensor(Tensor::ones([channels], device)),
            shift: Param::from_tensor(Tensor::zeros([channels], device)),
        }
    }

    pub fn forward(&self, x: Tensor<4>) -> Tensor<4> {
        let c = self.scale.dims()[0];
        x * self.scale.val().reshape([1, c, 1, 1]) + self.shift.val().reshape([1, c, 1, 1])
    }

    /// Folds torchvision's `{prefix}.weight/bias/running_mean/running_var` (ε = 1e-5):
    /// `scale = w / √(var + ε)`, `shift = b − mean · scale`.
    fn load(&mut self, file: &WeightFile, prefix: &str) -> Result<(), WeightsError> {
        let c = self.scale.dims()[0];
        let device = self.scale.device();
        let get = |n: &str| file.tensor::<1>(&format!("{prefix}.{n}"), [c], &device);
        let (w, b, mean, var) = (
            get("weight")?,
            get("bias")?,
            get("running_mean")?,
            get("running_var")?,
        );
        let scale = w / (var + 1e-5).sqrt();
        self.shift = Param::from_tensor(b - mean * scale.clone());
        self.scale = Param::from_tensor(scale);
        Ok(())
    }
}

fn conv(i: usize, o: usize, k: usize, stride: usize, device: &Device) -> Conv2d {
    Conv2dConfig::new([i, o], [k, k])
        .with_stride([stride, stride])
        .with_padding(PaddingConfig2d::Explicit(k / 2, k / 2, k / 2, k / 2))
        .with_bias(false)
        .init(device)
}

fn load_conv(file: &WeightFile, name: &str, c: &mut Conv2d) -> Result<(), WeightsError> {
    file.load_into(&format!("{name}.weight"), &mut c.weight)
}

/// A residual block: basic (two 3×3) or bottleneck (1×1, 3×3 with the stride, 1×1 ×4).
#[derive(Module, Debug)]
pub struct Block {
    convs: Vec<Conv2d>,
    norms: Vec<FrozenBatchNorm>,
    downsample: Option<(Conv2d, FrozenBatchNorm)>,
}

impl Block {
    fn new(inputs: usize, width: usize, stride: usize, bottleneck: bool, device: &Device) -> Self {
        let (convs, outputs) = if bottleneck {
            (
                vec![
                    conv(inputs, width, 1, 1, device),
                    conv(width, width, 3, stride, device),
                    conv(width, 4 * width, 1, 1, device),
                ],
                4 * width,
            )
        } else {
            (
                vec![
                    conv(inputs, width, 3, stride, device),
                    conv(width, width, 3, 1, device),
                ],
                width,
            )
        };
        let norms = convs
            .iter()
            .map(|c| FrozenBatchNorm::new(c.weight.dims()[0], device))
            .collect();
        let downsample = (stride != 1 || inputs != outputs).then(|| {
            (
                conv(inputs, outputs, 1, stride, device),
                FrozenBatchNorm::new(outputs, device),
            )
        });
        Self {
            convs,
            norms,
            downsample,
        }
    }

    fn forward(&self, x: Tensor<4>) -> Tensor<4> {
        let identity = match &self.downsample {
            Some((c, n)) => n.forward(c.forward(x.clone())),
            None => x.clone(),
        };
        let mut y = x;
        let last = self.convs.len() - 1;
        for (k, (c, n)) in self.convs.iter().zip(&self.norms).enumerate() {
            y = n.forward(c.forward(y));
            if k < last {
                y = burn::tensor::activation::relu(y);
            }
        }
        burn::tensor::activation::relu(y + identity)
    }

    fn load(&mut self, file: &WeightFile, prefix: &str) -> Result<(), WeightsError> {
        for (k, (c, n)) in self.convs.iter_mut().zip(self.norms.iter_mut()).enumerate() {
            load_conv(file, &format!("{prefix}.conv{}", k + 1), c)?;
            n.load(file, &format!("{prefix}.bn{}", k + 1))?;
        }
        if let Some((c, n)) = &mut self.downsample {
            load_conv(file, &format!("{prefix}.downsample.0"), c)?;
            n.load(file, &format!("{prefix}.downsample.1"))?;
        }
        Ok(())
    }
}

#[derive(Module, Debug)]
pub struct ResNet {
    conv1: Conv2d,
    bn1: FrozenBatchNorm,
    layers: Vec<Vec<Block>>,
}

impl ResNet {
    /// Randomly initialised (Burn's default initialisers).
    pub fn new(depth: Depth, device: &Device) -> Self {
        let mut layers = Vec::new();
        let mut inputs = 64;
        for (stage, &count) in depth.blocks().iter().enumerate() {
            let width = 64 << stage;
            let stride = if stage == 0 { 1 } else { 2 };
            let mut blocks = Vec::new();
            for b in 0..count {
                let block = Block::new(
                    inputs,
                    width,
                    if b == 0 { stride } else { 1 },
                    depth.bottleneck(),
                    device,
                );
                inputs = if depth.bottleneck() { 4 * width } else { width };
                blocks.push(block);
            }
            layers.push(blocks);
        }
        Self {
            conv1: conv(3, 64, 7, 2, device),
            bn1: FrozenBatchNorm::new(64, device),
            layers,
        }
    }

    /// Loads torchvision weights (`conv1`, `bn1`, `layer{1..4}.{i}.…`); the classifier `fc.*`
    /// is ignored.
    pub fn load(&mut self, file: &WeightFile) -> Result<(), WeightsError> {
        load_conv(file, "conv1", &mut self.conv1)?;
        self.bn1.load(file, "bn1")?;
        for (stage, blocks) in self.layers.iter_mut().enumerate() {
            for (b, block) in blocks.iter_mut().enumerate() {
                block.load(file, &format!("layer{}.{b}", stage + 1))?;
            }
        }
        Ok(())
    }

    /// `[N, 3, H, W]` images (ImageNet-normalised) → C2, C3, C4, C5.
    pub fn forward(&self, images: Tensor<4>) -> [Tensor<4>; 4] {
        let x = burn::tensor::activation::relu(self.bn1.forward(self.conv1.forward(images)));
        let mut x = max_pool2d(
            x,
            MaxPoolOptions::new([3, 3])
                .with_stride([2, 2])
                .with_padding([1, 1]),
        );
        let mut out = Vec::with_capacity(4);
        for blocks in &self.layers {
            for block in blocks {
                x = block.forward(x);
            }
            out.push(x.clone());
        }
        out.try_into().expect("four stages")
    }
}

/// ImageNet normalisation of `[N, 3, H, W]` images in [0, 1], as torchvision's weights expect.
pub fn imagenet_normalise(images: Tensor<4>) -> Tensor<4> {
    let device = images.device();
    let mean = Tensor::<1>::from_floats([0.485, 0.456, 0.406], &device).reshape([1, 3, 1, 1]);
    let std = Tensor::<1>::from_floats([0.229, 0.224, 0.225], &device).reshape([1, 3, 1, 1]);
    (images - mean) / std
}
