//! Front-to-back alpha compositing of each tile's sorted splats, and its backward (back to front,
//! recovering transmittance by division as INRIA 3DGS and gsplat do).

use super::bin::TileBins;
use super::real::Real;
use super::{ALPHA_MAX, PROJ_COLOR, PROJ_CONIC, PROJ_DEPTH, PROJ_OPACITY, TILE, TRANSMITTANCE_MIN};
use crate::camera::RasterSettings;
use rayon::prelude::*;

/// What a render leaves behind: the image and what the backward needs.
pub struct Blended<T> {
    /// `[H, W, C + 2]`: colour (with background), alpha, accumulated depth `Σ wᵢ zᵢ`.
    pub image: Vec<T>,
    /// `[H, W]` transmittance after the last contributing splat.
    pub final_transmittance: Vec<T>,
    /// `[H, W]` number of list entries each pixel walked before it stopped.
    pub contributors: Vec<u32>,
}

/// One splat's screen-space data, copied next to its tile's other splats.
#[derive(Clone, Copy)]
struct Local<T> {
    xy: [T; 2],
    conic: [T; 3],
    opacity: T,
    depth: T,
    splat: usize,
}

fn gather<T: Real>(projected: &[T], stride: usize, ids: &[u32]) -> Vec<Local<T>> {
    ids.iter()
        .map(|&id| {
            let row = &projected[id as usize * stride..(id as usize + 1) * stride];
            Local {
                xy: [row[0], row[1]],
                conic: [row[PROJ_CONIC], row[PROJ_CONIC + 1], row[PROJ_CONIC + 2]],
                opacity: row[PROJ_OPACITY],
                depth: row[PROJ_DEPTH],
                splat: id as usize,
            }
        })
        .collect()
}

/// Gaussian falloff exponent `σ` at a pixel centre, and the offsets `(dx, dy)`.
#[inline]
fn falloff<T: Real>(s: &Local<T>, px: T, py: T) -> (T, T, T) {
    let dx = px - s.xy[0];
    let dy = py - s.xy[1];
    let sigma = T::of(0.5) * (s.conic[0] * dx * dx + s.conic[2] * dy * dy) + s.conic[1] * dx * dy;
    (sigma, dx, dy)
}

/// Thresholds shared by forward and backward, so both skip exactly the same contributions.
#[derive(Clone, Copy)]
struct Cutoffs<T> {
    sigma_max: T,
    alpha_min: T,
}

impl<T: Real> Cutoffs<T> {
    fn new(settings: &RasterSettings) -> Self {
        let k = settings.clip_sigmas as f64;
        Self {
            sigma_max: T::of(0.5 * k * k),
            alpha_min: T::of(settings.alpha_min as f64),
        }
    }

    /// `(alpha, falloff value G, unclamped)` or `None` if the contribution is skipped.
    #[inline]
    fn alpha(&self, s: &Local<T>, sigma: T) -> Option<(T, T, bool)> {
        if sigma < T::zero() || sigma > self.sigma_max {
            return None;
        }
        let g = (-sigma).exp();
        let raw = s.opacity * g;
        let alpha = raw.min(T::of(ALPHA_MAX));
        if alpha < self.alpha_min || !(alpha > T::zero()) {
            return None;
        }
        Some((alpha, g, raw < T::of(ALPHA_MAX)))
    }
}

