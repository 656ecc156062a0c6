//! What a driving log offers beside the images, derived from a rendered view's ground truth: a
//! LiDAR stand-in (sparse, noisy depth on a few beam rows) and the coarse (human ∪ accessory)
//! mask in the variants annotations come in: exact, dilated, or each person's box filled
//! (drivestudio's `dynamic_masks`).

use super::rng::Rng;
use super::scene::ViewTruth;
use crate::masks::Mask;

/// Beam rows of the LiDAR stand-in.
pub const LIDAR_ROWS: usize = 32;
/// Standard deviation of the LiDAR stand-in's depth noise, metres.
pub const LIDAR_NOISE: f64 = 0.02;

impl ViewTruth {
    /// The pixel rows a LiDAR stand-in with `rows` beams samples: evenly spaced (row
    /// `⌊(i + ½) H / n⌋` for `i < n = min(rows, H)`), increasing, each at most once.
    pub fn beam_rows(&self, rows: usize) -> Vec<usize> {
        let h = self.render.height;
        let n = rows.min(h);
        (0..n).map(|i| (2 * i + 1) * h / (2 * n)).collect()
    }

    /// Sparse depth, `[H·W]` row-major: on the [`ViewTruth::beam_rows`] every pixel where
    /// something was hit gets its camera z (as `render.depth`) plus N(0, `noise`²) metres, drawn
    /// from `seed`; every other pixel is NaN. The defaults are [`LIDAR_ROWS`] and
    /// [`LIDAR_NOISE`].
    pub fn lidar_depth(&self, rows: usize, noise: f64, seed: u64) -> Vec<f32> {
        let (w, depth) = (self.render.width, &self.render.depth);
        let mut out = vec![f32::NAN; depth.len()];
        let mut rng = Rng(seed ^ 0x11DA_4000);
        for y in self.beam_rows(rows) {
            let row = y * w..(y + 1) * w;
            for (o, &d) in out[row.clone()].iter_mut().zip(&depth[row]) {
                if d.is_finite() {
                    *o = (f64::from(d) + noise * rng.normal()) as f32;
                }
            }
        }
        out
    }

    /// [`ViewTruth::coarse_mask`] dilated by the digital disk of `radius` pixels
    /// ([`Mask::dilate`]).
    pub fn coarse_mask_dilated(&self, radius: usize) -> Vec<bool> {
        let (w, h) = (self.render.width, self.render.height);
        Mask::new(w, h, self.coarse_mask()).dilate(radius).data
    }

    /// Per person of the scene (untracked ones included), the box `[x0, y0, x1, y1]` (`x1`, `y1`
    /// exclusive) around the pixels showing their body or accessories; `None` where none do.
    pub fn person_boxes(&self) -> Vec<Option<[usize; 4]>> {
        let w = self.render.width;
        let mut boxes: Vec<Option<[usize; 4]>> = vec![None; self.people];
        for (i, who) in self.person().into_iter().enumerate() {
            let Some(k) = who else { continue };
            let (x, y) = (i % w, i / w);
            boxes[k] = Some(match boxes[k] {
                None => [x, y, x + 1, y + 1],
                Some([x0, y0, x1, y1]) => [x0.min(x), y0.min(y), x1.max(x + 1), y1.max(y + 1)],
            });
        }
        boxes
    }

    /// The coarse mask as box annotations give it: every [`ViewTruth::person_boxes`] box filled.
    pub fn coarse_mask_boxes(&self) -> Vec<bool> {
        let w = self.render.width;
        let mut mask = vec![false; self.render.label.len()];
        for [x0, y0, x1, y1] in self.person_boxes().into_iter().flatten() {
            for y in y0..y1 {
                mask[y * w + x0..y * w + x1].fill(true);
            }
        }
        mask
    }
}
