//! COLMAP's sparse model: the text form (`cameras.txt`, `images.txt`, `points3D.txt`, as NeuMan
//! ships it) read here, the binary form (`*.bin`) in [`super::colmap_binary`], both into the
//! same types; [`read_model`] picks the binary files when `cameras.bin` is there.
//!
//! Conventions (COLMAP's documentation): image poses are world-to-camera, rotation as a
//! quaternion `QW QX QY QZ` (Hamilton, scalar first), OpenCV camera axes (x right, y down,
//! z forward); pixel centres at `+0.5`, as ours, so principal points carry over unchanged.
//! Camera models read ([`model_intrinsics`], shared by both forms): `SIMPLE_PINHOLE`,
//! `PINHOLE`, `SIMPLE_RADIAL` (`k1`), `RADIAL` (`k1 k2`), `OPENCV` (`k1 k2 p1 p2`); others are
//! refused naming the model (by name in text, by id and name in binary).

use super::colmap_binary::{read_cameras_binary, read_images_binary, read_points_binary};
use super::{Distortion, SparsePoint, camera_from};
use crate::DatasetError;
use splatzoo_models::rotation_scalar::quaternion_matrix;
use splatzoo_rasterizer::Camera;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// An intrinsic camera of `cameras.txt` / `cameras.bin`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Intrinsics {
    pub width: u32,
    pub height: u32,
    /// `fx fy cx cy`.
    pub k: [f64; 4],
    pub distortion: Distortion,
}

/// An image of `images.txt` / `images.bin`.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    pub name: String,
    pub camera_id: u32,
    /// World-to-camera.
    pub rotation: [[f64; 3]; 3],
    pub translation: [f64; 3],
}

impl Image {
    pub fn camera(&self, intrinsics: &Intrinsics) -> Camera {
        camera_from(
            intrinsics.k,
            (intrinsics.width, intrinsics.height),
            self.rotation,
            self.translation,
        )
    }
}

/// A camera model as a file names it: by name (`cameras.txt`) or by COLMAP's model id
/// (`cameras.bin`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CameraModel<'a> {
    Name(&'a str),
    Id(i32),
}

/// The models read, as COLMAP numbers them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Model {
    SimplePinhole,
    Pinhole,
    SimpleRadial,
    Radial,
    Opencv,
}

/// (model, name, COLMAP id, parameter count) of the models read.
static READ: [(Model, &str, i32, usize); 5] = [
    (Model::SimplePinhole, "SIMPLE_PINHOLE", 0, 3),
    (Model::Pinhole, "PINHOLE", 1, 4),
    (Model::SimpleRadial, "SIMPLE_RADIAL", 2, 4),
    (Model::Radial, "RADIAL", 3, 5),
    (Model::Opencv, "OPENCV", 4, 8),
];

/// COLMAP's other models by id, named in refusals.
static NOT_READ: [(&str, i32); 6] = [
    ("OPENCV_FISHEYE", 5),
    ("FULL_OPENCV", 6),
    ("FOV", 7),
    ("SIMPLE_RADIAL_FISHEYE", 8),
    ("RADIAL_FISHEYE", 9),
    ("THIN_PRISM_FISHEYE", 10),
];

const READ_NAMES: &str = "SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV";

fn lookup(model: CameraModel<'_>) -> Result<(Model, &'static str, usize), String> {
    let found = READ.iter().find(|(_, name, id, _)| match model {
        CameraModel::Name(n) => *name == n,
        CameraModel::Id(i) => *id == i,
    });
    if let Some(&(m, name, _, count)) = found {
        return Ok((m, name, count));
    }
    let described = match model {
        CameraModel::Name(n) => n.to_owned(),
        CameraModel::Id(i) => match NOT_READ.iter().find(|(_, id)| *id == i) {
            Some((name, _)) => format!("id {i} ({name})"),
            None => format!("id {i} (not a COLMAP model)"),
        },
    };
    Err(format!(
        "camera model {described} is not read ({READ_NAMES})"
    ))
}

/// How many parameters `model` takes, or why it is not read.
pub fn parameter_count(model: CameraModel<'_>) -> Result<usize, String> {
    lookup(model).map(|(_, _, count)| count)
}

/// `fx fy cx cy` and the OpenCV distortion of a COLMAP camera model from its parameters, the
/// one mapping of the text and binary readers; an error (for the caller to place) when the
/// model is not read or the parameter count is not the model's.
pub fn model_intrinsics(
    model: CameraModel<'_>,
    p: &[f64],
) -> Result<([f64; 4], Distortion), String> {
    let (model, name, count) = lookup(model)?;
    if p.len() != count {
        return Err(format!(
            "{name} takes {count} parameters, found {}",
            p.len()
        ));
    }
    let none = Distortion::default();
    Ok(match model {
        Model::SimplePinhole => ([p[0], p[0], p[1], p[2]], none),
        Model::Pinhole => ([p[0], p[1], p[2], p[3]], none),
        Model::SimpleRadial => ([p[0], p[0], p[1], p[2]], Distortion { k1: p[3], ..none }),
        Model::Radial => (
            [p[0], p[0], p[1], p[2]],
            Distortion {
                k1: p[3],
                k2: p[4],
                ..none
            },
        ),
        Model::Opencv => (
            [p[0], p[1], p[2], p[3]],
            Distortion {
                k1: p[4],
                k2: p[5],
                p1: p[6],
                p2: p[7],
                k3: 0.0,
            },
        ),
    })
}

