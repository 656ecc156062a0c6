//! The one bridge from a loaded capture ([`splatzoo_datasets::formats::Dataset`]: views,
//! masks, pose tracks, splits, sparse points) to training views, used by `train-3dgs` and
//! `train-avatar` alike.
//!
//! Each [`ViewRecord`] becomes a [`View`] whose pixels are a [`FileImage`] decoded on demand:
//! its camera scaled to the training resolution, its distortion undistorted, its mask read in
//! the format's convention and given a role (nerfstudio's `mask_path` marks pixels to train on;
//! every other format's mask marks the person). Loading decodes every image once, in parallel
//! bounded batches: that names the first unreadable or mis-sized file before training starts,
//! back-projects depth where the capture gives it, and warms the cache up to its budget.

use super::image_store::{FileImage, ImageSource, ImageStore, MaskRole};
use super::init_points::{InitPoints, back_project, random_points};
use super::undistort::is_distorted;
use super::{DataConfig, DataError, View, ViewSet, camera_extent, file_error, split};
use burn::tensor::Device;
use clap::ValueEnum;
use rayon::prelude::*;
use splatzoo_datasets::formats::{self, Dataset, Format, ViewRecord};
use splatzoo_rasterizer::Camera;
use std::path::Path;

/// A capture as loaded, and the factor its images must still be box-filtered by.
pub struct Loaded {
    pub dataset: Dataset,
    pub downscale: u32,
}

/// Loads the capture at `path` (a folder, or a nerfstudio `transforms.json`) in `format`
/// (detected when absent), for training at `1/downscale` of its resolution: a COLMAP scene
/// with an `images_<downscale>/` folder is read from there (as 3DGS's `-r` does); every other
/// capture is read at full size and box-filtered as its images are decoded.
pub fn load_capture(
    path: &Path,
    format: Option<&str>,
    downscale: u32,
) -> Result<Loaded, DataError> {
    let format = format
        .map(|name| {
            Format::from_str(name, true).map_err(|_| {
                let known: Vec<String> = Format::value_variants()
                    .iter()
                    .filter_map(|f| f.to_possible_value().map(|v| v.get_name().to_owned()))
                    .collect();
                DataError::Config(format!(
                    "data.format = {name:?} is not a format ({})",
                    known.join(", ")
                ))
            })
        })
        .transpose()?;
    let root = if path.is_file() {
        path.parent().unwrap_or(Path::new("."))
    } else {
        path
    };
    let format = format.or_else(|| formats::detect(root));
    let prescaled = downscale > 1
        && format == Some(Format::Colmap)
        && root.join(format!("images_{downscale}")).is_dir();
    if prescaled {
        let options = formats::LoadOptions { downscale };
        return Ok(Loaded {
            dataset: formats::load_with(root, format, &options)?,
            downscale: 1,
        });
    }
    Ok(Loaded {
        dataset: formats::load(root, format)?,
        downscale,
    })
}

/// `camera` seen at `1/f` of its resolution (pixel centres at +0.5 scale exactly).
pub fn scaled_camera(camera: &Camera, f: u32) -> Camera {
    if f == 1 {
        return *camera;
    }
    let s = 1.0 / f as f32;
    Camera {
        width: camera.width / f,
        height: camera.height / f,
        fx: camera.fx * s,
        fy: camera.fy * s,
        cx: camera.cx * s,
        cy: camera.cy * s,
        ..*camera
    }
}

/// What a format's `ViewRecord::mask` means.
pub fn mask_role(format: Format) -> MaskRole {
    match format {
        Format::Nerfstudio => MaskRole::Valid,
        _ => MaskRole::Person,
    }
}

/// A record's pixels as a file source, and its camera at training resolution.
pub fn file_image(
    record: &ViewRecord,
    role: MaskRole,
    downscale: u32,
    background: [f32; 3],
) -> (Camera, FileImage) {
    let camera = scaled_camera(&record.camera, downscale);
    let file = FileImage {
        image: record.image.clone(),
        mask: record.mask.clone(),
        mask_role: role,
        record: record.clone(),
        full_camera: record.camera,
        distortion: record.distortion,
        downscale,
        background,
    };
    (camera, file)
}

