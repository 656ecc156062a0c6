//! COLMAP's binary sparse model (`cameras.bin`, `images.bin`, `points3D.bin`), the form COLMAP
//! writes by default and 3DGS, gsplat and Brush read, into the types of the text reader
//! ([`super::colmap`]), so both forms give identical datasets.
//!
//! Layout (COLMAP's `read_write_model`), little-endian throughout:
//!
//! - `cameras.bin`: `u64` count; per camera `i32` CAMERA_ID, `i32` MODEL_ID, `u64` WIDTH,
//!   `u64` HEIGHT, then the model's `f64` parameters (their number follows from the model, so a
//!   model not read stops the file: refused by id and name).
//! - `images.bin`: `u64` count; per image `i32` IMAGE_ID, `f64` QW QX QY QZ, `f64` TX TY TZ,
//!   `i32` CAMERA_ID, the name as NUL-terminated bytes, `u64` POINTS2D count, then that many
//!   `(f64 X, f64 Y, i64 POINT3D_ID)` (skipped).
//! - `points3D.bin`: `u64` count; per point `u64` POINT3D_ID, `f64` X Y Z, `u8` R G B, `f64`
//!   ERROR, `u64` track length, then that many `(i32 IMAGE_ID, i32 POINT2D_IDX)` (skipped).
//!
//! A corrupt file is an error naming the file and what was being read ("truncated in image 3's
//! name"; records count from 0), never a panic; every count is checked against the bytes left
//! before anything is allocated for it, and bytes after the last record are refused.

use super::SparsePoint;
use super::colmap::{
    CameraModel, Image, Intrinsics, model_intrinsics, parameter_count, unit_colour,
};
use crate::DatasetError;
use splatzoo_models::rotation_scalar::quaternion_matrix;
use std::collections::BTreeMap;
use std::path::Path;

/// A little-endian cursor over a whole file, its errors naming the file.
struct Reader<'a> {
    path: &'a Path,
    bytes: &'a [u8],
    pos: usize,
}

impl<'a> Reader<'a> {
    fn new(path: &'a Path, bytes: &'a [u8]) -> Self {
        Self {
            path,
            bytes,
            pos: 0,
        }
    }

    fn remaining(&self) -> usize {
        self.bytes.len() - self.pos
    }

    fn truncated(&self, what: String, needed: u128) -> DatasetError {
        DatasetError::file(
            self.path,
            format!(
                "truncated in {what} (needs {needed} bytes at offset {}, {} remain)",
                self.pos,
                self.remaining()
            ),
        )
    }

    fn take(&mut self, n: usize, what: impl Fn() -> String) -> Result<&'a [u8], DatasetError> {
        if self.remaining() < n {
            return Err(self.truncated(what(), n as u128));
        }
        let bytes: &'a [u8] = self.bytes;
        let slice = &bytes[self.pos..self.pos + n];
        self.pos += n;
        Ok(slice)
    }

    fn array<const N: usize>(
        &mut self,
        what: impl Fn() -> String,
    ) -> Result<[u8; N], DatasetError> {
        let mut out = [0u8; N];
        out.copy_from_slice(self.take(N, what)?);
        Ok(out)
    }

    fn u64(&mut self, what: impl Fn() -> String) -> Result<u64, DatasetError> {
        self.array(what).map(u64::from_le_bytes)
    }

    fn i32(&mut self, what: impl Fn() -> String) -> Result<i32, DatasetError> {
        self.array(what).map(i32::from_le_bytes)
    }

    fn f64(&mut self, what: impl Fn() -> String) -> Result<f64, DatasetError> {
        self.array(what).map(f64::from_le_bytes)
    }

    /// An `f64` that must be finite.
    fn finite(&mut self, what: impl Fn() -> String) -> Result<f64, DatasetError> {
        let v = self.f64(&what)?;
        if v.is_finite() {
            Ok(v)
        } else {
            Err(DatasetError::file(
                self.path,
                format!("{} is {v}, expected a finite number", what()),
            ))
        }
    }

    /// A record count, at most what the bytes left can hold at `min_record` bytes each.
    fn count(&mut self, records: &str, min_record: usize) -> Result<usize, DatasetError> {
        let n = self.u64(|| format!("the {records} count"))?;
        let fits = (self.remaining() / min_record) as u64;
        if n > fits {
            return Err(DatasetError::file(
                self.path,
                format!(
                    "{n} {records}s need at least {min_record} bytes each, {} bytes remain \
                     (truncated or corrupt)",
                    self.remaining()
                ),
            ));
        }
        Ok(n as usize)
    }

    /// Skips `n` entries of `size` bytes.
    fn skip(&mut self, n: u64, size: usize, what: impl Fn() -> String) -> Result<(), DatasetError> {
        let needed = u128::from(n) * size as u128;
        if needed > self.remaining() as u128 {
            return Err(self.truncated(format!("{} ({n} entries)", what()), needed));
        }
        self.pos += needed as usize;
        Ok(())
    }

    /// NUL-terminated UTF-8 text.
    fn name(&mut self, what: impl Fn() -> String) -> Result<String, DatasetError> {
        let rest = &self.bytes[self.pos..];
        let Some(end) = rest.iter().position(|&b| b == 0) else {
            return Err(DatasetError::file(
                self.path,
                format!(
                    "truncated in {} (no terminating NUL before the end of the file)",
                    what()
                ),
            ));
        };
        let text = std::str::from_utf8(&rest[..end])
            .map_err(|_| DatasetError::file(self.path, format!("{} is not UTF-8 text", what())))?;
        let text = text.to_owned();
        self.pos += end + 1;
        Ok(text)
    }

    /// Refuses bytes after the last record (a count smaller than the file's records).
    fn finish(&self, records: &str) -> Result<(), DatasetError> {
        match self.remaining() {
            0 => Ok(()),
            n => Err(DatasetError::file(
                self.path,
                format!("{n} bytes after the last {records} (a corrupt count?)"),
            )),
        }
    }
}

