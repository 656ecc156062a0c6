//! A trainable set of 3D Gaussians in the rasterizer's parameterisation (means, w-first
//! quaternions, log-scales, opacity logits, degree-3 SH as DC plus 15 rest coefficients), held
//! as plain tensors between steps and copied into autodiff leaves (the same type) for each step.

use crate::checkpoint::{Checkpoint, CheckpointError};
use burn::tensor::{Device, Int, Tensor, TensorData};
use splatzoo_rasterizer::Splats;

/// The SH DC basis constant: colour = C0 · dc + 0.5.
pub use splatzoo_rasterizer::sh::SH_C0;
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

    /// The set behind degree-3 `splats` (what [`Self::splats`] gave, or a scene graph's render
    /// input, for `.ply` export); lower degrees are padded with zero coefficients.
    pub fn from_splats(splats: &Splats) -> GaussianSet {
        let [n, k, c] = splats.colors.dims();
        assert!(
            c == 3 && (1..=SH_REST + 1).contains(&k),
            "from_splats: colours [N, K ≤ 16, 3], got {:?}",
            [n, k, c]
        );
        let device = splats.colors.device();
        let pad = || Tensor::<3>::zeros([n, SH_REST + 1 - k, 3], &device);
        let sh_rest = match k {
            1 => pad(),
            k if k == SH_REST + 1 => splats.colors.clone().slice([0..n, 1..k, 0..3]),
            _ => Tensor::cat(
                vec![splats.colors.clone().slice([0..n, 1..k, 0..3]), pad()],
                1,
            ),
        };
        GaussianSet {
            means: splats.means.clone(),
            quats: splats.quats.clone(),
            log_scales: splats.log_scales.clone(),
            opacity_logits: splats.opacity_logits.clone(),
            sh_dc: splats.colors.clone().slice([0..n, 0..1, 0..3]),
            sh_rest,
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

    /// The rows `index` (in that order).
    pub fn select(&self, index: &[usize]) -> GaussianSet {
        let device = self.means.device();
        let index = Tensor::<1, Int>::from_data(
            TensorData::new(index.iter().map(|&i| i as i64).collect(), [index.len()]),
            &device,
        );
        GaussianSet {
            means: self.means.clone().select(0, index.clone()),
            quats: self.quats.clone().select(0, index.clone()),
            log_scales: self.log_scales.clone().select(0, index.clone()),
            opacity_logits: self.opacity_logits.clone().select(0, index.clone()),
            sh_dc: self.sh_dc.clone().select(0, index.clone()),
            sh_rest: self.sh_rest.clone().select(0, index),
        }
    }

    /// `self` followed by `more`.
    pub fn append(&self, more: &GaussianSet) -> GaussianSet {
        let cat2 = |a: &Tensor<2>, b: &Tensor<2>| Tensor::cat(vec![a.clone(), b.clone()], 0);
        let cat3 = |a: &Tensor<3>, b: &Tensor<3>| Tensor::cat(vec![a.clone(), b.clone()], 0);
        GaussianSet {
            means: cat2(&self.means, &more.means),
            quats: cat2(&self.quats, &more.quats),
            log_scales: cat2(&self.log_scales, &more.log_scales),
            opacity_logits: Tensor::cat(
                vec![self.opacity_logits.clone(), more.opacity_logits.clone()],
                0,
            ),
            sh_dc: cat3(&self.sh_dc, &more.sh_dc),
            sh_rest: cat3(&self.sh_rest, &more.sh_rest),
        }
    }

    /// The parameters on the host, row-major (for density control and exports).
    pub fn to_rows(&self) -> GaussianRows {
        use crate::host_f32 as host;
        GaussianRows {
            means: host(&self.means),
            quats: host(&self.quats),
            log_scales: host(&self.log_scales),
            opacity_logits: host(&self.opacity_logits),
            sh_dc: host(&self.sh_dc),
            sh_rest: host(&self.sh_rest),
        }
    }

    pub fn from_rows(rows: &GaussianRows, device: &Device) -> GaussianSet {
        let n = rows.len();
        let t2 = |v: &[f32], w: usize| {
            Tensor::<2>::from_data(TensorData::new(v.to_vec(), [n, w]), device)
        };
        let t3 = |v: &[f32], k: usize| {
            Tensor::<3>::from_data(TensorData::new(v.to_vec(), [n, k, 3]), device)
        };
        GaussianSet {
            means: t2(&rows.means, 3),
            quats: t2(&rows.quats, 4),
            log_scales: t2(&rows.log_scales, 3),
            opacity_logits: Tensor::from_data(
                TensorData::new(rows.opacity_logits.clone(), [n]),
                device,
            ),
            sh_dc: t3(&rows.sh_dc, 1),
            sh_rest: t3(&rows.sh_rest, SH_REST),
        }
    }

    /// Stores the parameters under gsplat's names (`{prefix}.means`, `.quats`, `.scales` (log),
    /// `.opacities` (logits), `.sh0`, `.shN`).
    pub fn save(&self, checkpoint: &mut Checkpoint, prefix: &str) {
        checkpoint.put(&format!("{prefix}.means"), &self.means);
        checkpoint.put(&format!("{prefix}.quats"), &self.quats);
        checkpoint.put(&format!("{prefix}.scales"), &self.log_scales);
        checkpoint.put(&format!("{prefix}.opacities"), &self.opacity_logits);
        checkpoint.put(&format!("{prefix}.sh0"), &self.sh_dc);
        checkpoint.put(&format!("{prefix}.shN"), &self.sh_rest);
    }

    /// The set saved under `prefix`; every tensor must agree on the number of Gaussians.
    pub fn load(
        checkpoint: &Checkpoint,
        prefix: &str,
        device: &Device,
    ) -> Result<GaussianSet, CheckpointError> {
        let name = |s: &str| format!("{prefix}.{s}");
        let means: Tensor<2> = checkpoint.tensor(&name("means"), [None, Some(3)], device)?;
        let n = Some(means.dims()[0]);
        Ok(GaussianSet {
            means,
            quats: checkpoint.tensor(&name("quats"), [n, Some(4)], device)?,
            log_scales: checkpoint.tensor(&name("scales"), [n, Some(3)], device)?,
            opacity_logits: checkpoint.tensor(&name("opacities"), [n], device)?,
            sh_dc: checkpoint.tensor(&name("sh0"), [n, Some(1), Some(3)], device)?,
            sh_rest: checkpoint.tensor(&name("shN"), [n, Some(SH_REST), Some(3)], device)?,
        })
    }
}

/// A [`GaussianSet`] on the host, row-major: widths 3, 4, 3, 1, 3 and 45 floats per Gaussian.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct GaussianRows {
    pub means: Vec<f32>,
    pub quats: Vec<f32>,
    pub log_scales: Vec<f32>,
    pub opacity_logits: Vec<f32>,
    pub sh_dc: Vec<f32>,
    pub sh_rest: Vec<f32>,
}

