//! Undistortion of captured images onto the rasterizer's pinhole camera.
//!
//! The splat rasterizer projects through an ideal pinhole, so images taken through a lens with
//! OpenCV distortion (`k1 k2 p1 p2 k3`, as COLMAP's `SIMPLE_RADIAL`, `RADIAL` and `OPENCV`
//! models and drivestudio's intrinsics give them) are resampled before training, as gsplat's
//! COLMAP parser and 3DGS's `convert.py` (COLMAP's image undistorter) do. The output keeps the
//! camera's own `fx fy cx cy` and size; each output pixel looks up where the lens put that ray
//! in the captured image (the forward OpenCV model, no iteration needed) and samples it
//! bilinearly. Pixels whose ray left the captured image are marked invalid, so the loss ignores
//! them rather than learning a black border.

use splatzoo_datasets::formats::Distortion;
use splatzoo_rasterizer::Camera;

/// Whether `d` changes any pixel.
pub fn is_distorted(d: &Distortion) -> bool {
    [d.k1, d.k2, d.p1, d.p2, d.k3].iter().any(|&v| v != 0.0)
}

/// The OpenCV model: where the lens sends normalised pinhole coordinates `(x, y)`.
pub fn distort_normalised(d: &Distortion, x: f64, y: f64) -> (f64, f64) {
    let r2 = x * x + y * y;
    let radial = 1.0 + r2 * (d.k1 + r2 * (d.k2 + r2 * d.k3));
    (
        x * radial + 2.0 * d.p1 * x * y + d.p2 * (r2 + 2.0 * x * x),
        y * radial + d.p1 * (r2 + 2.0 * y * y) + 2.0 * d.p2 * x * y,
    )
}

/// For every output pixel (row-major), the captured image's continuous pixel coordinate
/// (pixel centres at +0.5) its ray came from.
pub fn source_coordinates(camera: &Camera, d: &Distortion) -> Vec<(f64, f64)> {
    let (w, h) = (camera.width as usize, camera.height as usize);
    let (fx, fy) = (camera.fx as f64, camera.fy as f64);
    let (cx, cy) = (camera.cx as f64, camera.cy as f64);
    let mut out = Vec::with_capacity(w * h);
    for py in 0..h {
        for px in 0..w {
            let x = (px as f64 + 0.5 - cx) / fx;
            let y = (py as f64 + 0.5 - cy) / fy;
            let (xd, yd) = distort_normalised(d, x, y);
            out.push((fx * xd + cx, fy * yd + cy));
        }
    }
    out
}

/// Resamples `values` (`[h, w, channels]`, row-major) at `coordinates` bilinearly; a sample
/// whose footprint leaves the image is zero and marked invalid (`false`).
pub fn remap_bilinear(
    values: &[f32],
    w: usize,
    h: usize,
    channels: usize,
    coordinates: &[(f64, f64)],
) -> (Vec<f32>, Vec<bool>) {
    let mut out = vec![0.0f32; coordinates.len() * channels];
    let mut valid = vec![false; coordinates.len()];
    for (k, &(u, v)) in coordinates.iter().enumerate() {
        // Index space: pixel centres at integers.
        let (x, y) = (u - 0.5, v - 0.5);
        if !(x >= 0.0 && y >= 0.0 && x <= (w - 1) as f64 && y <= (h - 1) as f64) {
            continue;
        }
        let (x0, y0) = (x.floor() as usize, y.floor() as usize);
        let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
        let (fx, fy) = ((x - x0 as f64) as f32, (y - y0 as f64) as f32);
        for c in 0..channels {
            let at = |xx: usize, yy: usize| values[(yy * w + xx) * channels + c];
            let top = at(x0, y0) * (1.0 - fx) + at(x1, y0) * fx;
            let bottom = at(x0, y1) * (1.0 - fx) + at(x1, y1) * fx;
            out[k * channels + c] = top * (1.0 - fy) + bottom * fy;
        }
        valid[k] = true;
    }
    (out, valid)
}

/// Resamples a per-pixel flag at `coordinates` by its nearest pixel (masks are not blended);
/// outside the image it is `false`.
pub fn remap_nearest(values: &[bool], w: usize, h: usize, coordinates: &[(f64, f64)]) -> Vec<bool> {
    coordinates
        .iter()
        .map(|&(u, v)| {
            let (x, y) = (u.floor(), v.floor());
            if x >= 0.0 && y >= 0.0 && (x as usize) < w && (y as usize) < h {
                values[y as usize * w + x as usize]
            } else {
                false
            }
        })
        .collect()
}