fn read_file(path: &Path) -> Result<Vec<u8>, DatasetError> {
    std::fs::read(path).map_err(|e| DatasetError::file(path, format!("cannot read ({e})")))
}

/// A non-negative id as `u32`.
fn id_u32(path: &Path, key: &str, name: &str, id: i32) -> Result<u32, DatasetError> {
    u32::try_from(id)
        .map_err(|_| DatasetError::field(path, key, format!("{name} {id} is negative")))
}

/// `cameras.bin`: intrinsics by CAMERA_ID.
pub fn read_cameras_binary(path: &Path) -> Result<BTreeMap<u32, Intrinsics>, DatasetError> {
    let bytes = read_file(path)?;
    let mut r = Reader::new(path, &bytes);
    // id, model, width, height, and at least SIMPLE_PINHOLE's 3 parameters.
    let n = r.count("camera", 4 + 4 + 8 + 8 + 3 * 8)?;
    let mut cameras = BTreeMap::new();
    for i in 0..n {
        let key = format!("camera {i}");
        let id = r.i32(|| format!("camera {i}'s CAMERA_ID"))?;
        let model = r.i32(|| format!("camera {i}'s MODEL_ID"))?;
        let width = r.u64(|| format!("camera {i}'s WIDTH"))?;
        let height = r.u64(|| format!("camera {i}'s HEIGHT"))?;
        let id = id_u32(path, &key, "CAMERA_ID", id)?;
        let count = parameter_count(CameraModel::Id(model))
            .map_err(|p| DatasetError::field(path, &key, p))?;
        let (w, h) = match (u32::try_from(width), u32::try_from(height)) {
            (Ok(w), Ok(h)) if w > 0 && h > 0 => (w, h),
            _ => {
                return Err(DatasetError::field(
                    path,
                    &key,
                    format!("WIDTH {width} × HEIGHT {height}: expected positive 32-bit sizes"),
                ));
            }
        };
        let mut params = Vec::with_capacity(count);
        for j in 0..count {
            params.push(r.finite(|| format!("camera {i}'s parameter {j}"))?);
        }
        let (k, distortion) = model_intrinsics(CameraModel::Id(model), &params)
            .map_err(|p| DatasetError::field(path, &key, p))?;
        cameras.insert(
            id,
            Intrinsics {
                width: w,
                height: h,
                k,
                distortion,
            },
        );
    }
    r.finish("camera")?;
    Ok(cameras)
}

/// `images.bin`: images in file order (their 2D points skipped).
pub fn read_images_binary(path: &Path) -> Result<Vec<Image>, DatasetError> {
    let bytes = read_file(path)?;
    let mut r = Reader::new(path, &bytes);
    // id, pose, camera id, an empty name's NUL, the 2D point count.
    let n = r.count("image", 4 + 7 * 8 + 4 + 1 + 8)?;
    let mut images = Vec::with_capacity(n);
    for i in 0..n {
        r.i32(|| format!("image {i}'s IMAGE_ID"))?;
        let mut pose = [0.0; 7];
        for (j, field) in ["QW", "QX", "QY", "QZ", "TX", "TY", "TZ"]
            .iter()
            .enumerate()
        {
            pose[j] = r.finite(|| format!("image {i}'s {field}"))?;
        }
        let camera_id = r.i32(|| format!("image {i}'s CAMERA_ID"))?;
        let name = r.name(|| format!("image {i}'s name"))?;
        let camera_id = id_u32(path, &name, "CAMERA_ID", camera_id)?;
        let points = r.u64(|| format!("image {i}'s POINTS2D count"))?;
        r.skip(points, 8 + 8 + 8, || format!("image {i}'s POINTS2D"))?;
        images.push(Image {
            name,
            camera_id,
            rotation: quaternion_matrix([pose[0], pose[1], pose[2], pose[3]]),
            translation: [pose[4], pose[5], pose[6]],
        });
    }
    r.finish("image")?;
    Ok(images)
}

/// `points3D.bin`: points as (position, sRGB colour in [0, 1]), in file order.
pub fn read_points_binary(path: &Path) -> Result<Vec<SparsePoint>, DatasetError> {
    let bytes = read_file(path)?;
    let mut r = Reader::new(path, &bytes);
    // id, position, colour, error, track length.
    let n = r.count("point", 8 + 3 * 8 + 3 + 8 + 8)?;
    let mut points = Vec::with_capacity(n);
    for i in 0..n {
        r.u64(|| format!("point {i}'s POINT3D_ID"))?;
        let mut x = [0.0; 3];
        for (j, field) in ["X", "Y", "Z"].iter().enumerate() {
            x[j] = r.finite(|| format!("point {i}'s {field}"))?;
        }
        let rgb: [u8; 3] = r.array(|| format!("point {i}'s colour"))?;
        r.f64(|| format!("point {i}'s ERROR"))?;
        let track = r.u64(|| format!("point {i}'s track length"))?;
        r.skip(track, 4 + 4, || format!("point {i}'s track"))?;
        points.push((x, rgb.map(|c| unit_colour(f64::from(c)))));
    }
    r.finish("point")?;
    Ok(points)
}