/// A whole sparse model, from text or binary files.
#[derive(Debug, Clone)]
pub struct ColmapModel {
    /// The folder read (`sparse/0/`, …).
    pub dir: PathBuf,
    /// Whether the `.bin` files were read.
    pub binary: bool,
    pub cameras: BTreeMap<u32, Intrinsics>,
    /// In file order.
    pub images: Vec<Image>,
    /// Empty where the model has no `points3D` file.
    pub points: Vec<SparsePoint>,
}

impl ColmapModel {
    /// The file of the model's form: `file("images")` is `<dir>/images.bin` or `images.txt`.
    pub fn file(&self, stem: &str) -> PathBuf {
        let ext = if self.binary { "bin" } else { "txt" };
        self.dir.join(format!("{stem}.{ext}"))
    }
}

/// Reads the model in `dir`: the binary files when `cameras.bin` exists, else the text files.
/// A missing `points3D` file gives no points.
pub fn read_model(dir: &Path) -> Result<ColmapModel, DatasetError> {
    let binary = dir.join("cameras.bin").is_file();
    let mut model = ColmapModel {
        dir: dir.to_path_buf(),
        binary,
        cameras: BTreeMap::new(),
        images: Vec::new(),
        points: Vec::new(),
    };
    let (cameras, images, points) = (
        model.file("cameras"),
        model.file("images"),
        model.file("points3D"),
    );
    if binary {
        model.cameras = read_cameras_binary(&cameras)?;
        model.images = read_images_binary(&images)?;
        if points.is_file() {
            model.points = read_points_binary(&points)?;
        }
    } else {
        model.cameras = read_cameras(&cameras)?;
        model.images = read_images(&images)?;
        if points.is_file() {
            model.points = read_points(&points)?;
        }
    }
    Ok(model)
}

fn read(path: &Path) -> Result<String, DatasetError> {
    std::fs::read_to_string(path)
        .map_err(|e| DatasetError::file(path, format!("cannot read ({e})")))
}

/// Data lines (comments and blank lines dropped) with their 1-based line numbers.
fn data_lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.starts_with('#'))
}

fn numbers(
    path: &Path,
    line: usize,
    fields: &[&str],
    what: &str,
) -> Result<Vec<f64>, DatasetError> {
    fields
        .iter()
        .map(|f| f.parse::<f64>().ok().filter(|v| v.is_finite()))
        .collect::<Option<Vec<_>>>()
        .ok_or_else(|| {
            DatasetError::field(path, &format!("line {line}"), format!("expected {what}"))
        })
}

pub fn read_cameras(path: &Path) -> Result<BTreeMap<u32, Intrinsics>, DatasetError> {
    let text = read(path)?;
    let mut cameras = BTreeMap::new();
    for (line, l) in data_lines(&text).filter(|(_, l)| !l.is_empty()) {
        let f: Vec<&str> = l.split_whitespace().collect();
        let bad = |what: &str| DatasetError::field(path, &format!("line {line}"), what.to_owned());
        if f.len() < 5 {
            return Err(bad("expected CAMERA_ID MODEL WIDTH HEIGHT PARAMS[]"));
        }
        let id: u32 = f[0]
            .parse()
            .map_err(|_| bad("CAMERA_ID is not an integer"))?;
        let (w, h): (u32, u32) = match (f[2].parse(), f[3].parse()) {
            (Ok(w), Ok(h)) if w > 0 && h > 0 => (w, h),
            _ => return Err(bad("WIDTH and HEIGHT must be positive integers")),
        };
        let p = numbers(path, line, &f[4..], "finite camera parameters")?;
        let (k, distortion) =
            model_intrinsics(CameraModel::Name(f[1]), &p).map_err(|e| bad(e.as_str()))?;
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
    Ok(cameras)
}

/// Images in file order (the second line of each record, its 2D points, is skipped).
pub fn read_images(path: &Path) -> Result<Vec<Image>, DatasetError> {
    let text = read(path)?;
    let mut images = Vec::new();
    let mut lines = data_lines(&text);
    while let Some((line, l)) = lines.next() {
        if l.is_empty() {
            continue;
        }
        let f: Vec<&str> = l.split_whitespace().collect();
        if f.len() != 10 {
            return Err(DatasetError::field(
                path,
                &format!("line {line}"),
                "expected IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME (10 fields)",
            ));
        }
        let v = numbers(path, line, &f[1..8], "a finite quaternion and translation")?;
        let camera_id = f[8].parse().map_err(|_| {
            DatasetError::field(path, &format!("line {line}"), "CAMERA_ID is not an integer")
        })?;
        images.push(Image {
            name: f[9].to_owned(),
            camera_id,
            rotation: quaternion_matrix([v[0], v[1], v[2], v[3]]),
            translation: [v[4], v[5], v[6]],
        });
        lines.next(); // POINTS2D
    }
    Ok(images)
}

/// An 8-bit colour channel in [0, 1], the same in the text and binary readers.
pub(crate) fn unit_colour(c: f64) -> f32 {
    (c / 255.0) as f32
}

/// Points as (position, sRGB colour in [0, 1]).
pub fn read_points(path: &Path) -> Result<Vec<SparsePoint>, DatasetError> {
    let text = read(path)?;
    let mut points = Vec::new();
    for (line, l) in data_lines(&text).filter(|(_, l)| !l.is_empty()) {
        let f: Vec<&str> = l.split_whitespace().collect();
        if f.len() < 8 {
            return Err(DatasetError::field(
                path,
                &format!("line {line}"),
                "expected POINT3D_ID X Y Z R G B ERROR TRACK[]",
            ));
        }
        let v = numbers(path, line, &f[1..7], "finite X Y Z R G B")?;
        points.push(([v[0], v[1], v[2]], [v[3], v[4], v[5]].map(unit_colour)));
    }
    Ok(points)
}
