//! Linear-RGB images to 8-bit sRGB PNGs (and 16-bit PNGs for depth).

use crate::DatasetError;
use crate::files::write_atomically;
use std::path::Path;

/// The sRGB transfer function (IEC 61966-2-1).
pub fn linear_to_srgb(x: f32) -> f32 {
    let x = x.clamp(0.0, 1.0);
    if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// Inverse of [`linear_to_srgb`].
pub fn srgb_to_linear(x: f32) -> f32 {
    let x = x.clamp(0.0, 1.0);
    if x <= 0.040_45 {
        x / 12.92
    } else {
        ((x + 0.055) / 1.055).powf(2.4)
    }
}

/// A colour from hue (turns, [0, 1)), saturation and value, each channel in [0, 1].
pub fn hsv(hue: f64, saturation: f64, value: f64) -> [f32; 3] {
    let h = hue.rem_euclid(1.0) * 6.0;
    let x = 1.0 - (h % 2.0 - 1.0).abs();
    let (r, g, b) = match h as u32 {
        0 => (1.0, x, 0.0),
        1 => (x, 1.0, 0.0),
        2 => (0.0, 1.0, x),
        3 => (0.0, x, 1.0),
        4 => (x, 0.0, 1.0),
        _ => (1.0, 0.0, x),
    };
    [r, g, b].map(|c| (value * (1.0 - saturation + saturation * c)) as f32)
}

/// Writes `[H, W]` linear RGB as an sRGB PNG.
pub fn write_rgb_png(
    path: &Path,
    width: usize,
    height: usize,
    pixels: &[[f32; 3]],
) -> Result<(), DatasetError> {
    assert_eq!(pixels.len(), width * height, "pixels must be [H, W]");
    let bytes: Vec<u8> = pixels
        .iter()
        .flat_map(|p| p.map(|c| (linear_to_srgb(c) * 255.0 + 0.5) as u8))
        .collect();
    let image = image::RgbImage::from_raw(width as u32, height as u32, bytes).expect("sized above");
    write_atomically(path, |tmp| {
        image
            .save_with_format(tmp, image::ImageFormat::Png)
            .map_err(std::io::Error::other)
    })
}

/// Writes a `[H, W]` mask (0 or 255) as a greyscale PNG.
pub fn write_mask_png(
    path: &Path,
    width: usize,
    height: usize,
    mask: &[bool],
) -> Result<(), DatasetError> {
    assert_eq!(mask.len(), width * height, "mask must be [H, W]");
    let bytes = mask.iter().map(|&m| if m { 255 } else { 0 }).collect();
    let image =
        image::GrayImage::from_raw(width as u32, height as u32, bytes).expect("sized above");
    write_atomically(path, |tmp| {
        image
            .save_with_format(tmp, image::ImageFormat::Png)
            .map_err(std::io::Error::other)
    })
}
