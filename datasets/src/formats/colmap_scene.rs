//! A COLMAP scene folder as 3DGS, gsplat and Brush read it (the layout of 3DGS's `convert.py`,
//! Mip-NeRF 360 and Tanks and Temples downloads): a sparse model in `<root>/sparse/0/` (or
//! directly in `<root>/sparse/`), binary or text ([`super::colmap::read_model`]), and the
//! undistorted images in `<root>/images/`, named as in `images.bin` (subfolders allowed).
//!
//! - Views: one per image, sorted by name (3DGS sorts its cameras by name); `frame` is the index
//!   in that order, `camera_name` the image name, the distortion the camera model's. The world is
//!   COLMAP's, in its own unit. No people, no splits: the trainers hold out every 8th view
//!   themselves (the LLFF convention 3DGS and gsplat use).
//! - Points: `points3D`, with their colours, as the trainers' initialisation.
//! - Masks: none in COLMAP; where `<root>/masks/<name>.png` exists (the image name with a `.png`
//!   extension, so `sub/a.jpg` → `masks/sub/a.png`) it is the view's mask, non-zero = person
//!   ([`MaskConvention::NonZeroIsPerson`]).
//! - Downscale `N` (3DGS's `-r N`, gsplat's `data_factor`): cameras at `1/N` of the resolution,
//!   `fx fy cx cy` divided by `N` (pixel centres at +0.5 scale exactly) and the size
//!   [`downscaled_size`], `round(w / N)` as 3DGS rounds and as the `images_N/` folders of
//!   Mip-NeRF 360 are sized (gsplat floors, then rescales to the file it finds). When
//!   `<root>/images_N/` exists its images are read (masks then from `masks_N/`, where present),
//!   and [`Dataset::image_downscale`] is 1. Otherwise the full-resolution `images/` are listed
//!   and `image_downscale` is `N`: a consumer must shrink each image (and mask) to its camera's
//!   size. [`super::check::check`] compares files with cameras either way, naming any image
//!   whose size is not the camera's.

use super::colmap::read_model;
use super::{Dataset, Format, MaskConvention, ViewRecord};
use crate::DatasetError;
use splatzoo_rasterizer::Camera;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The folder holding the scene's model: `sparse/0/` when it has `cameras.{bin,txt}`, else
/// `sparse/` when that has them.
pub fn sparse_dir(root: &Path) -> Option<PathBuf> {
    [root.join("sparse/0"), root.join("sparse")]
        .into_iter()
        .find(|dir| dir.join("cameras.bin").is_file() || dir.join("cameras.txt").is_file())
}

/// Whether `root` looks like a COLMAP scene: a model in `sparse/0/` or `sparse/`, an `images/`
/// folder, and no NeuMan `alignments.npy` (NeuMan scenes hold a COLMAP text model too).
pub fn is_colmap_scene(root: &Path) -> bool {
    sparse_dir(root).is_some()
        && root.join("images").is_dir()
        && !root.join("alignments.npy").is_file()
}

/// An image size at `1/factor`: `round(size / factor)` (halves up), at least 1.
pub fn downscaled_size(width: u32, height: u32, factor: u32) -> (u32, u32) {
    let f = u64::from(factor.max(1));
    let scale = |s: u32| ((2 * u64::from(s) + f) / (2 * f)).max(1) as u32;
    (scale(width), scale(height))
}

/// `camera` at `1/factor` of its resolution: `fx fy cx cy` divided by `factor`, the size by
/// [`downscaled_size`].
pub fn downscaled_camera(camera: &Camera, factor: u32) -> Camera {
    if factor <= 1 {
        return *camera;
    }
    let s = 1.0 / factor as f32;
    let (width, height) = downscaled_size(camera.width, camera.height, factor);
    Camera {
        fx: camera.fx * s,
        fy: camera.fy * s,
        cx: camera.cx * s,
        cy: camera.cy * s,
        width,
        height,
        ..*camera
    }
}

/// The view's mask in `dir`, where there is one: the image name with a `.png` extension.
fn mask_in(dir: &Path, name: &str) -> Option<PathBuf> {
    let path = dir.join(Path::new(name).with_extension("png"));
    path.is_file().then_some(path)
}

/// Loads the scene at `root`, its cameras at `1/downscale` of the model's resolution.
pub fn load(root: &Path, downscale: u32) -> Result<Dataset, DatasetError> {
    if downscale == 0 {
        return Err(DatasetError::file(
            root,
            "downscale 0: expected a factor of at least 1",
        ));
    }
    let sparse = sparse_dir(root).ok_or_else(|| {
        DatasetError::file(
            root,
            "no COLMAP model: expected sparse/0/cameras.{bin,txt} or sparse/cameras.{bin,txt}",
        )
    })?;
    let model = read_model(&sparse)?;
    let images_file = model.file("images");
    let cameras_file = model.file("cameras");
    let mut images = model.images;
    images.sort_by(|a, b| a.name.cmp(&b.name));

    let mut warnings = Vec::new();
    let scaled_images = root.join(format!("images_{downscale}"));
    let (image_dir, mask_dir, image_downscale) = if downscale > 1 && scaled_images.is_dir() {
        let scaled_masks = root.join(format!("masks_{downscale}"));
        if !scaled_masks.is_dir() && root.join("masks").is_dir() {
            warnings.push((
                root.join("masks").display().to_string(),
                format!(
                    "full-resolution masks not used with images_{downscale}/ (no \
                     masks_{downscale}/ beside it)"
                ),
            ));
        }
        (scaled_images, scaled_masks, 1)
    } else {
        (root.join("images"), root.join("masks"), downscale)
    };

    let mut views = Vec::with_capacity(images.len());
    for (frame, image) in images.iter().enumerate() {
        let intrinsics = model.cameras.get(&image.camera_id).ok_or_else(|| {
            DatasetError::field(
                &images_file,
                &image.name,
                format!(
                    "CAMERA_ID {} is not in {}",
                    image.camera_id,
                    cameras_file.display()
                ),
            )
        })?;
        views.push(ViewRecord {
            frame,
            camera_name: image.name.clone(),
            camera: downscaled_camera(&image.camera(intrinsics), downscale),
            distortion: intrinsics.distortion,
            image: image_dir.join(&image.name),
            mask: mask_in(&mask_dir, &image.name),
            mask_convention: MaskConvention::NonZeroIsPerson,
            other_masks: Default::default(),
            depth: None,
        });
    }
    Ok(Dataset {
        format: Format::Colmap,
        root: root.to_path_buf(),
        frame_count: views.len(),
        frame_times: Vec::new(),
        views,
        people: Vec::new(),
        splits: BTreeMap::new(),
        points: model.points,
        boxes: Vec::new(),
        warnings,
        image_downscale,
    })
}
