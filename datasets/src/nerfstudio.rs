//! nerfstudio's `transforms.json`: per-image file paths and camera-to-world matrices in the
//! OpenGL convention (x right, y up, looking down −z), pinhole intrinsics shared at the top
//! level or given per frame (`fl_x`, `fl_y`, `cx`, `cy`, `w`, `h`), optional `mask_path`
//! (0 = ignore the pixel) and `depth_file_path` (16-bit PNG in millimetres). The Blender
//! variant's `camera_angle_x` is read too, and the top-level `ply_file_path` (a PLY of SfM
//! points, relative to the `transforms.json`, which `ns-process-data` writes as
//! `sparse_pc.ply`; read by [`crate::point_ply`]). nerfstudio, gsplat's and Brush's loaders read this
//! layout, so a scene written here trains in them unchanged.

use crate::DatasetError;
use crate::files::write_bytes;
use serde::{Deserialize, Serialize};
use splatzoo_rasterizer::Camera;
use std::path::Path;

/// One image of a capture.
#[derive(Debug, Clone, PartialEq)]
pub struct NerfstudioFrame {
    /// Relative to the `transforms.json`.
    pub file_path: String,
    pub mask_path: Option<String>,
    pub depth_file_path: Option<String>,
    pub camera: Camera,
    /// Normalised capture time in [0, 1] for dynamic scenes.
    pub time: Option<f64>,
}

#[derive(Debug, Default, Serialize, Deserialize)]
struct Intrinsics {
    #[serde(skip_serializing_if = "Option::is_none")]
    fl_x: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    fl_y: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    cx: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    cy: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    w: Option<u32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    h: Option<u32>,
    #[serde(default, skip_serializing)]
    camera_angle_x: Option<f64>,
}

#[derive(Debug, Serialize, Deserialize)]
struct FrameJson {
    file_path: String,
    transform_matrix: [[f64; 4]; 4],
    #[serde(default, skip_serializing_if = "Option::is_none")]
    mask_path: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    depth_file_path: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    time: Option<f64>,
    #[serde(flatten)]
    intrinsics: Intrinsics,
}

#[derive(Debug, Serialize, Deserialize)]
struct TransformsJson {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    camera_model: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    ply_file_path: Option<String>,
    #[serde(flatten)]
    intrinsics: Intrinsics,
    frames: Vec<FrameJson>,
}

fn intrinsics_of(camera: &Camera) -> Intrinsics {
    Intrinsics {
        fl_x: Some(camera.fx as f64),
        fl_y: Some(camera.fy as f64),
        cx: Some(camera.cx as f64),
        cy: Some(camera.cy as f64),
        w: Some(camera.width),
        h: Some(camera.height),
        camera_angle_x: None,
    }
}

/// Camera-to-world in the OpenGL convention from the rasterizer's OpenCV world-to-camera.
pub fn camera_to_world_opengl(camera: &Camera) -> [[f64; 4]; 4] {
    let w = camera.world_to_camera.map(|r| r.map(f64::from));
    let mut m = [[0.0; 4]; 4];
    for i in 0..3 {
        // Rotation transposed; camera centre −Rᵀt.
        for j in 0..3 {
            m[i][j] = w[j][i];
        }
        m[i][3] = -(0..3).map(|k| w[k][i] * w[k][3]).sum::<f64>();
        // OpenCV (y down, z forward) → OpenGL (y up, z backward).
        m[i][1] = -m[i][1];
        m[i][2] = -m[i][2];
    }
    m[3][3] = 1.0;
    m
}

fn world_to_camera_opencv(m: &[[f64; 4]; 4]) -> [[f32; 4]; 3] {
    let mut w = [[0.0f32; 4]; 3];
    for i in 0..3 {
        let sign = if i == 0 { 1.0 } else { -1.0 };
        for j in 0..3 {
            w[i][j] = (sign * m[j][i]) as f32;
        }
        w[i][3] = -(sign * (0..3).map(|k| m[k][i] * m[k][3]).sum::<f64>()) as f32;
    }
    w
}

/// A whole `transforms.json`: its frames and the top-level `ply_file_path`, where given.
#[derive(Debug, Clone, PartialEq)]
pub struct Transforms {
    pub frames: Vec<NerfstudioFrame>,
    /// Relative to the `transforms.json`.
    pub ply_file_path: Option<String>,
}

/// Writes `frames` as `path` (a `transforms.json`), intrinsics at the top level when every
/// camera shares them, per frame otherwise.
pub fn write_transforms(path: &Path, frames: &[NerfstudioFrame]) -> Result<(), DatasetError> {
    write_transforms_with_points(path, frames, None)
}