/// Renders the binned splats over `background`.
pub fn blend_forward<T: Real>(
    projected: &[T],
    channels: usize,
    bins: &TileBins,
    background: &[T],
    settings: &RasterSettings,
) -> Blended<T> {
    let (width, height) = (
        settings.camera.width as usize,
        settings.camera.height as usize,
    );
    let stride = super::proj_stride(channels);
    let out_ch = channels + 2;
    let mut image = vec![T::zero(); width * height * out_ch];
    let mut final_transmittance = vec![T::one(); width * height];
    let mut contributors = vec![0u32; width * height];
    let cut = Cutoffs::new(settings);
    image
        .par_chunks_mut(TILE * width * out_ch)
        .zip(final_transmittance.par_chunks_mut(TILE * width))
        .zip(contributors.par_chunks_mut(TILE * width))
        .enumerate()
        .for_each(|(ty, ((img, trans), count))| {
            let rows = trans.len() / width;
            let mut color = vec![T::zero(); channels];
            for tx in 0..bins.tiles_x {
                let range = bins.tile_range(ty * bins.tiles_x + tx);
                let local = gather(projected, stride, &bins.splat_from_isect[range]);
                let x_end = ((tx + 1) * TILE).min(width);
                for r in 0..rows {
                    let py = T::of((ty * TILE + r) as f64 + 0.5);
                    for x in tx * TILE..x_end {
                        let px = T::of(x as f64 + 0.5);
                        let mut t = T::one();
                        let mut depth = T::zero();
                        let mut last = 0u32;
                        color.iter_mut().for_each(|c| *c = T::zero());
                        for (j, s) in local.iter().enumerate() {
                            let (sigma, _, _) = falloff(s, px, py);
                            let Some((alpha, _, _)) = cut.alpha(s, sigma) else {
                                continue;
                            };
                            let next_t = t * (T::one() - alpha);
                            if next_t < T::of(TRANSMITTANCE_MIN) {
                                break;
                            }
                            let w = alpha * t;
                            let row =
                                &projected[s.splat * stride + PROJ_COLOR..(s.splat + 1) * stride];
                            for (c, v) in color.iter_mut().zip(row) {
                                *c = *c + *v * w;
                            }
                            depth = depth + s.depth * w;
                            t = next_t;
                            last = j as u32 + 1;
                        }
                        let p = r * width + x;
                        let out = &mut img[p * out_ch..(p + 1) * out_ch];
                        for ch in 0..channels {
                            out[ch] = color[ch] + t * background[ch];
                        }
                        out[channels] = T::one() - t;
                        out[channels + 1] = depth;
                        trans[p] = t;
                        count[p] = last;
                    }
                }
            }
        });
    Blended {
        image,
        final_transmittance,
        contributors,
    }
}

