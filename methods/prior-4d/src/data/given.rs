//! The external priors a user gives beside a NeuMan capture's images ([`super::neuman`]), each
//! an optional folder holding one file per image, named by the image's stem (`00012.png` →
//! `00012`), at the image's full resolution:
//!
//! | folder | file | contents |
//! |---|---|---|
//! | `keypoints/` | `<stem>_keypoints.json` | OpenPose BODY_25 (`--write_json`), pixels; the most confident person |
//! | `normals/` | `<stem>.npy` | `(H, W, 3)` float camera-frame normals, OpenCV axes (x right, y down, z forward), zero where unknown |
//! | `mono_depth/` | `<stem>.npy` | `(H, W)` float monocular **inverse** depth up to an unknown affine map (DPT, Depth Anything), 0 where unknown |
//! | `ground/` | `<stem>.png` | ground pixels non-zero (replaces the feet rule) |
//!
//! A folder that is there must hold a file for every acting frame; a missing or mis-shaped
//! file is named with the shape expected. Maps are resampled to the training size by the
//! nearest pixel (normals renormalised, zero off the person mask); keypoints are scaled.
//! [`write_given`] writes the synthetic capture's own noisy priors in this layout.

use super::{ActingFrame, Prior4dCapture};
use crate::error::Prior4dError;
use splatzoo_datasets::files::write_bytes;
use splatzoo_datasets::formats::{ViewRecord, read_npy};
use splatzoo_datasets::masks::Mask;
use splatzoo_datasets::openpose::{PersonKeypoints, read_main_person, write_keypoints};
use splatzoo_datasets::synth::export::write_npy_f32;
use splatzoo_rasterizer::Camera;
use splatzoo_train::host_f32;
use std::path::{Path, PathBuf};

/// BODY_25's points.
const BODY_25: usize = 25;

/// The four folders.
pub const KEYPOINTS: &str = "keypoints";
pub const NORMALS: &str = "normals";
pub const MONO_DEPTH: &str = "mono_depth";
pub const GROUND: &str = "ground";

fn stem(record: &ViewRecord) -> String {
    record
        .image
        .file_stem()
        .map_or_else(String::new, |s| s.to_string_lossy().into_owned())
}

/// `root/<folder>/<stem><suffix>` where the folder exists.
pub fn given_file(root: &Path, folder: &str, record: &ViewRecord, suffix: &str) -> Option<PathBuf> {
    let dir = root.join(folder);
    dir.is_dir()
        .then(|| dir.join(format!("{}{suffix}", stem(record))))
}

fn problem(path: &Path, what: impl Into<String>) -> Prior4dError {
    Prior4dError::input(path.display().to_string(), what)
}

/// The full-resolution pixel a training pixel `(x, y)` of `size` takes (nearest).
fn source_pixel(x: usize, y: usize, size: (usize, usize), full: (usize, usize)) -> usize {
    let sx = (((x as f64 + 0.5) * full.0 as f64 / size.0 as f64) as usize).min(full.0 - 1);
    let sy = (((y as f64 + 0.5) * full.1 as f64 / size.1 as f64) as usize).min(full.1 - 1);
    sy * full.0 + sx
}

/// A `.npy` map of `channels` per pixel at `full` = (W, H), resampled to `size`.
fn read_map(
    path: &Path,
    channels: usize,
    full: (usize, usize),
    size: (usize, usize),
) -> Result<Vec<f32>, Prior4dError> {
    if !path.is_file() {
        return Err(problem(path, "missing: one file per acting frame"));
    }
    let array = read_npy(path).map_err(|e| Prior4dError::Train(e.into()))?;
    let expected: Vec<usize> = if channels == 1 {
        vec![full.1, full.0]
    } else {
        vec![full.1, full.0, channels]
    };
    if array.shape != expected {
        return Err(problem(
            path,
            format!(
                "shape {:?}, expected {expected:?} (the image's H, W)",
                array.shape
            ),
        ));
    }
    if let Some(k) = array.values.iter().position(|v| !v.is_finite()) {
        return Err(problem(path, format!("value {k} is {}", array.values[k])));
    }
    let mut out = Vec::with_capacity(size.0 * size.1 * channels);
    for y in 0..size.1 {
        for x in 0..size.0 {
            let p = source_pixel(x, y, size, full);
            out.extend((0..channels).map(|c| array.values[p * channels + c] as f32));
        }
    }
    Ok(out)
}

/// Frame `record`'s normal map at `size`, unit length on the person, zero elsewhere.
pub fn read_normals(
    path: &Path,
    full: (usize, usize),
    size: (usize, usize),
    person: &Mask,
) -> Result<Vec<f32>, Prior4dError> {
    let mut normals = read_map(path, 3, full, size)?;
    for (k, n) in normals.chunks_mut(3).enumerate() {
        let length = n.iter().map(|v| v * v).sum::<f32>().sqrt();
        if person.data[k] && length > 1e-6 {
            n.iter_mut().for_each(|v| *v /= length);
        } else {
            n.fill(0.0);
        }
    }
    Ok(normals)
}

/// Frame `record`'s monocular inverse depth at `size` (0 where unknown; negative refused).
pub fn read_mono_depth(
    path: &Path,
    full: (usize, usize),
    size: (usize, usize),
) -> Result<Vec<f32>, Prior4dError> {
    let depth = read_map(path, 1, full, size)?;
    if let Some(k) = depth.iter().position(|&v| v < 0.0) {
        return Err(problem(
            path,
            format!("resampled value {k} is {} (inverse depth ≥ 0)", depth[k]),
        ));
    }
    Ok(depth)
}

