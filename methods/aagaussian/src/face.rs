//! The facial rendering loss (Eq. 6's L_f of AAGaussian; its form is ours, U5–U6 of the spec):
//! `L_f = L_fc + λ_los L_los`.
//!
//! - U5, the colour term: a centre-weighted, normalised pixel comparison of the render from the
//!   fixed face camera with the face crop, `L_fc = Σ_p ω(p) ‖Î(p) − F(p)‖ / 3` with
//!   `ω(p) ∝ exp(−‖p − c‖² / (2 (κ W)²))`, κ = 0.25, `Σ_p ω(p) = 1`; L1 (default) or squared.
//! - U6, the line-of-sight term: Gaussians whose centres project into the face mask and sit
//!   more than τ in front of the body's surface along the face camera's ray pay for it,
//!   `L_los = Σ_{i∈V} o_i max(0, D_m(u_i) − z_i − τ) / (d_f Σ_{i∈V} o_i)` — one-sided, because
//!   the paper's failure is a layer in front of the face. No gradient flows through `u_i`.

use crate::error::AagError;
use burn::tensor::activation::sigmoid;
use burn::tensor::{Int, Tensor, TensorData};
use serde::{Deserialize, Serialize};
use splatzoo_rasterizer::Camera;
use splatzoo_train::host_f32;

/// The pixel norm of U5.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum FaceNorm {
    L1,
    L2,
}

/// U5's centre weights over a `size × size` image, summing to 1, `[H · W]` row-major.
pub fn centre_weights(size: usize, kappa: f64) -> Vec<f32> {
    let c = 0.5 * size as f64;
    let spread = 2.0 * (kappa * size as f64).powi(2);
    let raw: Vec<f64> = (0..size * size)
        .map(|p| {
            let (x, y) = ((p % size) as f64 + 0.5, (p / size) as f64 + 0.5);
            (-((x - c).powi(2) + (y - c).powi(2)) / spread).exp()
        })
        .collect();
    let total: f64 = raw.iter().sum();
    raw.iter().map(|w| (w / total) as f32).collect()
}

/// U5: `Σ_p ω(p) ‖image(p) − crop(p)‖ / 3` for `image` and `crop` `[H, W, 3]`, `weights`
/// `[H · W]` summing to 1.
pub fn face_colour_loss(
    image: Tensor<3>,
    crop: Tensor<3>,
    weights: &[f32],
    norm: FaceNorm,
) -> Tensor<1> {
    let [h, w, _] = image.dims();
    assert_eq!(weights.len(), h * w, "one weight per pixel");
    let device = image.device();
    let omega = Tensor::<3>::from_data(TensorData::new(weights.to_vec(), vec![h, w, 1]), &device);
    let diff = image - crop;
    let per_pixel = match norm {
        FaceNorm::L1 => diff.abs(),
        FaceNorm::L2 => diff.powi_scalar(2),
    };
    (per_pixel * omega).sum().div_scalar(3.0)
}

/// What U6 needs from the face view, computed once (the face camera is fixed).
#[derive(Debug, Clone)]
pub struct LineOfSight {
    pub camera: Camera,
    /// `[S · S]` the face mask.
    pub mask: Vec<bool>,
    /// `[S · S]` D_m: the body's depth (∞ off the body).
    pub depth: Vec<f32>,
    /// τ, normalised units.
    pub margin: f64,
    /// d_f, normalised units (makes the term dimensionless).
    pub distance: f64,
}

impl LineOfSight {
    /// The Gaussians V (projecting into the mask onto the body) and D_m at each, from the
    /// detached centres `means` (`[N, 3]` host values).
    pub fn visible(&self, means: &[f32]) -> (Vec<i64>, Vec<f32>) {
        let m = &self.camera.world_to_camera;
        let (w, h) = (self.camera.width as usize, self.camera.height as usize);
        let mut index = Vec::new();
        let mut depth = Vec::new();
        for (i, p) in means.chunks(3).enumerate() {
            let cam = [0, 1, 2].map(|r| m[r][0] * p[0] + m[r][1] * p[1] + m[r][2] * p[2] + m[r][3]);
            if cam[2] <= self.camera.near {
                continue;
            }
            let u = self.camera.fx * cam[0] / cam[2] + self.camera.cx;
            let v = self.camera.fy * cam[1] / cam[2] + self.camera.cy;
            if !(u >= 0.0 && v >= 0.0 && (u as usize) < w && (v as usize) < h) {
                continue;
            }
            let pixel = v as usize * w + u as usize;
            if self.mask[pixel] && self.depth[pixel].is_finite() {
                index.push(i as i64);
                depth.push(self.depth[pixel]);
            }
        }
        (index, depth)
    }

    /// U6's `L_los` for centres `means` (`[N, 3]`) and opacity logits (`[N]`); zero (and no
    /// gradient) when no Gaussian projects into the face.
    pub fn loss(&self, means: Tensor<2>, opacity_logits: Tensor<1>) -> Result<Tensor<1>, AagError> {
        let device = means.device();
        let (index, surface) = self.visible(&host_f32(&means));
        if index.is_empty() {
            return Ok(Tensor::<1>::zeros([1], &device));
        }
        let n = index.len();
        let rows = Tensor::<1, Int>::from_data(TensorData::new(index, vec![n]), &device);
        let centres = means.select(0, rows.clone());
        let opacity = sigmoid(opacity_logits.select(0, rows));
        let m = &self.camera.world_to_camera;
        let axis = Tensor::<2>::from_data(
            TensorData::new(vec![m[2][0], m[2][1], m[2][2]], vec![3, 1]),
            &device,
        );
        let z = centres.matmul(axis).reshape([n]).add_scalar(m[2][3]);
        let surface = Tensor::<1>::from_data(TensorData::new(surface, vec![n]), &device);
        let gap = (surface - z).sub_scalar(self.margin).clamp_min(0.0);
        let total = opacity.clone().sum();
        Ok((opacity * gap)
            .sum()
            .div(total.clamp_min(1e-12))
            .div_scalar(self.distance))
    }

    /// Σ opacity of the Gaussians more than τ in front of the face (the floater mass metric).
    pub fn floater_mass(&self, means: &[f32], opacities: &[f32]) -> f64 {
        let m = &self.camera.world_to_camera;
        let (index, surface) = self.visible(means);
        index
            .iter()
            .zip(surface)
            .filter(|(i, d)| {
                let p = &means[3 * **i as usize..3 * **i as usize + 3];
                let z = m[2][0] * p[0] + m[2][1] * p[1] + m[2][2] * p[2] + m[2][3];
                f64::from(*d - z) > self.margin
            })
            .map(|(i, _)| f64::from(opacities[*i as usize]))
            .sum()
    }
}
