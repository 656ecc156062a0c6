//! U8, the face crop from a portrait photo (the paper moves the face "to the centre" by hand):
//! the least-squares 2-D similarity (Umeyama 1991: scale, rotation, translation, no reflection)
//! that maps the photo's face keypoints (OpenPose face points: pupils, nose tip, mouth, chin)
//! onto the fixed face camera's projections of the same landmarks of the avatar's canonical
//! body, then the photo resampled through it (bilinear) into the crop, the background outside
//! the body's silhouette from the face camera set to black (the spec's person mask).

use crate::error::AagError;

/// `p ↦ s R p + t`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Similarity2 {
    pub scale: f64,
    /// Rotation angle, radians (from +x towards +y: clockwise on screen, y pointing down).
    pub angle: f64,
    pub translation: [f64; 2],
}

impl Similarity2 {
    pub fn apply(&self, p: [f64; 2]) -> [f64; 2] {
        let (s, c) = self.angle.sin_cos();
        [
            self.scale * (c * p[0] - s * p[1]) + self.translation[0],
            self.scale * (s * p[0] + c * p[1]) + self.translation[1],
        ]
    }

    /// The inverse map.
    pub fn inverse(&self) -> Self {
        let (s, c) = (-self.angle).sin_cos();
        let t = self.translation;
        let inv = 1.0 / self.scale;
        Self {
            scale: inv,
            angle: -self.angle,
            translation: [-inv * (c * t[0] - s * t[1]), -inv * (s * t[0] + c * t[1])],
        }
    }
}

/// The similarity minimising `Σ ‖s R src_k + t − dst_k‖²` (Umeyama's closed form; rotations
/// only). At least two distinct source points are needed.
pub fn umeyama_2d(src: &[[f64; 2]], dst: &[[f64; 2]]) -> Result<Similarity2, AagError> {
    assert_eq!(src.len(), dst.len(), "paired points");
    let n = src.len() as f64;
    let mean = |pts: &[[f64; 2]]| {
        let mut m = [0.0; 2];
        for p in pts {
            m[0] += p[0] / n;
            m[1] += p[1] / n;
        }
        m
    };
    let (ms, md) = (mean(src), mean(dst));
    // Σ over pairs of the centred dst · src (as complex numbers: Σ conj(s) d) and ‖src‖².
    let (mut re, mut im, mut spread) = (0.0, 0.0, 0.0);
    for (s, d) in src.iter().zip(dst) {
        let (sx, sy) = (s[0] - ms[0], s[1] - ms[1]);
        let (dx, dy) = (d[0] - md[0], d[1] - md[1]);
        re += sx * dx + sy * dy;
        im += sx * dy - sy * dx;
        spread += sx * sx + sy * sy;
    }
    if src.len() < 2 || spread < 1e-12 * n.max(1.0) {
        return Err(AagError::input(
            "face keypoints",
            format!(
                "{} point(s) spread over {spread:.3e} px²: the face crop's alignment needs two \
                 distinct face points (pupils, nose tip, mouth, chin)",
                src.len()
            ),
        ));
    }
    let angle = im.atan2(re);
    let scale = (re * re + im * im).sqrt() / spread;
    if !(scale > 1e-9 && scale.is_finite()) {
        return Err(AagError::input(
            "face keypoints",
            format!("the face points map to one point (scale {scale:.3e}): nothing to align"),
        ));
    }
    let (sin, cos) = angle.sin_cos();
    let rotated = [
        scale * (cos * ms[0] - sin * ms[1]),
        scale * (sin * ms[0] + cos * ms[1]),
    ];
    Ok(Similarity2 {
        scale,
        angle,
        translation: [md[0] - rotated[0], md[1] - rotated[1]],
    })
}

/// `[3, size, size]` in [0, 1]: the planar `[3, height, width]` `image` seen through
/// `crop_from_image` (pixel centres at +0.5), bilinear, black outside the image and where
/// `keep` (`[size²]`) is false.
pub fn warp_crop(
    image: &[f32],
    width: usize,
    height: usize,
    crop_from_image: &Similarity2,
    size: usize,
    keep: &[bool],
) -> Vec<f32> {
    assert_eq!(image.len(), 3 * width * height, "image is [3, H, W]");
    assert_eq!(keep.len(), size * size, "keep is [S²]");
    let image_from_crop = crop_from_image.inverse();
    let plane = width * height;
    let at = |c: usize, x: isize, y: isize| -> f32 {
        if x < 0 || y < 0 || x >= width as isize || y >= height as isize {
            0.0
        } else {
            image[c * plane + y as usize * width + x as usize]
        }
    };
    let mut out = vec![0.0; 3 * size * size];
    for row in 0..size {
        for col in 0..size {
            let p = row * size + col;
            if !keep[p] {
                continue;
            }
            let [u, v] = image_from_crop.apply([col as f64 + 0.5, row as f64 + 0.5]);
            let (x, y) = (u - 0.5, v - 0.5);
            let (x0, y0) = (x.floor(), y.floor());
            let (fx, fy) = ((x - x0) as f32, (y - y0) as f32);
            let (x0, y0) = (x0 as isize, y0 as isize);
            for c in 0..3 {
                out[c * size * size + p] = (1.0 - fy)
                    * ((1.0 - fx) * at(c, x0, y0) + fx * at(c, x0 + 1, y0))
                    + fy * ((1.0 - fx) * at(c, x0, y0 + 1) + fx * at(c, x0 + 1, y0 + 1));
            }
        }
    }
    out
}

/// The body landmarks U8 aligns by, the OpenPose face points 68, 69 (pupils), 30 (nose tip),
/// 62 (mouth) and 8 (chin).
pub const ALIGNMENT_LANDMARKS: [&str; 5] = ["right_eye", "left_eye", "nose_tip", "mouth", "chin"];

/// A face crop made from a portrait photo.
#[derive(Debug, Clone, PartialEq)]
pub struct PortraitCrop {
    /// `[3, S, S]` in [0, 1].
    pub crop: Vec<f32>,
    /// RMS distance of the aligned photo points from the body's, crop pixels.
    pub residual_px: f64,
    /// Point pairs the alignment used.
    pub points: usize,
}

/// U8: the crop of the planar `[3, height, width]` `photo` whose face points `photo_points`
/// (pixels, by [`ALIGNMENT_LANDMARKS`] slot; `None` where the detector missed one) meet the face
/// camera's projections `body_points` of the avatar's landmarks (`None` where the body has no
/// such landmark), `size`² pixels, black outside `keep`.
pub fn crop_from_portrait(
    photo: &[f32],
    width: usize,
    height: usize,
    photo_points: &[Option<[f64; 2]>],
    body_points: &[Option<[f64; 2]>],
    size: usize,
    keep: &[bool],
) -> Result<PortraitCrop, AagError> {
    let (src, dst): (Vec<[f64; 2]>, Vec<[f64; 2]>) = photo_points
        .iter()
        .zip(body_points)
        .filter_map(|(a, b)| a.zip(*b))
        .unzip();
    let crop_from_photo = umeyama_2d(&src, &dst)?;
    let residual_px = (src
        .iter()
        .zip(&dst)
        .map(|(s, d)| {
            let p = crop_from_photo.apply(*s);
            (p[0] - d[0]).powi(2) + (p[1] - d[1]).powi(2)
        })
        .sum::<f64>()
        / src.len() as f64)
        .sqrt();
    Ok(PortraitCrop {
        crop: warp_crop(photo, width, height, &crop_from_photo, size, keep),
        residual_px,
        points: src.len(),
    })
}
