//! LPIPS (Zhang et al., "The Unreasonable Effectiveness of Deep Features as a Perceptual
//! Metric", 2018): images are scaled to [−1, 1] and shifted/scaled per channel, passed through
//! an AlexNet or VGG-16 backbone, each tapped layer's features are normalised over channels,
//! their squared difference is weighted per channel by a learned linear head (a 1×1 convolution),
//! averaged over space and summed over layers (their Eq. 1).
//!
//! Weights are the user's: one safetensors file in torchvision naming for the backbone
//! (`features.{i}.weight`, `features.{i}.bias`), optionally with the LPIPS heads under the
//! official names (`lin{k}.model.1.weight`, `[1, C, 1, 1]`). Without heads every channel weighs
//! `1 / C` (the paper's unlearned baseline), said in [`Lpips::learned_heads`]. Nothing is
//! downloaded.

use crate::checkpoint::{Checkpoint, CheckpointError};
use burn::tensor::module::{conv2d, max_pool2d};
use burn::tensor::ops::{ConvOptions, MaxPoolOptions};
use burn::tensor::{Device, Tensor, TensorData};
use std::path::Path;

/// The backbones LPIPS was published with.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Backbone {
    Alex,
    Vgg16,
}

/// One layer of a torchvision `features` stack.
#[derive(Debug, Clone, Copy)]
enum Layer {
    /// Index in `features`, stride, padding.
    Conv(usize, usize, usize),
    /// ReLU; `true` where LPIPS taps its output.
    Relu(bool),
    /// Max pooling with kernel 3 / stride 2 (AlexNet) or kernel 2 / stride 2 (VGG).
    Pool(usize),
}

impl Backbone {
    fn layers(self) -> Vec<Layer> {
        use Layer::*;
        match self {
            Backbone::Alex => vec![
                Conv(0, 4, 2),
                Relu(true),
                Pool(3),
                Conv(3, 1, 2),
                Relu(true),
                Pool(3),
                Conv(6, 1, 1),
                Relu(true),
                Conv(8, 1, 1),
                Relu(true),
                Conv(10, 1, 1),
                Relu(true),
            ],
            Backbone::Vgg16 => {
                let mut layers = Vec::new();
                let blocks: [&[usize]; 5] = [
                    &[0, 2],
                    &[5, 7],
                    &[10, 12, 14],
                    &[17, 19, 21],
                    &[24, 26, 28],
                ];
                for (b, convs) in blocks.iter().enumerate() {
                    if b > 0 {
                        layers.push(Pool(2));
                    }
                    for (k, &index) in convs.iter().enumerate() {
                        layers.push(Conv(index, 1, 1));
                        layers.push(Relu(k + 1 == convs.len()));
                    }
                }
                layers
            }
        }
    }
}

pub struct Lpips {
    pub backbone: Backbone,
    /// `(weight [O, I, k, k], bias [O])` by torchvision index.
    convs: Vec<(usize, Tensor<4>, Tensor<1>)>,
    /// `[1, C, 1, 1]` per tapped layer.
    heads: Vec<Tensor<4>>,
    pub learned_heads: bool,
}

/// LPIPS's input shift and scale (for images in [−1, 1]).
const SHIFT: [f32; 3] = [-0.030, -0.088, -0.188];
const SCALE: [f32; 3] = [0.458, 0.448, 0.450];