/// [`write_transforms`], naming a PLY of sparse points (relative to `path`'s folder) as the
/// top-level `ply_file_path` where given.
pub fn write_transforms_with_points(
    path: &Path,
    frames: &[NerfstudioFrame],
    ply_file_path: Option<&str>,
) -> Result<(), DatasetError> {
    let shared = frames
        .first()
        .map(|f| intrinsics_of(&f.camera))
        .filter(|first| {
            frames.iter().all(|f| {
                let i = intrinsics_of(&f.camera);
                (i.fl_x, i.fl_y, i.cx, i.cy, i.w, i.h)
                    == (first.fl_x, first.fl_y, first.cx, first.cy, first.w, first.h)
            })
        });
    let json = TransformsJson {
        camera_model: Some("OPENCV".into()),
        ply_file_path: ply_file_path.map(str::to_owned),
        frames: frames
            .iter()
            .map(|f| FrameJson {
                file_path: f.file_path.clone(),
                transform_matrix: camera_to_world_opengl(&f.camera),
                mask_path: f.mask_path.clone(),
                depth_file_path: f.depth_file_path.clone(),
                time: f.time,
                intrinsics: if shared.is_some() {
                    Intrinsics::default()
                } else {
                    intrinsics_of(&f.camera)
                },
            })
            .collect(),
        intrinsics: shared.unwrap_or_default(),
    };
    let text = serde_json::to_string_pretty(&json).expect("plain data serialises");
    write_bytes(path, text.as_bytes())
}

/// Reads a `transforms.json` into cameras (near/far left at the rasterizer's defaults).
pub fn read_transforms(path: &Path) -> Result<Vec<NerfstudioFrame>, DatasetError> {
    read_transforms_with_points(path).map(|t| t.frames)
}

/// Reads a `transforms.json` into cameras and its `ply_file_path` (the file itself is read by
/// [`crate::point_ply::read_points`]).
pub fn read_transforms_with_points(path: &Path) -> Result<Transforms, DatasetError> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| DatasetError::file(path, format!("cannot read ({e})")))?;
    let json: TransformsJson = serde_json::from_str(&text)
        .map_err(|e| DatasetError::file(path, format!("not a nerfstudio transforms.json: {e}")))?;
    let frames = json
        .frames
        .iter()
        .enumerate()
        .map(|(k, f)| {
            let own = &f.intrinsics;
            let top = &json.intrinsics;
            let key = |name: &str| format!("frames[{k}].{name}");
            let w = own.w.or(top.w).ok_or_else(|| {
                DatasetError::field(
                    path,
                    &key("w"),
                    "image width missing (no top-level `w` either)",
                )
            })?;
            let h = own.h.or(top.h).ok_or_else(|| {
                DatasetError::field(
                    path,
                    &key("h"),
                    "image height missing (no top-level `h` either)",
                )
            })?;
            let angle = own.camera_angle_x.or(top.camera_angle_x);
            let fl_x = own
                .fl_x
                .or(top.fl_x)
                .or(angle.map(|a| 0.5 * w as f64 / (0.5 * a).tan()))
                .ok_or_else(|| {
                    DatasetError::field(
                        path,
                        &key("fl_x"),
                        "focal length missing (no `fl_x` or `camera_angle_x` here or at the top)",
                    )
                })?;
            let fl_y = own.fl_y.or(top.fl_y).unwrap_or(fl_x);
            let cx = own.cx.or(top.cx).unwrap_or(0.5 * w as f64);
            let cy = own.cy.or(top.cy).unwrap_or(0.5 * h as f64);
            let m = &f.transform_matrix;
            if m.iter().flatten().any(|x| !x.is_finite()) || m[3] != [0.0, 0.0, 0.0, 1.0] {
                return Err(DatasetError::field(
                    path,
                    &key("transform_matrix"),
                    "expected a finite 4×4 rigid transform with last row [0, 0, 0, 1]",
                ));
            }
            Ok(NerfstudioFrame {
                file_path: f.file_path.clone(),
                mask_path: f.mask_path.clone(),
                depth_file_path: f.depth_file_path.clone(),
                time: f.time,
                camera: Camera {
                    fx: fl_x as f32,
                    fy: fl_y as f32,
                    cx: cx as f32,
                    cy: cy as f32,
                    width: w,
                    height: h,
                    near: 0.01,
                    far: 1e4,
                    world_to_camera: world_to_camera_opencv(m),
                },
            })
        })
        .collect::<Result<Vec<_>, DatasetError>>()?;
    Ok(Transforms {
        frames,
        ply_file_path: json.ply_file_path,
    })
}