impl GaussianRows {
    pub fn len(&self) -> usize {
        self.opacity_logits.len()
    }

    pub fn is_empty(&self) -> bool {
        self.opacity_logits.is_empty()
    }

    /// Appends row `i` of `from`.
    pub fn push_from(&mut self, from: &GaussianRows, i: usize) {
        self.means.extend_from_slice(&from.means[3 * i..3 * i + 3]);
        self.quats.extend_from_slice(&from.quats[4 * i..4 * i + 4]);
        self.log_scales
            .extend_from_slice(&from.log_scales[3 * i..3 * i + 3]);
        self.opacity_logits.push(from.opacity_logits[i]);
        self.sh_dc.extend_from_slice(&from.sh_dc[3 * i..3 * i + 3]);
        let r = 3 * SH_REST;
        self.sh_rest
            .extend_from_slice(&from.sh_rest[r * i..r * i + r]);
    }

    pub fn mean(&self, i: usize) -> [f32; 3] {
        [
            self.means[3 * i],
            self.means[3 * i + 1],
            self.means[3 * i + 2],
        ]
    }

    pub fn scale(&self, i: usize) -> [f32; 3] {
        std::array::from_fn(|k| self.log_scales[3 * i + k].exp())
    }

    pub fn opacity(&self, i: usize) -> f32 {
        1.0 / (1.0 + (-self.opacity_logits[i]).exp())
    }

    /// The rotation matrix of row `i` (normalised quaternion; zero means identity).
    pub fn rotation(&self, i: usize) -> [[f32; 3]; 3] {
        let q: [f64; 4] = std::array::from_fn(|k| self.quats[4 * i + k] as f64);
        splatzoo_models::rotation_scalar::quaternion_matrix(q).map(|row| row.map(|v| v as f32))
    }
}