/// A readable name for a view: its image's file stem (with the camera where images of several
/// cameras share stems).
fn view_name(record: &ViewRecord, index: usize) -> String {
    let stem = record
        .image
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| format!("view_{index:05}"));
    if record.camera_name.contains('/') || record.camera_name == stem {
        stem
    } else {
        format!("{}_{stem}", record.camera_name)
    }
}

/// Decodes every source once, in parallel batches, into the store's cache (as far as its
/// budget goes). The first failure is returned, naming its file.
pub fn first_pass(store: &ImageStore, keys: &[usize], device: &Device) -> Result<(), DataError> {
    let batch = rayon::current_num_threads().max(1) * 2;
    for chunk in keys.chunks(batch) {
        let decoded: Vec<_> = chunk
            .par_iter()
            .map(|&key| match store.source(key) {
                ImageSource::File(file) => file.decode().map(Some),
                ImageSource::Memory(_) => Ok(None),
            })
            .collect();
        for (&key, frame) in chunk.iter().zip(decoded) {
            if let Some(frame) = frame? {
                store.insert(key, frame.upload(device));
            }
        }
    }
    Ok(())
}

/// Train and held-out view indices: the capture's own `train` and `test` (else `val`) split
/// where it names one, otherwise every `test_every`-th view held out.
pub fn train_test_split(dataset: &Dataset, test_every: usize) -> (Vec<usize>, Vec<usize>, String) {
    let named = |k: &str| dataset.splits.get(k).filter(|v| !v.is_empty());
    if let (Some(train), Some((name, test))) = (
        named("train"),
        named("test")
            .map(|t| ("test", t))
            .or_else(|| named("val").map(|t| ("val", t))),
    ) {
        return (
            train.clone(),
            test.clone(),
            format!("the capture's own split (train / {name})"),
        );
    }
    let (train, test) = split((0..dataset.views.len()).collect(), test_every);
    (
        train,
        test,
        format!("every {test_every}th view held out (no split in the capture)"),
    )
}

/// A static scene's views from any capture.
pub fn static_views(
    path: &Path,
    config: &DataConfig,
    device: &Device,
) -> Result<ViewSet, DataError> {
    let Loaded { dataset, downscale } =
        load_capture(path, config.format.as_deref(), config.downscale)?;
    if dataset.views.len() < 2 {
        return Err(file_error(
            &dataset.root,
            "needs at least two views (one to train on, one held out)",
        ));
    }
    let role = mask_role(dataset.format);
    let mut decisions = vec![format!(
        "{:?} capture: {} views, {} moment(s)",
        dataset.format,
        dataset.views.len(),
        dataset.frame_count
    )];
    let has_person_masks =
        role == MaskRole::Person && dataset.views.iter().any(|v| v.mask.is_some());
    let mask_people = config
        .mask_people
        .unwrap_or(has_person_masks && dataset.frame_count > 1);
    decisions.push(match (mask_people, config.mask_people.is_some()) {
        (true, true) => "person pixels left out of the loss (data.mask_people)".into(),
        (false, true) => "person pixels trained (data.mask_people)".into(),
        (true, false) => {
            "person pixels left out of the loss: people move across the capture's moments".into()
        }
        (false, false) if has_person_masks => {
            "person pixels trained: one moment, people stand still".into()
        }
        (false, false) => "no person masks: every pixel trained".into(),
    });
    let distorted = dataset
        .views
        .iter()
        .filter(|v| is_distorted(&v.distortion))
        .count();
    if distorted > 0 {
        decisions.push(format!(
            "{distorted} views undistorted onto their pinhole camera"
        ));
    }
    let (train_ids, test_ids, how) = train_test_split(&dataset, config.test_every);
    decisions.push(format!("split: {how}"));
    let mut store = ImageStore::new(config.cache_mib, device);
    let mut make = |index: usize| -> View {
        let record = &dataset.views[index];
        let (camera, file) = file_image(record, role, downscale, config.background);
        View {
            name: view_name(record, index),
            camera,
            frame: record.frame,
            key: store.push(ImageSource::File(Box::new(file))),
        }
    };
    let train: Vec<View> = train_ids.iter().map(|&i| make(i)).collect();
    let test: Vec<View> = test_ids.iter().map(|&i| make(i)).collect();
    let keys: Vec<usize> = train.iter().chain(&test).map(|v| v.key).collect();
    first_pass(&store, &keys, device)?;
    let cameras: Vec<Camera> = train.iter().chain(&test).map(|v| v.camera).collect();
    let extent = camera_extent(&cameras);
    let points = if !dataset.points.is_empty() {
        decisions.push(format!(
            "initialised from the capture's {} sparse points",
            dataset.points.len()
        ));
        InitPoints::from_sparse(&dataset.points)
    } else {
        let mut points = InitPoints::default();
        depth_points(
            &dataset,
            &train_ids,
            &train,
            &store,
            downscale,
            config.init_stride,
            &mut points,
        )?;
        if points.is_empty() {
            decisions.push(format!(
                "no sparse points or depth: {} random points in the cameras' box",
                config.random_points
            ));
            random_points(&cameras, config.random_points, config.seed)
        } else {
            decisions.push(format!(
                "initialised from depth: {} back-projected points",
                points.len()
            ));
            points
        }
    };
    Ok(ViewSet {
        train,
        test,
        background: config.background,
        points,
        extent,
        mask_people,
        decisions,
        store,
    })
}

