//! The public entry point: shape-checked splat tensors in, image tensors out, on any backend.

use crate::backend::{SplatBackend, SplatInputs};
use crate::camera::{ColorMode, RasterSettings};
use crate::cpu::{PROJ_RADIUS, sh};
use crate::error::RasterError;
use burn::backend::Dispatch;
use burn::tensor::{Bool, Tensor};

/// Most splats one render takes (GPU launch grids and `f32` list indices bound it).
pub const MAX_SPLATS: usize = 16_000_000;

/// A set of 3D Gaussians, one row per splat.
#[derive(Debug, Clone)]
pub struct Splats {
    /// `[N, 3]` world-space centres.
    pub means: Tensor<2>,
    /// `[N, 4]` rotations as unnormalised quaternions (w, x, y, z); zero means identity.
    pub quats: Tensor<2>,
    /// `[N, 3]` natural-log standard deviations.
    pub log_scales: Tensor<2>,
    /// `[N]` opacity logits (opacity = sigmoid).
    pub opacity_logits: Tensor<1>,
    /// `[N, K, C]`: SH coefficients (`C = 3`, `K >= (degree + 1)²`, coefficient 0 is the DC term)
    /// or free features (`K = 1`).
    pub colors: Tensor<3>,
}

impl Splats {
    pub fn len(&self) -> usize {
        self.means.dims()[0]
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    fn check(&self, background: &Tensor<1>, settings: &RasterSettings) -> Result<(), RasterError> {
        let n = self.len();
        let shape_err = |name, expected: String, got: &[usize]| RasterError::Shape {
            name,
            expected,
            got: got.to_vec(),
        };
        let [_, d] = self.means.dims();
        if d != 3 {
            return Err(shape_err("means", "[N, 3]".into(), &self.means.dims()));
        }
        if self.quats.dims() != [n, 4] {
            return Err(shape_err("quats", format!("[{n}, 4]"), &self.quats.dims()));
        }
        if self.log_scales.dims() != [n, 3] {
            return Err(shape_err(
                "log_scales",
                format!("[{n}, 3]"),
                &self.log_scales.dims(),
            ));
        }
        if self.opacity_logits.dims() != [n] {
            return Err(shape_err(
                "opacity_logits",
                format!("[{n}]"),
                &self.opacity_logits.dims(),
            ));
        }
        let [cn, k, c] = self.colors.dims();
        let expected = match settings.color {
            ColorMode::Sh { degree } => {
                let need = sh::coeff_count(degree);
                (cn == n && k >= need && c == 3)
                    .then_some(())
                    .ok_or_else(|| format!("[{n}, >= {need}, 3] for SH degree {degree}"))
            }
            ColorMode::Features => (cn == n && k == 1 && c >= 1)
                .then_some(())
                .ok_or_else(|| format!("[{n}, 1, C] for features")),
        };
        if let Err(expected) = expected {
            return Err(shape_err("colors", expected, &self.colors.dims()));
        }
        if background.dims() != [c] {
            return Err(shape_err(
                "background",
                format!("[{c}]"),
                &background.dims(),
            ));
        }
        if n > MAX_SPLATS {
            return Err(RasterError::Value {
                name: "means",
                problem: format!("{n} splats exceed the supported {MAX_SPLATS}"),
            });
        }
        let on_gpu = matches!(
            self.means.device().inner().as_dispatch(),
            burn::backend::DispatchDevice::Cube(_)
        );
        if on_gpu && c > crate::cube_backend::MAX_GPU_CHANNELS {
            return Err(shape_err(
                "colors",
                format!(
                    "[N, K, C] with C <= {} on a GPU device",
                    crate::cube_backend::MAX_GPU_CHANNELS
                ),
                &self.colors.dims(),
            ));
        }
        Ok(())
    }
}

/// One rendered view.
#[derive(Debug, Clone)]
pub struct Render {
    /// `[H, W, C]` colour over the background.
    pub color: Tensor<3>,
    /// `[H, W]` accumulated opacity `1 − T`.
    pub alpha: Tensor<2>,
    /// `[H, W]` expected depth `Σ wᵢ zᵢ / max(alpha, 1e-6)` (camera z, not distance).
    pub depth: Tensor<2>,
    /// `[H, W]` un-normalised depth `Σ wᵢ zᵢ`.
    pub accumulated_depth: Tensor<2>,
    /// `[N]` screen radius in pixels, 0 for culled splats (no gradient).
    pub radii: Tensor<1>,
    /// `[N, 2]` the zero offsets added to the projected means; after `backward`, their gradient
    /// is dL/d(screen position) in pixels.
    pub screen_offsets: Tensor<2>,
}

impl Render {
    /// Splats that reached the image (not culled).
    pub fn visible(&self) -> Tensor<1, Bool> {
        self.radii.clone().greater_elem(0.0)
    }

