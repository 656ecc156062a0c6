//! A feature pyramid (Lin et al. 2017) over ResNet stages, fused to one map as NLF-GS does
//! (Eq. 8 and supplementary A of NLF-GS): lateral 1×1 convolutions bring C2–C5 to `channels`,
//! a top-down pathway adds each coarser level, upsampled 2× (nearest), to the next finer one,
//! 3×3 convolutions smooth each level into P2–P5, and P3–P5 are upsampled to P2's resolution
//! (stride 4) and concatenated: `4 · channels` features per pixel.
//!
//! Upsampling to P2 is bilinear through `grid_sample_2d` (Burn 0.22's bilinear interpolation has
//! no backward on wgpu and NdArray) or nearest: [`Upsample`].

use super::resnet::{Depth, ResNet, imagenet_normalise};
use super::weights::{WeightFile, WeightsError};
use burn::module::Module;
use burn::nn::PaddingConfig2d;
use burn::nn::conv::{Conv2d, Conv2dConfig};
use burn::tensor::module::interpolate;
use burn::tensor::ops::{GridSampleOptions, InterpolateMode, InterpolateOptions};
use burn::tensor::{Device, Tensor};

/// How coarse pyramid levels reach P2's resolution.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize, clap::ValueEnum,
)]
#[serde(rename_all = "lowercase")]
pub enum Upsample {
    Bilinear,
    Nearest,
}

/// Resizes `[N, C, h, w]` to `[N, C, H, W]`.
pub fn upsample(x: Tensor<4>, size: [usize; 2], mode: Upsample) -> Tensor<4> {
    match mode {
        Upsample::Nearest => interpolate(
            x,
            InterpolateOptions::new(InterpolateMode::Nearest).with_output_size(size),
        ),
        Upsample::Bilinear => {
            let [n, _, _, _] = x.dims();
            let [h, w] = size;
            let device = x.device();
            // Pixel centres of the output in [−1, 1] (align_corners = false), x then y.
            let centres = |n: usize| {
                let v: Vec<f32> = (0..n)
                    .map(|i| (2 * i + 1) as f32 / n as f32 - 1.0)
                    .collect();
                Tensor::<1>::from_floats(v.as_slice(), &device)
            };
            let (xs, ys) = (centres(w), centres(h));
            let gx = xs.reshape([1, w, 1]).expand([h, w, 1]);
            let gy = ys.reshape([h, 1, 1]).expand([h, w, 1]);
            let grid = Tensor::cat(vec![gx, gy], 2)
                .unsqueeze_dim::<4>(0)
                .expand([n, h, w, 2]);
            x.grid_sample_2d(
                grid,
                GridSampleOptions::new(InterpolateMode::Bilinear)
                    .with_padding_mode(burn::tensor::ops::GridSamplePaddingMode::Border),
            )
        }
    }
}

#[derive(Module, Debug)]
pub struct ResNetFpn {
    pub backbone: ResNet,
    lateral: Vec<Conv2d>,
    output: Vec<Conv2d>,
    #[module(skip)]
    upsample: Upsample,
}

impl ResNetFpn {
    pub fn new(depth: Depth, channels: usize, upsample: Upsample, device: &Device) -> Self {
        let lateral = depth
            .channels()
            .iter()
            .map(|&c| Conv2dConfig::new([c, channels], [1, 1]).init(device))
            .collect();
        let output = (0..4)
            .map(|_| {
                Conv2dConfig::new([channels, channels], [3, 3])
                    .with_padding(PaddingConfig2d::Explicit(1, 1, 1, 1))
                    .init(device)
            })
            .collect();
        Self {
            backbone: ResNet::new(depth, device),
            lateral,
            output,
            upsample,
        }
    }

    /// Loads torchvision backbone weights; the pyramid stays randomly initialised.
    pub fn load_backbone(&mut self, file: &WeightFile) -> Result<(), WeightsError> {
        self.backbone.load(file)
    }

    /// `[N, 3, H, W]` images in [0, 1] → `[N, 4·channels, ⌈H/4⌉, ⌈W/4⌉]` (Eq. 8, fused).
    pub fn forward(&self, images: Tensor<4>) -> Tensor<4> {
        self.fused(images, false)
    }

    /// The same map as [`forward`](Self::forward), bilinear upsampling done by `interpolate`:
    /// burn-onnx lowers that to ONNX `Resize`, but it has no backward on wgpu and NdArray, so
    /// training samples a grid instead. For inference and ONNX export.
    pub fn forward_inference(&self, images: Tensor<4>) -> Tensor<4> {
        self.fused(images, true)
    }

    fn fused(&self, images: Tensor<4>, by_interpolate: bool) -> Tensor<4> {
        let c = self.backbone.forward(imagenet_normalise(images));
        let mut p: Vec<Tensor<4>> = Vec::with_capacity(4);
        let mut top: Option<Tensor<4>> = None;
        for level in (0..4).rev() {
            let lateral = self.lateral[level].forward(c[level].clone());
            let [_, _, h, w] = lateral.dims();
            let merged = match top {
                Some(coarse) => lateral + upsample(coarse, [h, w], Upsample::Nearest),
                None => lateral,
            };
            p.push(self.output[level].forward(merged.clone()));
            top = Some(merged);
        }
        p.reverse(); // P2 … P5
        let [_, _, h, w] = p[0].dims();
        let fused: Vec<Tensor<4>> = p
            .into_iter()
            .enumerate()
            .map(|(k, level)| {
                if k == 0 {
                    level
                } else if by_interpolate && self.upsample == Upsample::Bilinear {
                    interpolate(
                        level,
                        InterpolateOptions::new(InterpolateMode::Bilinear)
                            .with_align_corners(false)
                            .with_output_size([h, w]),
                    )
                } else {
                    upsample(level, [h, w], self.upsample)
                }
            })
            .collect();
        Tensor::cat(fused, 1)
    }
}
