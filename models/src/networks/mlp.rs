//! The deformation MLP of DeformGS and OmniRe: `depth` ReLU layers of `width`, the input
//! concatenated back in after layer `skip` (NeRF's skip), then linear heads. A head can start
//! at zero (weights and bias), so a residual field predicts exactly nothing at step 0.

use burn::module::Module;
use burn::nn::{Initializer, Linear, LinearConfig};
use burn::tensor::activation::relu;
use burn::tensor::{Device, Tensor};

#[derive(Module, Debug)]
pub struct SkipMlp {
    pub layers: Vec<Linear>,
    /// Layer index after which the input is concatenated (`None`: no skip).
    #[module(skip)]
    skip: Option<usize>,
}

impl SkipMlp {
    /// `inputs` → `depth` layers of `width` (ReLU); with `skip = Some(k)` layer `k + 1` reads
    /// `[hidden ‖ input]`.
    pub fn new(
        inputs: usize,
        depth: usize,
        width: usize,
        skip: Option<usize>,
        device: &Device,
    ) -> Self {
        assert!(depth >= 1, "an MLP needs at least one layer");
        let skip = skip.filter(|&k| k + 1 < depth);
        let layers = (0..depth)
            .map(|k| {
                let fan_in = match k {
                    0 => inputs,
                    _ if Some(k - 1) == skip => width + inputs,
                    _ => width,
                };
                LinearConfig::new(fan_in, width).init(device)
            })
            .collect();
        Self { layers, skip }
    }

    /// Width of [`Self::forward`]'s output (the last layer's, plus the input when the skip
    /// follows the last layer; it never does: a skip there is dropped).
    pub fn output_width(&self) -> usize {
        self.layers.last().expect("≥ 1 layer").weight.dims()[1]
    }

    /// `[N, inputs]` → `[N, width]`.
    pub fn forward(&self, input: Tensor<2>) -> Tensor<2> {
        let mut x = input.clone();
        for (k, layer) in self.layers.iter().enumerate() {
            x = relu(layer.forward(x));
            if Some(k) == self.skip {
                x = Tensor::cat(vec![x, input.clone()], 1);
            }
        }
        x
    }
}

/// A linear head, zero-initialised (weights and bias) when `zero` is true.
pub fn head(inputs: usize, outputs: usize, zero: bool, device: &Device) -> Linear {
    let config = LinearConfig::new(inputs, outputs);
    if zero {
        config.with_initializer(Initializer::Zeros).init(device)
    } else {
        config.init(device)
    }
}