    /// `‖dL/d(screen position)‖` per splat in pixels: the statistic adaptive density control
    /// thresholds. `None` outside autodiff or before a backward pass through this render.
    pub fn screen_gradient_norm(&self, grads: &burn::tensor::Gradients) -> Option<Tensor<1>> {
        let g = self.screen_offsets.grad(grads)?;
        Some(g.powi_scalar(2).sum_dim(1).sqrt().squeeze_dim(1))
    }
}

/// Renders `splats` from `settings.camera` over `background` (`[C]`).
///
/// Works on every backend the crate supports (see the crate doc); under autodiff every input
/// receives gradients. Splats holding NaN or ±∞ in any parameter are culled (radius 0, zero
/// gradients) rather than poisoning the image; non-finite background values are the caller's
/// responsibility and are rejected here.
pub fn rasterize(
    splats: &Splats,
    background: Tensor<1>,
    settings: &RasterSettings,
) -> Result<Render, RasterError> {
    settings.validate()?;
    splats.check(&background, settings)?;
    let n = splats.len();
    let [_, _, c] = splats.colors.dims();
    let bg_values = background
        .clone()
        .into_data()
        .convert::<f32>()
        .try_into_vec::<f32>()
        .unwrap_or_default();
    if bg_values.iter().any(|v| !v.is_finite()) {
        return Err(RasterError::Value {
            name: "background",
            problem: format!("holds a non-finite value: {bg_values:?}"),
        });
    }
    let device = splats.means.device();
    let mut screen_offsets = Tensor::<2>::zeros([n, 2], &device);
    if screen_offsets.is_autodiff() {
        screen_offsets = screen_offsets.require_grad();
    }
    let inputs = SplatInputs {
        means: splats.means.clone().into_dispatch(),
        quats: splats.quats.clone().into_dispatch(),
        log_scales: splats.log_scales.clone().into_dispatch(),
        opacity_logits: splats.opacity_logits.clone().into_dispatch(),
        colors: splats.colors.clone().into_dispatch(),
        background: background.into_dispatch(),
        screen_offsets: screen_offsets.clone().into_dispatch(),
    };
    let out = <Dispatch as SplatBackend>::splat_forward(inputs, *settings);
    let image = Tensor::<3>::from_dispatch(out.image);
    let projected = Tensor::<2>::from_dispatch(out.saved.projected);
    let (h, w) = (
        settings.camera.height as usize,
        settings.camera.width as usize,
    );
    let color = image.clone().slice([0..h, 0..w, 0..c]);
    let alpha = image.clone().slice([0..h, 0..w, c..c + 1]).reshape([h, w]);
    let accumulated_depth = image.slice([0..h, 0..w, c + 1..c + 2]).reshape([h, w]);
    let depth = accumulated_depth.clone() / alpha.clone().clamp_min(1e-6);
    let radii = projected
        .slice([0..n, PROJ_RADIUS..PROJ_RADIUS + 1])
        .reshape([n])
        .detach();
    Ok(Render {
        color,
        alpha,
        depth,
        accumulated_depth,
        radii,
        screen_offsets,
    })
}