impl Lpips {
    /// Reads backbone (and head) weights; the backbone is recognised by its layer indices.
    pub fn load(path: &Path, device: &Device) -> Result<Self, CheckpointError> {
        let file = Checkpoint::read(path)?;
        let backbone = if file.tensors.contains_key("features.28.weight") {
            Backbone::Vgg16
        } else if file.tensors.contains_key("features.10.weight") {
            Backbone::Alex
        } else {
            return Err(CheckpointError::File {
                file: path.display().to_string(),
                problem: "neither torchvision AlexNet (features.0 … features.10) nor VGG-16 \
                          (features.0 … features.28) weights"
                    .into(),
            });
        };
        let mut convs = Vec::new();
        let mut inputs = 3;
        let mut tapped = Vec::new();
        for layer in backbone.layers() {
            match layer {
                Layer::Conv(index, _, _) => {
                    let weight: Tensor<4> = file.tensor(
                        &format!("features.{index}.weight"),
                        [None, Some(inputs), None, None],
                        device,
                    )?;
                    let outputs = weight.dims()[0];
                    let bias =
                        file.tensor(&format!("features.{index}.bias"), [Some(outputs)], device)?;
                    convs.push((index, weight, bias));
                    inputs = outputs;
                }
                Layer::Relu(true) => tapped.push(inputs),
                _ => {}
            }
        }
        let learned_heads = file.tensors.contains_key("lin0.model.1.weight");
        let heads = tapped
            .iter()
            .enumerate()
            .map(|(k, &c)| {
                if learned_heads {
                    file.tensor(
                        &format!("lin{k}.model.1.weight"),
                        [Some(1), Some(c), Some(1), Some(1)],
                        device,
                    )
                } else {
                    Ok(Tensor::full([1, c, 1, 1], 1.0 / c as f32, device))
                }
            })
            .collect::<Result<_, _>>()?;
        Ok(Self {
            backbone,
            convs,
            heads,
            learned_heads,
        })
    }

    /// The normalised tapped features of `[N, 3, H, W]` images in [0, 1].
    fn features(&self, images: Tensor<4>) -> Vec<Tensor<4>> {
        let device = images.device();
        let shift = Tensor::<4>::from_data(TensorData::new(SHIFT.to_vec(), [1, 3, 1, 1]), &device);
        let scale = Tensor::<4>::from_data(TensorData::new(SCALE.to_vec(), [1, 3, 1, 1]), &device);
        let mut x = (images * 2.0 - 1.0 - shift) / scale;
        let mut taps = Vec::with_capacity(5);
        let mut convs = self.convs.iter();
        for layer in self.backbone.layers() {
            x = match layer {
                Layer::Conv(_, stride, padding) => {
                    let (_, w, b) = convs.next().expect("one weight per convolution");
                    let options = ConvOptions::new([stride; 2], [padding; 2], [1, 1], 1);
                    conv2d(x, w.clone(), Some(b.clone()), options)
                }
                Layer::Relu(tap) => {
                    let y = burn::tensor::activation::relu(x);
                    if tap {
                        let norm = y.clone().powi_scalar(2).sum_dim(1).sqrt() + 1e-10;
                        taps.push(y.clone() / norm);
                    }
                    y
                }
                Layer::Pool(k) => max_pool2d(x, MaxPoolOptions::new([k, k]).with_stride([2, 2])),
            };
        }
        taps
    }

    /// LPIPS between `[H, W, 3]` images in [0, 1] (Eq. 1 of Zhang et al.), `[1]`.
    pub fn distance(&self, image: Tensor<3>, target: Tensor<3>) -> Tensor<1> {
        let [h, w, c] = image.dims();
        assert_eq!(c, 3, "LPIPS compares [H, W, 3] images");
        assert_eq!(
            target.dims(),
            [h, w, 3],
            "LPIPS compares images of one size"
        );
        let batch = |t: Tensor<3>| t.permute([2, 0, 1]).unsqueeze_dim::<4>(0);
        let a = self.features(batch(image));
        let b = self.features(batch(target));
        let mut total = Tensor::<1>::zeros([1], &self.heads[0].device());
        for ((fa, fb), head) in a.into_iter().zip(b).zip(&self.heads) {
            let d = (fa - fb).powi_scalar(2);
            let weighted = conv2d(
                d,
                head.clone(),
                None,
                ConvOptions::new([1, 1], [0, 0], [1, 1], 1),
            );
            total = total + weighted.mean().reshape([1]);
        }
        total
    }
}
