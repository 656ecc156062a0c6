//! The rasterizer as a Burn backend extension: one forward and one backward primitive per
//! backend, routed by `Dispatch` from the tensors' device.
//!
//! Every tensor crossing this boundary has a shape fixed by its inputs (so Fusion can describe
//! outputs lazily): data-dependent state such as tile lists is rebuilt inside each call.
#![allow(deprecated)] // burn-ndarray is deprecated upstream but is a backend this project serves.

use crate::camera::RasterSettings;
use burn::backend::fusion::custom::TensorSpec;
use burn::backend::{Backend, ExtensionType, backend_extension, tensor::FloatTensor};
use burn::tensor::Shape;

/// The op's differentiable inputs.
#[derive(ExtensionType, Clone, Debug)]
#[extension_type(fusion)]
pub struct SplatInputs<B: Backend> {
    /// `[N, 3]` world-space centres.
    pub means: FloatTensor<B>,
    /// `[N, 4]` unnormalised rotations (w, x, y, z).
    pub quats: FloatTensor<B>,
    /// `[N, 3]` log standard deviations along the local axes.
    pub log_scales: FloatTensor<B>,
    /// `[N]` opacity logits.
    pub opacity_logits: FloatTensor<B>,
    /// `[N, K, C]` SH coefficients or features.
    pub colors: FloatTensor<B>,
    /// `[C]` background colour.
    pub background: FloatTensor<B>,
    /// `[N, 2]` pixel offsets added to the projected means (zeros in normal use); their gradient
    /// is the screen-space positional gradient densification uses.
    pub screen_offsets: FloatTensor<B>,
}

impl<B: Backend> SplatInputs<B> {
    /// Shapes of the fields in declaration order (those of the matching gradients).
    pub fn shapes(&self) -> [Shape; 7] {
        use burn::backend::TensorMetadata;
        [
            self.means.shape(),
            self.quats.shape(),
            self.log_scales.shape(),
            self.opacity_logits.shape(),
            self.colors.shape(),
            self.background.shape(),
            self.screen_offsets.shape(),
        ]
    }
}

/// State a forward leaves for its backward, fixed-size.
#[derive(ExtensionType, Clone, Debug)]
#[extension_type(fusion)]
pub struct SplatSaved<B: Backend> {
    /// `[N, 8 + C]` projected splats (layout in `cpu`).
    pub projected: FloatTensor<B>,
    /// `[H, W]`.
    pub final_transmittance: FloatTensor<B>,
    /// `[H, W]` list entries walked per pixel, as floats (exact below 2²⁴).
    pub contributors: FloatTensor<B>,
}

/// Forward outputs: the image and the saved state.
#[derive(ExtensionType, Clone, Debug)]
#[extension_type(fusion)]
pub struct SplatForward<B: Backend> {
    /// `[H, W, C + 2]`: colour (over the background), alpha, accumulated depth `Σ wᵢ zᵢ`.
    pub image: FloatTensor<B>,
    #[extension_type]
    pub saved: SplatSaved<B>,
}

/// Gradients of every field of [`SplatInputs`], same shapes.
#[derive(ExtensionType, Clone, Debug)]
#[extension_type(fusion)]
pub struct SplatInputGrads<B: Backend> {
    pub means: FloatTensor<B>,
    pub quats: FloatTensor<B>,
    pub log_scales: FloatTensor<B>,
    pub opacity_logits: FloatTensor<B>,
    pub colors: FloatTensor<B>,
    pub background: FloatTensor<B>,
    pub screen_offsets: FloatTensor<B>,
}

fn forward_meta(inputs: &SplatInputsMetadata, settings: &RasterSettings) -> SplatForwardMetadata {
    let n = inputs.means.shape[0];
    let channels = inputs.background.shape[0];
    let (h, w) = (
        settings.camera.height as usize,
        settings.camera.width as usize,
    );
    let dtype = inputs.means.dtype;
    SplatForwardMetadata {
        image: TensorSpec::new(Shape::new([h, w, channels + 2]), dtype),
        saved: SplatSavedMetadata {
            projected: TensorSpec::new(Shape::new([n, crate::cpu::proj_stride(channels)]), dtype),
            final_transmittance: TensorSpec::new(Shape::new([h, w]), dtype),
            contributors: TensorSpec::new(Shape::new([h, w]), dtype),
        },
    }
}

fn backward_meta(
    inputs: &SplatInputsMetadata,
    _saved: &SplatSavedMetadata,
    _grad_image: &TensorSpec,
    _settings: &RasterSettings,
) -> SplatInputGradsMetadata {
    SplatInputGradsMetadata {
        means: inputs.means.clone(),
        quats: inputs.quats.clone(),
        log_scales: inputs.log_scales.clone(),
        opacity_logits: inputs.opacity_logits.clone(),
        colors: inputs.colors.clone(),
        background: inputs.background.clone(),
        screen_offsets: inputs.screen_offsets.clone(),
    }
}

/// A backend that can rasterize Gaussian splats.
#[backend_extension(Autodiff, Cube, Fusion, NdArray, Flex)]
pub trait SplatBackend: Backend {
    /// Renders; see [`crate::rasterize`] for the public, shape-checked entry point.
    #[fusion(meta = forward_meta)]
    fn splat_forward(
        #[extension_type] inputs: SplatInputs<Self>,
        settings: RasterSettings,
    ) -> SplatForward<Self>;

    /// Gradients of the inputs given dL/d(image).
    #[fusion(meta = backward_meta)]
    fn splat_backward(
        #[extension_type] inputs: SplatInputs<Self>,
        #[extension_type] saved: SplatSaved<Self>,
        grad_image: FloatTensor<Self>,
        settings: RasterSettings,
    ) -> SplatInputGrads<Self>;
}
