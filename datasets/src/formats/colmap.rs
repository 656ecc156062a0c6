//! COLMAP's text model (`cameras.txt`, `images.txt`, `points3D.txt`), as NeuMan ships it.
//!
//! Conventions (COLMAP's documentation): image poses are world-to-camera, rotation as a
//! quaternion `QW QX QY QZ` (Hamilton, scalar first), OpenCV camera axes (x right, y down,
//! z forward); pixel centres at `+0.5`, as ours, so principal points carry over unchanged.
//! Camera models read: `SIMPLE_PINHOLE`, `PINHOLE`, `SIMPLE_RADIAL` (`k1`), `RADIAL` (`k1 k2`),
//! `OPENCV` (`k1 k2 p1 p2`); others are refused naming the model.

use super::{Distortion, SparsePoint, camera_from};
use crate::DatasetError;
use splatzoo_models::rotation_scalar::quaternion_matrix;
use splatzoo_rasterizer::Camera;
use std::collections::BTreeMap;
use std::path::Path;

/// An intrinsic camera of `cameras.txt`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Intrinsics {
    pub width: u32,
    pub height: u32,
    /// `fx fy cx cy`.
    pub k: [f64; 4],
    pub distortion: Distortion,
}

/// An image of `images.txt`.
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
        let (count, k, d) = match f[1] {
            "SIMPLE_PINHOLE" => (3, [p[0], p[0], p[1], p[2]], Distortion::default()),
            "PINHOLE" => (4, [p[0], p[1], p[2], p[3]], Distortion::default()),
            "SIMPLE_RADIAL" => (
                4,
                [p[0], p[0], p[1], p[2]],
                Distortion {
                    k1: p[3],
                    ..Default::default()
                },
            ),
            "RADIAL" => (
                5,
                [p[0], p[0], p[1], p[2]],
                Distortion {
                    k1: p[3],
                    k2: p[4],
                    ..Default::default()
                },
            ),
            "OPENCV" => (
                8,
                [p[0], p[1], p[2], p[3]],
                Distortion {
                    k1: p[4],
                    k2: p[5],
                    p1: p[6],
                    p2: p[7],
                    k3: 0.0,
                },
            ),
            other => {
                return Err(bad(&format!(
                    "camera model {other} is not read (SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV)"
                )));
            }
        };
        if p.len() != count {
            return Err(bad(&format!(
                "{} takes {count} parameters, found {}",
                f[1],
                p.len()
            )));
        }
        cameras.insert(
            id,
            Intrinsics {
                width: w,
                height: h,
                k,
                distortion: d,
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
        points.push((
            [v[0], v[1], v[2]],
            [v[3], v[4], v[5]].map(|c| (c / 255.0) as f32),
        ));
    }
    Ok(points)
}
