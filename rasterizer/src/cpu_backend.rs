//! Wires the CPU rasterizer to Burn's CPU backends (NdArray and Flex) from one implementation:
//! tensors are read to host vectors, rendered by `cpu`, and written back.

use crate::backend::{SplatBackend, SplatForward, SplatInputGrads, SplatInputs, SplatSaved};
use crate::camera::RasterSettings;
use crate::cpu;
use burn::backend::{Backend, TensorMetadata, tensor::FloatTensor};
use burn::tensor::{Shape, TensorData};

fn host<B: Backend>(tensor: FloatTensor<B>) -> Vec<f32> {
    burn::tensor::read_sync(B::float_into_data(tensor))
        .expect("reading a CPU tensor cannot fail")
        .convert::<f32>()
        .try_into_vec::<f32>()
        .expect("converted to f32")
}

fn device_tensor<B: Backend>(values: Vec<f32>, shape: Shape, device: &B::Device) -> FloatTensor<B> {
    B::float_from_data(TensorData::new(values, shape), device)
}

/// Host copies of the inputs and the sizes `K`, `C`.
struct HostInputs {
    n: usize,
    coeffs: usize,
    channels: usize,
    means: Vec<f32>,
    quats: Vec<f32>,
    log_scales: Vec<f32>,
    opacity_logits: Vec<f32>,
    colors: Vec<f32>,
    background: Vec<f32>,
    screen_offsets: Vec<f32>,
}

impl HostInputs {
    fn read<B: Backend>(inputs: SplatInputs<B>) -> Self {
        let color_shape = inputs.colors.shape();
        Self {
            n: color_shape[0],
            coeffs: color_shape[1],
            channels: color_shape[2],
            means: host::<B>(inputs.means),
            quats: host::<B>(inputs.quats),
            log_scales: host::<B>(inputs.log_scales),
            opacity_logits: host::<B>(inputs.opacity_logits),
            colors: host::<B>(inputs.colors),
            background: host::<B>(inputs.background),
            screen_offsets: host::<B>(inputs.screen_offsets),
        }
    }

    fn splats(&self) -> cpu::Splats<'_, f32> {
        cpu::Splats {
            count: self.n,
            coeffs: self.coeffs,
            channels: self.channels,
            means: &self.means,
            quats: &self.quats,
            log_scales: &self.log_scales,
            opacity_logits: &self.opacity_logits,
            colors: &self.colors,
            screen_offsets: &self.screen_offsets,
        }
    }
}

/// CPU forward for any host-readable backend.
pub fn forward<B: Backend>(inputs: SplatInputs<B>, settings: RasterSettings) -> SplatForward<B> {
    let device = inputs.means.device();
    let host_inputs = HostInputs::read(inputs);
    let out = cpu::forward(&host_inputs.splats(), &host_inputs.background, &settings);
    let (h, w) = (
        settings.camera.height as usize,
        settings.camera.width as usize,
    );
    let c = host_inputs.channels;
    SplatForward {
        image: device_tensor::<B>(out.image, Shape::new([h, w, c + 2]), &device),
        saved: SplatSaved {
            projected: device_tensor::<B>(
                out.projected,
                Shape::new([host_inputs.n, cpu::proj_stride(c)]),
                &device,
            ),
            final_transmittance: device_tensor::<B>(
                out.final_transmittance,
                Shape::new([h, w]),
                &device,
            ),
            contributors: device_tensor::<B>(
                out.contributors.iter().map(|&v| v as f32).collect(),
                Shape::new([h, w]),
                &device,
            ),
        },
    }
}

/// CPU backward for any host-readable backend.
pub fn backward<B: Backend>(
    inputs: SplatInputs<B>,
    saved: SplatSaved<B>,
    grad_image: FloatTensor<B>,
    settings: RasterSettings,
) -> SplatInputGrads<B> {
    let device = inputs.means.device();
    let shapes = inputs.shapes();
    let host_inputs = HostInputs::read(inputs);
    let projected = host::<B>(saved.projected);
    let final_transmittance = host::<B>(saved.final_transmittance);
    let contributors: Vec<u32> = host::<B>(saved.contributors)
        .into_iter()
        .map(|v| v as u32)
        .collect();
    let grad_image = host::<B>(grad_image);
    let grads = cpu::backward(
        &host_inputs.splats(),
        &host_inputs.background,
        &settings,
        &projected,
        &final_transmittance,
        &contributors,
        &grad_image,
    );
    let [
        means,
        quats,
        log_scales,
        opacity_logits,
        colors,
        background,
        screen_offsets,
    ] = shapes;
    let s = grads.splats;
    SplatInputGrads {
        means: device_tensor::<B>(s.means, means, &device),
        quats: device_tensor::<B>(s.quats, quats, &device),
        log_scales: device_tensor::<B>(s.log_scales, log_scales, &device),
        opacity_logits: device_tensor::<B>(s.opacity_logits, opacity_logits, &device),
        colors: device_tensor::<B>(s.colors, colors, &device),
        background: device_tensor::<B>(grads.background, background, &device),
        screen_offsets: device_tensor::<B>(s.screen_offsets, screen_offsets, &device),
    }
}

macro_rules! cpu_splat_backend {
    ($backend:ty) => {
        impl SplatBackend for $backend {
            fn splat_forward(
                inputs: SplatInputs<Self>,
                settings: RasterSettings,
            ) -> SplatForward<Self> {
                forward::<Self>(inputs, settings)
            }

            fn splat_backward(
                inputs: SplatInputs<Self>,
                saved: SplatSaved<Self>,
                grad_image: FloatTensor<Self>,
                settings: RasterSettings,
            ) -> SplatInputGrads<Self> {
                backward::<Self>(inputs, saved, grad_image, settings)
            }
        }
    };
}

#[allow(deprecated)]
mod impls {
    use super::*;
    cpu_splat_backend!(burn::backend::NdArray);
    cpu_splat_backend!(burn::backend::Flex);
}