/// Backward of `blend_forward`: returns dL/d(projected rows) (radius slot zero) and dL/dbackground.
#[allow(clippy::too_many_arguments)]
pub fn blend_backward<T: Real>(
    projected: &[T],
    channels: usize,
    bins: &TileBins,
    background: &[T],
    settings: &RasterSettings,
    final_transmittance: &[T],
    contributors: &[u32],
    grad_image: &[T],
) -> (Vec<T>, Vec<T>) {
    let width = settings.camera.width as usize;
    let stride = super::proj_stride(channels);
    let out_ch = channels + 2;
    let cut = Cutoffs::new(settings);
    let n_splats = projected.len() / stride;

    // One gradient row per (tile, splat) intersection, so tiles never write to shared memory.
    let mut isect_grads = vec![T::zero(); bins.splat_from_isect.len() * stride];
    let mut row_slices: Vec<&mut [T]> = Vec::with_capacity(bins.tiles_y);
    let mut rest = isect_grads.as_mut_slice();
    for ty in 0..bins.tiles_y {
        let range = bins.offsets[ty * bins.tiles_x]..bins.offsets[(ty + 1) * bins.tiles_x];
        let (head, tail) = rest.split_at_mut(range.len() * stride);
        row_slices.push(head);
        rest = tail;
    }
    let height = settings.camera.height as usize;
    let bg_parts: Vec<Vec<T>> = row_slices
        .into_par_iter()
        .enumerate()
        .map(|(ty, grads)| {
            let row_start = bins.offsets[ty * bins.tiles_x];
            let rows = (height - ty * TILE).min(TILE);
            let mut grad_bg = vec![T::zero(); channels];
            let mut acc = vec![T::zero(); channels];
            for tx in 0..bins.tiles_x {
                let range = bins.tile_range(ty * bins.tiles_x + tx);
                let base = range.start - row_start;
                let local = gather(projected, stride, &bins.splat_from_isect[range]);
                let x_end = ((tx + 1) * TILE).min(width);
                for r in 0..rows {
                    let y = ty * TILE + r;
                    let py = T::of(y as f64 + 0.5);
                    for x in tx * TILE..x_end {
                        let px = T::of(x as f64 + 0.5);
                        let p = y * width + x;
                        let g = &grad_image[p * out_ch..(p + 1) * out_ch];
                        let (g_color, g_alpha, g_depth) =
                            (&g[..channels], g[channels], g[channels + 1]);
                        let t_final = final_transmittance[p];
                        for ch in 0..channels {
                            grad_bg[ch] = grad_bg[ch] + g_color[ch] * t_final;
                            acc[ch] = background[ch] * t_final;
                        }
                        let mut acc_depth = T::zero();
                        let mut t = t_final;
                        for j in (0..contributors[p] as usize).rev() {
                            let s = &local[j];
                            let (sigma, dx, dy) = falloff(s, px, py);
                            let Some((alpha, falloff_value, unclamped)) = cut.alpha(s, sigma)
                            else {
                                continue;
                            };
                            let one_minus = T::one() - alpha;
                            let t_i = t / one_minus;
                            let w = alpha * t_i;
                            let out = &mut grads[(base + j) * stride..(base + j + 1) * stride];
                            let color =
                                &projected[s.splat * stride + PROJ_COLOR..(s.splat + 1) * stride];
                            let mut dl_dalpha = g_alpha * t_final / one_minus
                                + g_depth * (s.depth * t_i - acc_depth / one_minus);
                            for ch in 0..channels {
                                out[PROJ_COLOR + ch] = out[PROJ_COLOR + ch] + g_color[ch] * w;
                                dl_dalpha = dl_dalpha
                                    + g_color[ch] * (color[ch] * t_i - acc[ch] / one_minus);
                                acc[ch] = acc[ch] + color[ch] * w;
                            }
                            out[PROJ_DEPTH] = out[PROJ_DEPTH] + g_depth * w;
                            acc_depth = acc_depth + s.depth * w;
                            t = t_i;
                            if unclamped {
                                out[PROJ_OPACITY] = out[PROJ_OPACITY] + dl_dalpha * falloff_value;
                                let g_sigma = -dl_dalpha * alpha;
                                let half = T::of(0.5);
                                let [a, b, c] = s.conic;
                                out[PROJ_CONIC] = out[PROJ_CONIC] + g_sigma * half * dx * dx;
                                out[PROJ_CONIC + 1] = out[PROJ_CONIC + 1] + g_sigma * dx * dy;
                                out[PROJ_CONIC + 2] =
                                    out[PROJ_CONIC + 2] + g_sigma * half * dy * dy;
                                out[0] = out[0] - g_sigma * (a * dx + b * dy);
                                out[1] = out[1] - g_sigma * (b * dx + c * dy);
                            }
                        }
                    }
                }
            }
            grad_bg
        })
        .collect();

    let mut grad_bg = vec![T::zero(); channels];
    for part in bg_parts {
        for (g, v) in grad_bg.iter_mut().zip(part) {
            *g = *g + v;
        }
    }
    // Reduce intersections to splats in a fixed order: deterministic.
    let mut grad_proj = vec![T::zero(); n_splats * stride];
    for (k, &splat) in bins.splat_from_isect.iter().enumerate() {
        let src = &isect_grads[k * stride..(k + 1) * stride];
        let dst = &mut grad_proj[splat as usize * stride..(splat as usize + 1) * stride];
        for (d, s) in dst.iter_mut().zip(src) {
            *d = *d + *s;
        }
    }
    (grad_proj, grad_bg)
}
