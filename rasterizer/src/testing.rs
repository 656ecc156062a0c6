//! Random scenes for tests and benchmarks: a camera looking at a cloud of splats, generated
//! from a seed on the host so any backend (and the f64 kernel) can be fed the same values.

use crate::camera::{Camera, ColorMode, RasterSettings};
use crate::cpu::{Splats as CpuSplats, sh};
use rand::{Rng, SeedableRng, rngs::StdRng};

/// Host copy of a splat set, flattened row-major.
#[derive(Debug, Clone)]
pub struct HostScene {
    pub count: usize,
    pub coeffs: usize,
    pub channels: usize,
    pub means: Vec<f32>,
    pub quats: Vec<f32>,
    pub log_scales: Vec<f32>,
    pub opacity_logits: Vec<f32>,
    pub colors: Vec<f32>,
    pub background: Vec<f32>,
}

/// Knobs of [`random_scene`].
#[derive(Debug, Clone, Copy)]
pub struct SceneSpec {
    pub splats: usize,
    pub width: u32,
    pub height: u32,
    pub color: ColorMode,
    /// Colour channels for [`ColorMode::Features`] (SH is always RGB).
    pub feature_channels: usize,
    /// Range of standard deviations, world units.
    pub scale_range: (f32, f32),
    /// Range of opacities (before the logit).
    pub opacity_range: (f32, f32),
}

impl SceneSpec {
    pub fn new(splats: usize, width: u32, height: u32, color: ColorMode) -> Self {
        Self {
            splats,
            width,
            height,
            color,
            feature_channels: 4,
            scale_range: (0.03, 0.25),
            opacity_range: (0.1, 0.9),
        }
    }
}

/// A camera 4 units from the origin looking at it, 60° horizontal field of view.
pub fn default_camera(width: u32, height: u32) -> Camera {
    Camera::look_at(
        [0.4, -0.3, -4.0],
        [0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        60.0,
        width,
        height,
    )
}

/// Splats uniformly in a cube of side 2 around the origin, with random rotations, scales,
/// opacities and colours.
pub fn random_scene(seed: u64, spec: &SceneSpec) -> (HostScene, RasterSettings) {
    let mut rng = StdRng::seed_from_u64(seed);
    let n = spec.splats;
    let (coeffs, channels) = match spec.color {
        ColorMode::Sh { degree } => (sh::coeff_count(degree), 3),
        ColorMode::Features => (1, spec.feature_channels),
    };
    let mut uniform = |lo: f32, hi: f32, count: usize| -> Vec<f32> {
        (0..count).map(|_| rng.random_range(lo..hi)).collect()
    };
    let means = uniform(-1.0, 1.0, n * 3);
    let quats = uniform(-1.0, 1.0, n * 4);
    let (s0, s1) = spec.scale_range;
    let log_scales = uniform(s0.ln(), s1.ln(), n * 3);
    let (o0, o1) = spec.opacity_range;
    let opacity_logits = uniform(o0, o1, n)
        .into_iter()
        .map(|o| (o / (1.0 - o)).ln())
        .collect();
    let mut colors = uniform(-0.2, 0.2, n * coeffs * channels);
    if matches!(spec.color, ColorMode::Sh { .. }) {
        // DC terms well above the clamp at 0.
        let dc = uniform(0.0, 1.2, n * channels);
        for i in 0..n {
            colors[i * coeffs * channels..i * coeffs * channels + channels]
                .copy_from_slice(&dc[i * channels..(i + 1) * channels]);
        }
    }
    let background = uniform(0.0, 1.0, channels);
    let settings = RasterSettings::new(default_camera(spec.width, spec.height), spec.color);
    (
        HostScene {
            count: n,
            coeffs,
            channels,
            means,
            quats,
            log_scales,
            opacity_logits,
            colors,
            background,
        },
        settings,
    )
}

impl HostScene {
    /// The scene converted to `T` (with zero screen offsets), for the CPU kernels.
    pub fn to_real<T: crate::cpu::Real>(&self) -> RealScene<T> {
        let cast = |v: &[f32]| v.iter().map(|&x| T::of(x as f64)).collect::<Vec<T>>();
        RealScene {
            count: self.count,
            coeffs: self.coeffs,
            channels: self.channels,
            means: cast(&self.means),
            quats: cast(&self.quats),
            log_scales: cast(&self.log_scales),
            opacity_logits: cast(&self.opacity_logits),
            colors: cast(&self.colors),
            background: cast(&self.background),
            screen_offsets: vec![T::zero(); self.count * 2],
        }
    }

    /// The scene as tensors on `device`.
    pub fn tensors(
        &self,
        device: &burn::tensor::Device,
    ) -> (crate::Splats, burn::tensor::Tensor<1>) {
        use burn::tensor::{Tensor, TensorData};
        let n = self.count;
        let t2 = |v: &[f32], d: usize| {
            Tensor::<2>::from_data(TensorData::new(v.to_vec(), [n, d]), device)
        };
        (
            crate::Splats {
                means: t2(&self.means, 3),
                quats: t2(&self.quats, 4),
                log_scales: t2(&self.log_scales, 3),
                opacity_logits: Tensor::<1>::from_data(
                    TensorData::new(self.opacity_logits.clone(), [n]),
                    device,
                ),
                colors: Tensor::<3>::from_data(
                    TensorData::new(self.colors.clone(), [n, self.coeffs, self.channels]),
                    device,
                ),
            },
            Tensor::<1>::from_data(
                TensorData::new(self.background.clone(), [self.channels]),
                device,
            ),
        )
    }
}

/// A scene in the kernels' precision, owning its buffers.
#[derive(Debug, Clone)]
pub struct RealScene<T> {
    pub count: usize,
    pub coeffs: usize,
    pub channels: usize,
    pub means: Vec<T>,
    pub quats: Vec<T>,
    pub log_scales: Vec<T>,
    pub opacity_logits: Vec<T>,
    pub colors: Vec<T>,
    pub background: Vec<T>,
    pub screen_offsets: Vec<T>,
}

impl<T> RealScene<T> {
    pub fn splats(&self) -> CpuSplats<'_, T> {
        CpuSplats {
            count: self.count,
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

    /// Every parameter buffer, named, mutable (for finite differences).
    pub fn buffers_mut(&mut self) -> [(&'static str, &mut Vec<T>); 7] {
        [
            ("means", &mut self.means),
            ("quats", &mut self.quats),
            ("log_scales", &mut self.log_scales),
            ("opacity_logits", &mut self.opacity_logits),
            ("colors", &mut self.colors),
            ("background", &mut self.background),
            ("screen_offsets", &mut self.screen_offsets),
        ]
    }
}
