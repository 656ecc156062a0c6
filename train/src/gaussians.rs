//! A trainable set of 3D Gaussians in the rasterizer's parameterisation (means, w-first
//! quaternions, log-scales, opacity logits, degree-3 SH as DC plus 15 rest coefficients), held
//! as plain tensors between steps and copied into autodiff leaves (the same type) for each step.

use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_rasterizer::Splats;

/// The SH DC basis constant: colour = C0 · dc + 0.5.
pub const SH_C0: f64 = 0.282_094_791_773_878_14;
/// SH coefficients per colour channel besides DC at degree 3.
pub const SH_REST: usize = 15;

#[derive(Debug, Clone)]
pub struct GaussianSet {
    /// `[N, 3]`
    pub means: Tensor<2>,
    /// `[N, 4]` (w, x, y, z)
    pub quats: Tensor<2>,
    /// `[N, 3]`
    pub log_scales: Tensor<2>,
    /// `[N]`
    pub opacity_logits: Tensor<1>,
    /// `[N, 1, 3]`
    pub sh_dc: Tensor<3>,
    /// `[N, 15, 3]`
    pub sh_rest: Tensor<3>,
}

impl GaussianSet {
    /// Gaussians at `positions` with colours `colours` (in [0, 1]) and isotropic standard
    /// deviations `sigmas`, opacity 0.1 and identity rotation (the 3DGS initialisation).
    pub fn from_points(
        positions: &[[f32; 3]],
        colours: &[[f32; 3]],
        sigmas: &[f32],
        device: &Device,
    ) -> Self {
        let n = positions.len();
        assert_eq!(colours.len(), n, "one colour per point");
        assert_eq!(sigmas.len(), n, "one scale per point");
        let flat = |v: Vec<f32>, shape: Vec<usize>| TensorData::new(v, shape);
        let means = Tensor::<2>::from_data(
            flat(positions.iter().flatten().copied().collect(), vec![n, 3]),
            device,
        );
        let mut quats = vec![0.0f32; 4 * n];
        for q in quats.chunks_mut(4) {
            q[0] = 1.0;
        }
        let log_scales: Vec<f32> = sigmas.iter().flat_map(|s| [s.max(1e-7).ln(); 3]).collect();
        let dc: Vec<f32> = colours
            .iter()
            .flatten()
            .map(|&c| ((c as f64 - 0.5) / SH_C0) as f32)
            .collect();
        let opacity = (0.1f32 / 0.9).ln();
        Self {
            means,
            quats: Tensor::from_data(flat(quats, vec![n, 4]), device),
            log_scales: Tensor::from_data(flat(log_scales, vec![n, 3]), device),
            opacity_logits: Tensor::<1>::full([n], opacity, device),
            sh_dc: Tensor::from_data(flat(dc, vec![n, 1, 3]), device),
            sh_rest: Tensor::zeros([n, SH_REST, 3], device),
        }
    }

    pub fn len(&self) -> usize {
        self.means.dims()[0]
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The same parameters as autodiff leaves that retain their gradients, for one step.
    pub fn leaves(&self) -> GaussianSet {
        let leaf2 = |t: &Tensor<2>| t.clone().autodiff().require_grad();
        let leaf3 = |t: &Tensor<3>| t.clone().autodiff().require_grad();
        GaussianSet {
            means: leaf2(&self.means),
            quats: leaf2(&self.quats),
            log_scales: leaf2(&self.log_scales),
            opacity_logits: self.opacity_logits.clone().autodiff().require_grad(),
            sh_dc: leaf3(&self.sh_dc),
            sh_rest: leaf3(&self.sh_rest),
        }
    }

    /// The splats the rasterizer takes.
    pub fn splats(&self) -> Splats {
        Splats {
            means: self.means.clone(),
            quats: self.quats.clone(),
            log_scales: self.log_scales.clone(),
            opacity_logits: self.opacity_logits.clone(),
            colors: Tensor::cat(vec![self.sh_dc.clone(), self.sh_rest.clone()], 1),
        }
    }
}
