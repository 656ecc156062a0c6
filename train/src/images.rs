//! Image outputs of training and rendering: sRGB colour PNGs, 16-bit depth PNGs (millimetres,
//! 0 = nothing, as nerfstudio reads them), alpha PNGs, side-by-side comparisons and animated
//! GIFs; every file is written atomically.

use burn::tensor::Tensor;
use image::{Delay, Frame, ImageBuffer, Luma, Rgb, RgbImage, RgbaImage};
use splatzoo_datasets::DatasetError;
use splatzoo_datasets::files::write_atomically;
use std::path::Path;

use crate::host_f32 as host;

fn to_u8(v: f32) -> u8 {
    (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8
}

/// `[H, W, 3]` sRGB in [0, 1] (clamped) as an 8-bit image.
pub fn srgb_image(color: &Tensor<3>) -> RgbImage {
    let [h, w, c] = color.dims();
    assert_eq!(c, 3, "colour images are [H, W, 3]");
    let bytes = host(color).into_iter().map(to_u8).collect();
    RgbImage::from_raw(w as u32, h as u32, bytes).expect("sized by the tensor")
}

/// Images side by side (equal heights), e.g. render | ground truth.
pub fn side_by_side(images: &[RgbImage]) -> RgbImage {
    let h = images.iter().map(|i| i.height()).max().unwrap_or(0);
    let w = images.iter().map(|i| i.width()).sum();
    let mut out = RgbImage::new(w, h);
    let mut x0 = 0;
    for image in images {
        image::imageops::replace(&mut out, image, x0 as i64, 0);
        x0 += image.width();
    }
    out
}

pub fn write_png(path: &Path, image: &RgbImage) -> Result<(), DatasetError> {
    save_png(path, image)
}

fn save_png<P>(path: &Path, image: &ImageBuffer<P, Vec<P::Subpixel>>) -> Result<(), DatasetError>
where
    P: image::PixelWithColorType,
    [P::Subpixel]: image::EncodableLayout,
{
    write_atomically(path, |tmp| {
        image
            .save_with_format(tmp, image::ImageFormat::Png)
            .map_err(std::io::Error::other)
    })
}

/// `[H, W]` depth in metres (camera z) as a 16-bit PNG in millimetres, where `alpha` ≥ 0.5;
/// 0 elsewhere and beyond 65.535 m.
pub fn write_depth_png(
    path: &Path,
    depth: &Tensor<2>,
    alpha: &Tensor<2>,
) -> Result<(), DatasetError> {
    let [h, w] = depth.dims();
    let values: Vec<u16> = host(depth)
        .into_iter()
        .zip(host(alpha))
        .map(|(d, a)| {
            let mm = (d * 1000.0).round();
            if a >= 0.5 && mm.is_finite() && mm > 0.0 && mm < 65536.0 {
                mm as u16
            } else {
                0
            }
        })
        .collect();
    let image: ImageBuffer<Luma<u16>, Vec<u16>> =
        ImageBuffer::from_raw(w as u32, h as u32, values).expect("sized by the tensor");
    save_png(path, &image)
}

/// `[H, W]` opacity in [0, 1] as an 8-bit greyscale PNG.
pub fn write_alpha_png(path: &Path, alpha: &Tensor<2>) -> Result<(), DatasetError> {
    let [h, w] = alpha.dims();
    let bytes = host(alpha).into_iter().map(to_u8).collect();
    let image: ImageBuffer<Luma<u8>, Vec<u8>> =
        ImageBuffer::from_raw(w as u32, h as u32, bytes).expect("sized by the tensor");
    save_png(path, &image)
}

/// An endlessly looping GIF of `frames` at `fps`.
pub fn write_gif(path: &Path, frames: &[RgbImage], fps: u32) -> Result<(), DatasetError> {
    write_atomically(path, |tmp| {
        let file = std::io::BufWriter::new(std::fs::File::create(tmp)?);
        let mut encoder = image::codecs::gif::GifEncoder::new_with_speed(file, 10);
        encoder
            .set_repeat(image::codecs::gif::Repeat::Infinite)
            .map_err(std::io::Error::other)?;
        for frame in frames {
            let rgba: RgbaImage = ImageBuffer::from_fn(frame.width(), frame.height(), |x, y| {
                let Rgb([r, g, b]) = *frame.get_pixel(x, y);
                image::Rgba([r, g, b, 255])
            });
            let delay = Delay::from_numer_denom_ms(1000, fps.max(1));
            encoder
                .encode_frame(Frame::from_parts(rgba, 0, 0, delay))
                .map_err(std::io::Error::other)?;
        }
        Ok(())
    })
}
