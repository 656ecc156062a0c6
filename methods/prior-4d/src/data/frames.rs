//! Reading one view of a real capture at the training size: its image and person mask
//! resized, its camera scaled to match, refused when distorted (named by file).

use crate::error::Prior4dError;
use image::imageops::FilterType;
use splatzoo_datasets::formats::ViewRecord;
use splatzoo_datasets::masks::Mask;
use splatzoo_rasterizer::Camera;
use std::path::Path;

/// The training size of images like `camera`'s at `width` wide (the height by its aspect).
pub fn training_size(camera: &Camera, width: u32) -> (u32, u32) {
    let height = (f64::from(camera.height) * f64::from(width) / f64::from(camera.width)).round();
    (width, (height as u32).max(1))
}

/// Refuses a distorted camera of `record`, naming `model_file`.
pub fn undistorted(record: &ViewRecord, model_file: &Path) -> Result<(), Prior4dError> {
    let d = record.distortion;
    if [d.k1, d.k2, d.p1, d.p2, d.k3].iter().all(|&k| k == 0.0) {
        return Ok(());
    }
    Err(Prior4dError::input(
        model_file.display().to_string(),
        format!(
            "{}: a distorted camera; undistort the images first (NeuMan's preprocessing and \
             COLMAP's image_undistorter give PINHOLE cameras)",
            record.camera_name
        ),
    ))
}

/// `record`'s image at `size` as sRGB `[H, W, 3]`.
pub fn read_image(record: &ViewRecord, size: (u32, u32)) -> Result<Vec<f32>, Prior4dError> {
    let what = record.image.display().to_string();
    let picture = image::open(&record.image)
        .map_err(|e| Prior4dError::input(what.clone(), format!("cannot read ({e})")))?
        .to_rgb8();
    let (w, h) = picture.dimensions();
    if (w, h) != (record.camera.width, record.camera.height) {
        return Err(Prior4dError::input(
            what,
            format!(
                "a {w}×{h} image for a {}×{} camera",
                record.camera.width, record.camera.height
            ),
        ));
    }
    let resized = image::imageops::resize(&picture, size.0, size.1, FilterType::Triangle);
    Ok(resized
        .as_raw()
        .iter()
        .map(|&v| f32::from(v) / 255.0)
        .collect())
}

/// `record`'s person mask at `size` (thresholded at one half after resizing); it must have a
/// person pixel.
pub fn read_person(record: &ViewRecord, size: (u32, u32)) -> Result<Mask, Prior4dError> {
    let what = record.image.display().to_string();
    let no_mask = || Prior4dError::input(what.clone(), "no person mask beside the image");
    let (mw, mh, person) = record
        .read_mask()
        .ok_or_else(no_mask)?
        .map_err(|e| Prior4dError::Train(e.into()))?;
    let mask_file = || {
        record
            .mask
            .as_ref()
            .map_or_else(|| what.clone(), |p| p.display().to_string())
    };
    let (w, h) = (record.camera.width, record.camera.height);
    if (mw, mh) != (w, h) {
        return Err(Prior4dError::input(
            mask_file(),
            format!("a {mw}×{mh} mask for a {w}×{h} image"),
        ));
    }
    let grey: Vec<u8> = person.iter().map(|&p| if p { 255 } else { 0 }).collect();
    let grey = image::GrayImage::from_raw(w, h, grey).expect("sized above");
    let grey = image::imageops::resize(&grey, size.0, size.1, FilterType::Triangle);
    let mask = Mask::new(
        size.0 as usize,
        size.1 as usize,
        grey.as_raw().iter().map(|&v| v >= 128).collect(),
    );
    if mask.area() == 0 {
        return Err(Prior4dError::input(
            mask_file(),
            "no person pixel (NeuMan's helper asserts one)",
        ));
    }
    Ok(mask)
}

/// `camera` for its image resized to `size`.
pub fn resized_camera(camera: &Camera, size: (u32, u32)) -> Camera {
    let rx = f64::from(size.0) / f64::from(camera.width);
    let ry = f64::from(size.1) / f64::from(camera.height);
    Camera {
        fx: (f64::from(camera.fx) * rx) as f32,
        fy: (f64::from(camera.fy) * ry) as f32,
        cx: (f64::from(camera.cx) * rx) as f32,
        cy: (f64::from(camera.cy) * ry) as f32,
        width: size.0,
        height: size.1,
        ..*camera
    }
}
