//! A real capture's two scans (§3 of Prior-4D), each a folder a user gives beside the acting
//! video ([`super::neuman`]):
//!
//! - **scene scan** (`data.scene_scan`): the empty room filmed on its own, any format the
//!   engine reads with cameras (`splatzoo_datasets::formats`: a COLMAP scene as 3DGS's
//!   `convert.py` leaves it, a nerfstudio folder), **in the acting video's COLMAP world** (one
//!   reconstruction of both videos, or the acting frames registered into the scan's model with
//!   `colmap image_registrator`). Its images at `data.width` wide, its points start the scene
//!   prior (at most `data.scene_points`), and `ground/` and `mono_depth/` beside its images give
//!   ground masks and monocular depth ([`super::given`]). Without ground masks the floor is found
//!   from the acting frames' ground pixels.
//! - **human scan** (`data.human_scan`): the person turning in place, any format with one
//!   person track, person masks and cameras (a NeuMan-layout folder of that video, ZJU-MoCap,
//!   PeopleSnapshot): each view with a body fit becomes a scan view, in the world the engine
//!   folds the fit's placement into (`splatzoo_train::views::people`: metres, the body its own
//!   size), with the fit as the scan's body prior.

use super::frames::{read_image, read_person, resized_camera, training_size, undistorted};
use super::given::{GROUND, MONO_DEPTH, given_file, read_ground, read_mono_depth, sparse_depth};
use super::sensors::{mask_tensor, scaled_camera};
use super::{HumanScanView, Prior4dDataConfig, SceneScanView};
use crate::error::Prior4dError;
use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_datasets::formats::{self, Dataset};
use splatzoo_datasets::masks::Mask;
use splatzoo_datasets::pose_sequence::PoseSequence;
use splatzoo_models::body::builtin_body;
use splatzoo_train::views::people::person_sequence;
use splatzoo_train::views::{ColourSum, InitPoints};
use std::path::Path;

fn load(root: &Path, what: &str) -> Result<Dataset, Prior4dError> {
    let dataset = formats::load(root, None).map_err(|e| Prior4dError::Train(e.into()))?;
    if dataset.views.is_empty() {
        return Err(Prior4dError::input(
            root.display().to_string(),
            format!("{what}: no views"),
        ));
    }
    for record in &dataset.views {
        undistorted(record, root)?;
    }
    Ok(dataset)
}

/// The scene scan at `root`: its views, its points and the mean colour of its images.
pub fn read_scene_scan(
    root: &Path,
    config: &Prior4dDataConfig,
    device: &Device,
) -> Result<(Vec<SceneScanView>, InitPoints, [f32; 3]), Prior4dError> {
    let dataset = load(root, "scene scan")?;
    if dataset.points.is_empty() {
        return Err(Prior4dError::input(
            root.display().to_string(),
            "scene scan: no sparse points to start the scene prior from",
        ));
    }
    let all_points = InitPoints::from_sparse(&dataset.points);
    let mut colour = ColourSum::default();
    let mut views = Vec::with_capacity(dataset.views.len());
    for record in &dataset.views {
        let size = training_size(&record.camera, config.width);
        let (w, h) = (size.0 as usize, size.1 as usize);
        let full = (record.camera.width as usize, record.camera.height as usize);
        let camera = resized_camera(&record.camera, size);
        let pixels = read_image(record, size)?;
        colour.add(&pixels, None);
        let ground = match given_file(root, GROUND, record, ".png") {
            Some(path) => read_ground(&path, full, (w, h))?,
            None => Mask::empty(w, h),
        };
        let (mono, depth) = match given_file(root, MONO_DEPTH, record, ".npy") {
            Some(path) => (
                read_mono_depth(&path, full, (w, h))?,
                sparse_depth(&camera, &all_points.positions),
            ),
            None => (vec![0.0; w * h], vec![f32::INFINITY; w * h]),
        };
        views.push(SceneScanView {
            camera,
            image: Tensor::from_data(TensorData::new(pixels, [h, w, 3]), device),
            mono_inverse_depth: Tensor::from_data(TensorData::new(mono, [h, w]), device),
            depth,
            ground,
            person: None,
        });
    }
    let points = all_points.thinned(config.scene_points, config.seed ^ 0x9414_0001);
    Ok((views, points, colour.mean()))
}

/// The human scan at `root`: each view with a body fit, the fit (one frame per view, metres)
/// and the mean colour off the person.
pub fn read_human_scan(
    root: &Path,
    config: &Prior4dDataConfig,
    device: &Device,
) -> Result<(Vec<HumanScanView>, PoseSequence, [f32; 3]), Prior4dError> {
    let dataset = load(root, "human scan")?;
    let model = &builtin_body().model;
    let person = person_sequence(&dataset, 0, model, config.capture_betas)
        .map_err(|e| Prior4dError::Train(e.into()))?;
    let records: Vec<_> = dataset
        .views
        .iter()
        .filter(|v| person.valid.get(v.frame).copied().unwrap_or(false))
        .collect();
    if records.len() < 2 {
        return Err(Prior4dError::input(
            root.display().to_string(),
            format!(
                "human scan: {} views with a body fit, expected at least 2",
                records.len()
            ),
        ));
    }
    let frames: Vec<usize> = records.iter().map(|r| r.frame).collect();
    let mut colour = ColourSum::default();
    let mut views = Vec::with_capacity(records.len());
    for record in records {
        let size = training_size(&record.camera, config.width);
        let (w, h) = (size.0 as usize, size.1 as usize);
        let pixels = read_image(record, size)?;
        let mask = read_person(record, size)?;
        colour.add(&pixels, Some(&mask));
        views.push(HumanScanView {
            camera: scaled_camera(&resized_camera(&record.camera, size), person.world_scale),
            image: Tensor::from_data(TensorData::new(pixels, [h, w, 3]), device),
            mask: mask_tensor(&mask, device),
        });
    }
    Ok((views, person.sequence.frames_subset(&frames), colour.mean()))
}
