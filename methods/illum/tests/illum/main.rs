//! Illum's integration tests, one binary: the BRDF against its f64 reference and the white
//! furnace, Fibonacci sampling, Monte-Carlo shading against analytic irradiance, the light
//! volume's interpolation, the shadow decoder's occlusion, the smoothness terms, F_vis and its
//! ray-cast labels, stage 1's refined body, stage 2's lighting pipeline and the joint render.

mod backends;
mod brdf;
mod data;
mod disk;
mod environment;
mod extremes;
mod human;
mod light_volume;
mod lighting;
mod needs;
mod onnx;
mod probe_scores;
mod render;
mod sampling;
mod shading;
mod shadow;
mod smoothness;
mod stage1;
mod stage2;
mod trainer;
mod visibility;

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
