//! Points to initialise Gaussians from, in order of preference: a capture's sparse points
//! (COLMAP's `points3D`, nerfstudio's `ply_file_path`, NeuMan's model), each scaled as 3DGS
//! does by the root mean square distance to its three nearest neighbours; depth back-projected
//! from the training views (the synthetic ground truth, a nerfstudio `depth_file_path`; an
//! RGB-D stand-in for SfM points); otherwise uniform random points in the cameras' bounding box
//! (3DGS's random initialisation).

use rayon::prelude::*;
use splatzoo_datasets::formats::SparsePoint;
use splatzoo_datasets::synth::rng::Rng;
use splatzoo_models::knn::PointIndex;
use splatzoo_rasterizer::Camera;

/// Points to initialise Gaussians from.
#[derive(Debug, Clone, Default)]
pub struct InitPoints {
    pub positions: Vec<[f32; 3]>,
    /// sRGB in [0, 1].
    pub colours: Vec<[f32; 3]>,
    /// Isotropic standard deviation per point, world units.
    pub sigmas: Vec<f32>,
}

impl InitPoints {
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// At most `keep` of the points, a random subset drawn from `seed` (kept in their order).
    pub fn thinned(self, keep: usize, seed: u64) -> Self {
        if self.len() <= keep {
            return self;
        }
        let mut order: Vec<usize> = (0..self.len()).collect();
        splatzoo_datasets::synth::rng::Rng(seed).shuffle(&mut order);
        order.truncate(keep);
        order.sort_unstable();
        Self {
            positions: order.iter().map(|&i| self.positions[i]).collect(),
            colours: order.iter().map(|&i| self.colours[i]).collect(),
            sigmas: order.iter().map(|&i| self.sigmas[i]).collect(),
        }
    }

    /// The points as sparse points (positions widened to f64, sRGB colours; the scales dropped).
    pub fn to_sparse(&self) -> Vec<SparsePoint> {
        self.positions
            .iter()
            .zip(&self.colours)
            .map(|(p, c)| (p.map(f64::from), *c))
            .collect()
    }

    /// Sparse points, each with 3DGS's scale: `sqrt(mean d²)` over its three nearest neighbours
    /// (`distCUDA2`), floored at 1e-7 of the cloud's diagonal so duplicates stay finite.
    pub fn from_sparse(points: &[SparsePoint]) -> Self {
        let positions: Vec<[f32; 3]> = points.iter().map(|(p, _)| p.map(|v| v as f32)).collect();
        let sigmas = nearest_neighbour_scales(&positions, 3);
        Self {
            colours: points.iter().map(|(_, c)| *c).collect(),
            positions,
            sigmas,
        }
    }
}

/// `sqrt(mean d²)` over each point's `k` nearest other points (exact, by the engine's
/// [`PointIndex`]), floored at 1e-7 of the cloud's diagonal so duplicates stay finite.
pub fn nearest_neighbour_scales(positions: &[[f32; 3]], k: usize) -> Vec<f32> {
    let n = positions.len();
    if n < 2 {
        return vec![1e-2; n];
    }
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for p in positions {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    let diagonal = (0..3).map(|a| (hi[a] - lo[a]).powi(2)).sum::<f32>().sqrt();
    let floor = (diagonal * 1e-7).max(f32::MIN_POSITIVE);
    let index = PointIndex::new(positions);
    positions
        .par_iter()
        .enumerate()
        .map(|(i, p)| {
            let best = index.k_nearest(*p, k, Some(i));
            let mean = best.iter().map(|&(_, d2)| d2).sum::<f32>() / best.len().max(1) as f32;
            mean.sqrt().max(floor)
        })
        .collect()
}

/// Back-projects every `stride`-th pixel with finite positive depth (camera z, world units).
pub fn back_project(
    camera: &Camera,
    depth: &[f32],
    srgb: &[f32],
    stride: usize,
    points: &mut InitPoints,
) {
    let (w, h) = (camera.width as usize, camera.height as usize);
    let m = camera.world_to_camera;
    for y in (0..h).step_by(stride) {
        for x in (0..w).step_by(stride) {
            let d = depth[y * w + x];
            if !(d.is_finite() && d > 0.0) {
                continue;
            }
            let c = [
                d * (x as f32 + 0.5 - camera.cx) / camera.fx,
                d * (y as f32 + 0.5 - camera.cy) / camera.fy,
                d,
            ];
            // World = Rᵀ (c − t).
            points.positions.push(std::array::from_fn(|j| {
                (0..3).map(|i| m[i][j] * (c[i] - m[i][3])).sum()
            }));
            let p = 3 * (y * w + x);
            points.colours.push([srgb[p], srgb[p + 1], srgb[p + 2]]);
            points.sigmas.push(0.5 * stride as f32 * d / camera.fx);
        }
    }
}

/// A sparse depth map (camera z; NaN where no point lands) of world `points` seen by `camera`:
/// each point in front of the camera (`near < z ≤ far`) marks the pixel its projection falls
/// in (pixel centres at +0.5), the nearest point winning. The inverse of [`back_project`] for
/// a LiDAR scan: its returns as the depth a view would have measured.
pub fn sparse_depth(camera: &Camera, points: &[[f64; 3]]) -> Vec<f32> {
    let (w, h) = (camera.width as usize, camera.height as usize);
    let m = camera.world_to_camera.map(|row| row.map(f64::from));
    let mut depth = vec![f32::NAN; w * h];
    for p in points {
        let c: [f64; 3] =
            std::array::from_fn(|i| (0..3).map(|j| m[i][j] * p[j]).sum::<f64>() + m[i][3]);
        if !(c[2] > camera.near as f64 && c[2] <= camera.far as f64) {
            continue;
        }
        let u = camera.fx as f64 * c[0] / c[2] + camera.cx as f64;
        let v = camera.fy as f64 * c[1] / c[2] + camera.cy as f64;
        if !(u >= 0.0 && v >= 0.0 && u < w as f64 && v < h as f64) {
            continue;
        }
        let at = &mut depth[v as usize * w + u as usize];
        if at.is_nan() || (c[2] as f32) < *at {
            *at = c[2] as f32;
        }
    }
    depth
}

/// Uniform random points with random colours in the box spanned by the cameras and the points
/// 1 m in front of each (3DGS's initialisation where no SfM points exist).
pub fn random_points(cameras: &[Camera], count: usize, seed: u64) -> InitPoints {
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for c in cameras {
        let p = c.position();
        let m = c.world_to_camera;
        let ahead: [f32; 3] = std::array::from_fn(|k| p[k] + m[2][k]);
        for q in [p, ahead] {
            for k in 0..3 {
                lo[k] = lo[k].min(q[k]);
                hi[k] = hi[k].max(q[k]);
            }
        }
    }
    let mut rng = Rng(seed ^ 0x4A4D_0000);
    let diagonal = (0..3).map(|k| (hi[k] - lo[k]).powi(2)).sum::<f32>().sqrt();
    let sigma = 0.5 * diagonal / (count.max(1) as f32).cbrt();
    let mut points = InitPoints::default();
    for _ in 0..count {
        points.positions.push(std::array::from_fn(|k| {
            rng.range(lo[k] as f64, hi[k] as f64) as f32
        }));
        points
            .colours
            .push(std::array::from_fn(|_| rng.next() as f32));
        points.sigmas.push(sigma);
    }
    points
}
