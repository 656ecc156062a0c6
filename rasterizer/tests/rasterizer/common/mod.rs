//! Helpers shared by the tensor-level tests.
#![allow(dead_code)]

use burn::tensor::{Device, Gradients, Tensor};
use rand::{Rng, SeedableRng, rngs::StdRng};
use splatzoo_rasterizer::testing::{HostScene, SceneSpec, random_scene};
use splatzoo_rasterizer::{ColorMode, RasterMode};
use splatzoo_rasterizer::{RasterSettings, Render, Splats, rasterize};

pub fn values<const D: usize>(t: Tensor<D>) -> Vec<f32> {
    t.into_data()
        .convert::<f32>()
        .try_into_vec::<f32>()
        .unwrap()
}

/// Largest absolute difference relative to the largest magnitude of `expected`.
pub fn relative_error(actual: &[f32], expected: &[f32]) -> f32 {
    assert_eq!(actual.len(), expected.len());
    let scale = expected
        .iter()
        .fold(0.0f32, |m, v| m.max(v.abs()))
        .max(1e-6);
    let diff = actual
        .iter()
        .zip(expected)
        .fold(0.0f32, |m, (a, b)| m.max((a - b).abs()));
    diff / scale
}

/// Leaf tensors of a scene that require gradients.
pub struct Leaves {
    pub splats: Splats,
    pub background: Tensor<1>,
}

pub fn leaves(scene: &HostScene, device: &Device) -> Leaves {
    let (s, background) = scene.tensors(device);
    Leaves {
        splats: Splats {
            means: s.means.require_grad(),
            quats: s.quats.require_grad(),
            log_scales: s.log_scales.require_grad(),
            opacity_logits: s.opacity_logits.require_grad(),
            colors: s.colors.require_grad(),
        },
        background: background.require_grad(),
    }
}

impl Leaves {
    /// Gradients of every leaf, in the order means, quats, log_scales, opacity, colors, background.
    pub fn grads(&self, grads: &Gradients) -> Vec<(&'static str, Vec<f32>)> {
        let g2 = |t: &Tensor<2>| values(t.grad(grads).expect("gradient"));
        vec![
            ("means", g2(&self.splats.means)),
            ("quats", g2(&self.splats.quats)),
            ("log_scales", g2(&self.splats.log_scales)),
            (
                "opacity_logits",
                values(self.splats.opacity_logits.grad(grads).expect("gradient")),
            ),
            (
                "colors",
                values(self.splats.colors.grad(grads).expect("gradient")),
            ),
            (
                "background",
                values(self.background.grad(grads).expect("gradient")),
            ),
        ]
    }
}

/// The op's output packed like the reference's `[H, W, C + 2]`.
pub fn packed(render: &Render) -> Tensor<3> {
    let [h, w] = render.alpha.dims();
    Tensor::cat(
        vec![
            render.color.clone(),
            render.alpha.clone().reshape([h, w, 1]),
            render.accumulated_depth.clone().reshape([h, w, 1]),
        ],
        2,
    )
}

pub fn render(leaves: &Leaves, settings: &RasterSettings) -> Render {
    rasterize(&leaves.splats, leaves.background.clone(), settings).expect("valid inputs")
}

/// A random scene under settings that make the image smooth in its inputs (no alpha threshold,
/// a far cut-off), for gradient comparisons; with random loss weights over `[H, W, C + 2]`.
pub fn smooth_scene(
    seed: u64,
    splats: usize,
    (width, height): (u32, u32),
    color: ColorMode,
    mode: RasterMode,
) -> (HostScene, RasterSettings, Vec<f32>) {
    let mut spec = SceneSpec::new(splats, width, height, color);
    spec.opacity_range = (0.1, 0.7);
    let (scene, mut settings) = random_scene(seed, &spec);
    settings.alpha_min = 0.0;
    settings.clip_sigmas = 6.0;
    settings.mode = mode;
    let len = (width * height) as usize * (scene.channels + 2);
    let mut rng = StdRng::seed_from_u64(seed);
    let weights = (0..len).map(|_| rng.random_range(-1.0..1.0)).collect();
    (scene, settings, weights)
}

/// `weights` as a `[H, W, C + 2]` tensor matching `settings`' image.
pub fn weight_tensor(weights: &[f32], settings: &RasterSettings, device: &Device) -> Tensor<3> {
    let (h, w) = (
        settings.camera.height as usize,
        settings.camera.width as usize,
    );
    let c = weights.len() / (h * w) - 2;
    Tensor::<3>::from_data(
        burn::tensor::TensorData::new(weights.to_vec(), [h, w, c + 2]),
        device,
    )
}
