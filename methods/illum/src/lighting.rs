//! Stage 2's per-Gaussian lighting pipeline (§3.2): what reaches each human Gaussian from the
//! mesh and the light volume, and its shaded colour.
//!
//! - [`KnnTransfer`]: per-vertex quantities (normals, materials, skinning weights) carried to
//!   each Gaussian from its `k` nearest refined canonical vertices with inverse-distance
//!   weights `w ∝ 1/(d² + ε)` (spec: k = 3), rebuilt after density control.
//! - [`shade_gaussians`]: Eq. 6 (the volume's coefficients at each posed centre), the Fibonacci
//!   directions about the normal turned to the camera, the caller's visibility for those
//!   directions (F_vis, the ray cast, or none), and Eq. 7, giving linear RGB; the caller
//!   encodes it to sRGB ([`crate::pbr::linear_to_srgb`]) before the splat.

use crate::light_volume::LightVolume;
use crate::pbr::{ShadeInputs, Shading, face_forward, shade};
use crate::sampling::{HemisphereRule, fibonacci_hemisphere};
use burn::tensor::{Device, Int, Tensor, TensorData};
use splatzoo_models::knn::PointIndex;

/// Added to squared distances before inverting, so a Gaussian on a vertex takes that vertex's
/// value (up to `ε`-relative leakage) without dividing by zero.
pub const KNN_EPS: f64 = 1e-10;

/// Each Gaussian's `k` nearest vertices and their normalised inverse-distance weights.
#[derive(Debug, Clone)]
pub struct KnnTransfer {
    /// `[N, k]` vertex indices.
    pub indices: Tensor<2, Int>,
    /// `[N, k]` weights, each row summing to 1.
    pub weights: Tensor<2>,
}

impl KnnTransfer {
    /// Neighbours of `points` among `vertices` (both canonical); `k` is capped at the vertex
    /// count. Panics on an empty mesh (there is nothing to transfer from).
    pub fn new(points: &[[f32; 3]], vertices: &[[f32; 3]], k: usize, device: &Device) -> Self {
        assert!(
            !vertices.is_empty(),
            "KNN transfer from a mesh without vertices"
        );
        let k = k.clamp(1, vertices.len());
        let index = PointIndex::new(vertices);
        let n = points.len();
        let mut indices = Vec::with_capacity(n * k);
        let mut weights = Vec::with_capacity(n * k);
        for p in points {
            let near = index.k_nearest(*p, k, None);
            let inverse: Vec<f64> = near
                .iter()
                .map(|&(_, d2)| 1.0 / (f64::from(d2) + KNN_EPS))
                .collect();
            let total: f64 = inverse.iter().sum();
            for (&(j, _), w) in near.iter().zip(inverse) {
                indices.push(j as i64);
                weights.push((w / total) as f32);
            }
        }
        Self {
            indices: Tensor::<2, Int>::from_data(TensorData::new(indices, [n, k]), device),
            weights: Tensor::<2>::from_data(TensorData::new(weights, [n, k]), device),
        }
    }

    pub fn len(&self) -> usize {
        self.indices.dims()[0]
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// `[N, C]` blends of per-vertex values `[V, C]` (differentiable in the values).
    pub fn apply(&self, per_vertex: Tensor<2>) -> Tensor<2> {
        let [n, k] = self.indices.dims();
        let [_, c] = per_vertex.dims();
        let gathered = per_vertex
            .select(0, self.indices.clone().reshape([n * k]))
            .reshape([n, k, c]);
        (gathered * self.weights.clone().reshape([n, k, 1]))
            .sum_dim(1)
            .reshape([n, c])
    }
}

/// Monte-Carlo sampling of Eq. 7.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SamplingConfig {
    /// `N_l`: directions per Gaussian (spec: 32 in training, 64 in evaluation).
    pub count: usize,
    pub rule: HemisphereRule,
}

/// A human Gaussian's material: `[N, 3]` linear albedo, `[N, 1]` metallic and roughness.
#[derive(Debug, Clone)]
pub struct Material {
    pub albedo: Tensor<2>,
    pub metallic: Tensor<2>,
    pub roughness: Tensor<2>,
}

/// Unit directions `[N, 3]` from each point `[N, 3]` to the camera centre (ω_o).
pub fn view_directions(points: Tensor<2>, camera_centre: [f64; 3]) -> Tensor<2> {
    let device = points.device();
    let centre = Tensor::<2>::from_data(
        TensorData::new(camera_centre.map(|v| v as f32).to_vec(), [1, 3]),
        &device,
    );
    let towards = centre - points;
    let length = (towards.clone().powi_scalar(2).sum_dim(1) + 1e-30).sqrt();
    towards / length
}

/// The human Gaussians of one frame, as [`shade_gaussians`] needs them.
#[derive(Debug, Clone)]
pub struct LitGaussians {
    /// `[N, 3]` posed world centres.
    pub points: Tensor<2>,
    /// `[N, 3]` posed world normals (unit; turned to the camera inside).
    pub normals: Tensor<2>,
    pub material: Material,
    pub camera_centre: [f64; 3],
    /// `[N]` azimuth offsets of each Gaussian's sample set (training); `None` at evaluation.
    pub azimuth_offsets: Option<Tensor<1>>,
}

/// Linear RGB `[N, 3]` of `gaussians` lit by `volume` (Eq. 6) and shaded by Eq. 7.
/// `visibility` receives the sampled directions `[N, S, 3]` (world frame) and returns `V`
/// `[N, S]`, or `None` for `V ≡ 1`.
pub fn shade_gaussians(
    volume: &LightVolume,
    gaussians: LitGaussians,
    sampling: SamplingConfig,
    visibility: impl FnOnce(&Tensor<3>) -> Option<Tensor<2>>,
    shading: &Shading,
) -> Tensor<2> {
    let LitGaussians {
        points,
        normals,
        material,
        camera_centre,
        azimuth_offsets,
    } = gaussians;
    let view = view_directions(points.clone(), camera_centre);
    let facing = face_forward(normals, view.clone());
    let directions = fibonacci_hemisphere(
        facing.clone(),
        sampling.count,
        sampling.rule,
        azimuth_offsets,
    );
    let visibility = visibility(&directions);
    let (radiance_sh, _) = volume.interpolate(points);
    shade(
        ShadeInputs {
            normals: facing,
            view_dirs: view,
            albedo: material.albedo,
            metallic: material.metallic,
            roughness: material.roughness,
            radiance_sh,
            directions,
            visibility,
        },
        shading,
    )
}