/// Frame `record`'s ground mask at `size`.
pub fn read_ground(
    path: &Path,
    full: (usize, usize),
    size: (usize, usize),
) -> Result<Mask, Prior4dError> {
    let grey = image::open(path)
        .map_err(|e| problem(path, format!("cannot read ({e})")))?
        .to_luma8();
    if grey.dimensions() != (full.0 as u32, full.1 as u32) {
        return Err(problem(
            path,
            format!(
                "a {:?} mask for a {}×{} image",
                grey.dimensions(),
                full.0,
                full.1
            ),
        ));
    }
    let raw = grey.as_raw();
    let data = (0..size.1)
        .flat_map(|y| (0..size.0).map(move |x| (x, y)))
        .map(|(x, y)| raw[source_pixel(x, y, size, full)] != 0)
        .collect();
    Ok(Mask::new(size.0, size.1, data))
}

/// Frame `record`'s BODY_25 keypoints scaled by `scale` = (x, y); all `[0, 0, 0]` where the file
/// has no person.
pub fn read_body25(path: &Path, scale: (f64, f64)) -> Result<Vec<[f32; 3]>, Prior4dError> {
    if !path.is_file() {
        return Err(problem(path, "missing: one file per acting frame"));
    }
    let person = read_main_person(path).map_err(|e| Prior4dError::Train(e.into()))?;
    let Some(person) = person else {
        return Ok(vec![[0.0; 3]; BODY_25]);
    };
    if person.body.len() != BODY_25 {
        return Err(problem(
            path,
            format!(
                "pose_keypoints_2d: {} points, expected BODY_25's {BODY_25}",
                person.body.len()
            ),
        ));
    }
    Ok(person
        .body
        .iter()
        .map(|k| {
            [
                (f64::from(k[0]) * scale.0) as f32,
                (f64::from(k[1]) * scale.1) as f32,
                k[2],
            ]
        })
        .collect())
}

/// Camera-space depth of `points` (scene units) nearest to `camera` at each pixel, ∞ where none
/// lands: the sparse points the monocular depth's affine map is fitted to.
pub fn sparse_depth(camera: &Camera, points: &[[f32; 3]]) -> Vec<f32> {
    let (w, h) = (camera.width as usize, camera.height as usize);
    let mut depth = vec![f32::INFINITY; w * h];
    let m = camera.world_to_camera;
    for p in points {
        let c = [0, 1, 2].map(|i| m[i][0] * p[0] + m[i][1] * p[1] + m[i][2] * p[2] + m[i][3]);
        if c[2] <= 1e-6 {
            continue;
        }
        let u = camera.fx * c[0] / c[2] + camera.cx;
        let v = camera.fy * c[1] / c[2] + camera.cy;
        if u < 0.0 || v < 0.0 || u >= w as f32 || v >= h as f32 {
            continue;
        }
        let k = v as usize * w + u as usize;
        depth[k] = depth[k].min(c[2]);
    }
    depth
}

fn write_error(e: splatzoo_datasets::DatasetError) -> Prior4dError {
    Prior4dError::Train(e.into())
}

/// Writes the synthetic `capture`'s acting priors under `root` in this module's layout, frame
/// `k` as `name(k)`'s stem: its keypoints, normal maps, monocular inverse depth and ground
/// masks (at the capture's size, which is then the images' full resolution).
pub fn write_given(
    capture: &Prior4dCapture,
    root: &Path,
    name: impl Fn(usize) -> String,
) -> Result<(), Prior4dError> {
    for folder in [KEYPOINTS, NORMALS, MONO_DEPTH, GROUND] {
        let dir = root.join(folder);
        std::fs::create_dir_all(&dir).map_err(|e| problem(&dir, format!("cannot create ({e})")))?;
    }
    for (k, frame) in capture.acting.iter().enumerate() {
        let stem = Path::new(&name(k))
            .file_stem()
            .map_or_else(String::new, |s| s.to_string_lossy().into_owned());
        let [h, w, _] = frame.image.dims();
        if let Some(points) = capture.acting_keypoints.get(k) {
            let person = PersonKeypoints {
                body: points.clone(),
                face: Vec::new(),
                left_hand: Vec::new(),
                right_hand: Vec::new(),
            };
            let path = root.join(KEYPOINTS).join(format!("{stem}_keypoints.json"));
            write_keypoints(&path, &person).map_err(write_error)?;
        }
        if let Some(normals) = &frame.normals {
            let path = root.join(NORMALS).join(format!("{stem}.npy"));
            write_npy_f32(&path, &[h as u64, w as u64, 3], &host_f32(normals))
                .map_err(write_error)?;
        }
        let path = root.join(MONO_DEPTH).join(format!("{stem}.npy"));
        write_npy_f32(
            &path,
            &[h as u64, w as u64],
            &host_f32(&frame.mono_inverse_depth),
        )
        .map_err(write_error)?;
        write_ground(&root.join(GROUND).join(format!("{stem}.png")), frame)?;
    }
    Ok(())
}

fn write_ground(path: &Path, frame: &ActingFrame) -> Result<(), Prior4dError> {
    let g = &frame.ground;
    let grey: Vec<u8> = g.data.iter().map(|&v| if v { 255 } else { 0 }).collect();
    let image = image::GrayImage::from_raw(g.width as u32, g.height as u32, grey)
        .expect("one value per pixel");
    let mut bytes = Vec::new();
    image
        .write_to(
            &mut std::io::Cursor::new(&mut bytes),
            image::ImageFormat::Png,
        )
        .map_err(|e| problem(path, format!("cannot encode ({e})")))?;
    write_bytes(path, &bytes).map_err(write_error)
}