/// Back-projects the training views' depth maps (16-bit PNG in millimetres, 0 = none, or a
/// `.npy` of metres) where the capture has them and no lens distortion.
fn depth_points(
    dataset: &Dataset,
    train_ids: &[usize],
    train: &[View],
    store: &ImageStore,
    downscale: u32,
    stride: usize,
    points: &mut InitPoints,
) -> Result<(), DataError> {
    for (&index, view) in train_ids.iter().zip(train) {
        let Some(depth) = training_depth(&dataset.views[index], downscale)? else {
            continue;
        };
        let frame = store.frame(view.key)?;
        let srgb = crate::host_f32(&frame.image);
        back_project(&view.camera, &depth, &srgb, stride, points);
    }
    Ok(())
}

/// A view's depth map at training resolution (`1/downscale`; subsampled, not averaged, since
/// averaging mixes surfaces at edges), in the capture's world units; `None` where the view has
/// none or its lens distorts (the map is then not on the pinhole grid).
pub fn training_depth(record: &ViewRecord, downscale: u32) -> Result<Option<Vec<f32>>, DataError> {
    let Some(path) = &record.depth else {
        return Ok(None);
    };
    if is_distorted(&record.distortion) {
        return Ok(None);
    }
    let (w, h) = (record.camera.width as usize, record.camera.height as usize);
    let depth = read_depth(path, w, h)?;
    let f = downscale as usize;
    let (ow, oh) = (w / f, h / f);
    Ok(Some(
        (0..oh * ow)
            .map(|i| depth[((i / ow) * f + f / 2) * w + (i % ow) * f + f / 2])
            .collect(),
    ))
}

/// A depth map of `w × h` in the capture's unit (a `.npy` as stored; a 16-bit PNG of millimetres
/// as metres), non-finite where there is none.
pub fn read_depth(path: &Path, w: usize, h: usize) -> Result<Vec<f32>, DataError> {
    if path.extension().is_some_and(|e| e == "npy") {
        let array = formats::read_npy(path)?;
        if array.shape[..] != [h, w] {
            return Err(file_error(
                path,
                format!(
                    "depth of shape {:?}, expected ({h}, {w}) (the image's rows, columns)",
                    array.shape
                ),
            ));
        }
        return Ok(array
            .values
            .iter()
            .map(|&v| if v > 0.0 { v as f32 } else { f32::NAN })
            .collect());
    }
    let image = image::open(path).map_err(|e| file_error(path, format!("cannot decode ({e})")))?;
    let image::DynamicImage::ImageLuma16(depth) = image else {
        return Err(file_error(
            path,
            "expected a 16-bit greyscale PNG of depth in millimetres",
        ));
    };
    if depth.dimensions() != (w as u32, h as u32) {
        return Err(file_error(path, format!("depth is not {w}×{h}")));
    }
    Ok(depth
        .pixels()
        .map(|p| {
            if p[0] == 0 {
                f32::NAN
            } else {
                p[0] as f32 * 1e-3
            }
        })
        .collect())
}
