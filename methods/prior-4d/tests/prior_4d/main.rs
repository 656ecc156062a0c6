//! Prior-4D's integration tests, one binary: the floor plane and σ₀, the contact, normal and
//! Huber terms against hand-computed values, the locator's σ-invariance, camera refinement,
//! rendered normals against analytic ones, the pose-dependent offsets' place in Eq. 2, and
//! stage C's keypoint fit ([`keypoints`]), and the priors taken from the acting video
//! ([`sources`]); stage D on every backend ([`backends`]) and from user `.ply` files
//! ([`start_from_ply`]); a NeuMan folder read as the acting video ([`neuman`]) and the scans
//! given beside it ([`scans`]).

mod backends;
mod data;
mod extremes;
mod geometry;
mod keypoints;
mod neuman;
mod objective;
mod offsets;
mod plane;
mod scans;
mod sources;
mod start_from_ply;
mod trainer;

use burn::tensor::Tensor;

/// A seed from the clock, so each run draws fresh random inputs (print it on failure).
pub fn fresh_seed() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .expect("the clock is past 1970")
        .as_nanos() as u64
}

/// SplitMix64, for fresh random inputs.
pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[lo, hi)`.
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        let unit = (self.next_u64() >> 11) as f64 * (0.5 * f64::EPSILON);
        lo + (hi - lo) * unit
    }

    /// Roughly standard normal: the sum of 12 uniforms, less 6.
    pub fn gauss(&mut self) -> f64 {
        (0..12).map(|_| self.range(0.0, 1.0)).sum::<f64>() - 6.0
    }
}

/// A tensor's values as `f32`.
pub fn values<const D: usize>(t: Tensor<D>) -> Vec<f32> {
    t.into_data()
        .convert::<f32>()
        .try_into_vec::<f32>()
        .expect("f32 data")
}

/// The largest `|a − b|` over two equally long slices.
pub fn max_abs_difference(a: &[f32], b: &[f32]) -> f32 {
    assert_eq!(a.len(), b.len(), "compared slices differ in length");
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max)
}

/// `a` and `b` agree: size exactly, intrinsics and every world-to-camera entry within `tol`.
pub fn assert_same_camera(
    a: &splatzoo_rasterizer::Camera,
    b: &splatzoo_rasterizer::Camera,
    tol: f32,
    what: &str,
) {
    assert_eq!((a.width, a.height), (b.width, b.height), "{what}: size");
    let intrinsics = [a.fx - b.fx, a.fy - b.fy, a.cx - b.cx, a.cy - b.cy];
    assert!(
        intrinsics.iter().all(|d| d.abs() < 1e-3),
        "{what}: intrinsics off by {intrinsics:?}"
    );
    for i in 0..3 {
        for j in 0..4 {
            let d = (a.world_to_camera[i][j] - b.world_to_camera[i][j]).abs();
            assert!(d < tol, "{what}: world_to_camera[{i}][{j}] off by {d}");
        }
    }
}
