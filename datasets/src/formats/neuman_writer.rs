//! Writes frames as NeuMan's preprocessing leaves a scene (the layout [`super::neuman`] reads):
//! a synthetic capture written this way is a real-format capture whose every value is known,
//! to try and test a trainer's NeuMan path without NeuMan's data. Every file is written
//! atomically; a failure names the file.

use super::{Similarity, SparsePoint};
use crate::DatasetError;
use crate::files::write_bytes;
use crate::synth::export::write_npy_f32;
use splatzoo_models::pickle::{Writer, npy_object_bytes};
use splatzoo_rasterizer::Camera;
use std::path::Path;

/// One frame of a NeuMan scene.
pub struct NeumanFrame {
    /// World to camera (OpenCV axes, COLMAP's world) and pinhole intrinsics; the image's size.
    pub camera: Camera,
    /// `[H, W, 3]` sRGB bytes, row-major.
    pub rgb: Vec<u8>,
    /// `[H, W]`: the person's pixels.
    pub person: Vec<bool>,
    /// SMPL's 72 axis-angle values (the global orientation first) and 10 shape coefficients.
    pub pose: Vec<f64>,
    pub betas: Vec<f64>,
    /// `x_world = s R x_smpl + t`, NeuMan's alignment of this frame.
    pub alignment: Similarity,
    /// `[H, W]` z-depth in COLMAP's unit (0 or non-finite: none), written as
    /// `depth_maps/<NAME>.npy` where given.
    pub depth: Option<Vec<f32>>,
}

/// The image name of frame `k`.
pub fn frame_name(k: usize) -> String {
    format!("{k:05}.png")
}

fn png(path: &Path, image: impl Into<image::DynamicImage>) -> Result<(), DatasetError> {
    let mut bytes = Vec::new();
    image
        .into()
        .write_to(
            &mut std::io::Cursor::new(&mut bytes),
            image::ImageFormat::Png,
        )
        .map_err(|e| DatasetError::file(path, format!("cannot encode ({e})")))?;
    write_bytes(path, &bytes)
}

fn expect_len(frame: usize, what: &str, len: usize, expected: usize) -> Result<(), DatasetError> {
    if len == expected {
        return Ok(());
    }
    Err(DatasetError::file(
        Path::new(&frame_name(frame)),
        format!("{what}: {len} values, expected {expected}"),
    ))
}

/// Writes `frames` (named [`frame_name`], in order) under `root`: `sparse/` (a COLMAP text model
/// with `points`, positions and sRGB in [0, 1]), `images/`, `segmentations/<name>` (0 = person,
/// 255 = background), `smpl_output_optimized.pkl`, `alignments.npy`, and `test_split.txt`
/// listing the frames `test` (not written when empty); `depth_maps/<NAME>.npy` for the frames
/// that carry a depth map.
pub fn write_neuman_scene(
    root: &Path,
    frames: &[NeumanFrame],
    points: &[SparsePoint],
    test: &[usize],
) -> Result<(), DatasetError> {
    for dir in ["sparse", "images", "segmentations"] {
        let dir = root.join(dir);
        std::fs::create_dir_all(&dir)
            .map_err(|e| DatasetError::file(&dir, format!("cannot create ({e})")))?;
    }
    let mut cameras = String::from("# CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n");
    let mut images = String::from("# IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n");
    for (k, frame) in frames.iter().enumerate() {
        let c = &frame.camera;
        let (w, h) = (c.width, c.height);
        let pixels = (w * h) as usize;
        expect_len(k, "rgb", frame.rgb.len(), 3 * pixels)?;
        expect_len(k, "person", frame.person.len(), pixels)?;
        expect_len(k, "pose", frame.pose.len(), 72)?;
        expect_len(k, "betas", frame.betas.len(), 10)?;
        cameras.push_str(&format!(
            "{} PINHOLE {w} {h} {} {} {} {}\n",
            k + 1,
            c.fx,
            c.fy,
            c.cx,
            c.cy
        ));
        let m = c.world_to_camera;
        let r = glam::DMat3::from_cols_array_2d(
            &[0, 1, 2].map(|j| [0, 1, 2].map(|i| f64::from(m[i][j]))),
        );
        let q = glam::DQuat::from_mat3(&r).normalize();
        images.push_str(&format!(
            "{} {} {} {} {} {} {} {} {} {}\n\n",
            k + 1,
            q.w,
            q.x,
            q.y,
            q.z,
            m[0][3],
            m[1][3],
            m[2][3],
            k + 1,
            frame_name(k)
        ));
        let rgb = image::RgbImage::from_raw(w, h, frame.rgb.clone()).expect("length checked");
        png(&root.join("images").join(frame_name(k)), rgb)?;
        let grey: Vec<u8> = frame
            .person
            .iter()
            .map(|&p| if p { 0 } else { 255 })
            .collect();
        let mask = image::GrayImage::from_raw(w, h, grey).expect("length checked");
        png(&root.join("segmentations").join(frame_name(k)), mask)?;
        if let Some(depth) = &frame.depth {
            expect_len(k, "depth", depth.len(), pixels)?;
            let zeroed: Vec<f32> = depth
                .iter()
                .map(|&d| if d.is_finite() && d > 0.0 { d } else { 0.0 })
                .collect();
            let dir = root.join("depth_maps");
            std::fs::create_dir_all(&dir)
                .map_err(|e| DatasetError::file(&dir, format!("cannot create ({e})")))?;
            let file = dir.join(format!("{}.npy", frame_name(k)));
            write_npy_f32(&file, &[u64::from(h), u64::from(w)], &zeroed)?;
        }
    }
    let sparse = root.join("sparse");
    write_bytes(&sparse.join("cameras.txt"), cameras.as_bytes())?;
    write_bytes(&sparse.join("images.txt"), images.as_bytes())?;
    let mut lines = String::from("# POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[]\n");
    for (k, (p, c)) in points.iter().enumerate() {
        let [r, g, b] = c.map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8);
        lines.push_str(&format!(
            "{} {} {} {} {r} {g} {b} 0.5\n",
            k + 1,
            p[0],
            p[1],
            p[2]
        ));
    }
    write_bytes(&sparse.join("points3D.txt"), lines.as_bytes())?;

    let mut w = Writer::new(true);
    w.begin_dict().int(1).begin_dict().str("pose").begin_list();
    for frame in frames {
        w.array(&[72], &frame.pose, false);
    }
    w.end_list().str("betas").begin_list();
    for frame in frames {
        w.array(&[10], &frame.betas, false);
    }
    w.end_list().end_dict().end_dict();
    write_bytes(&root.join("smpl_output_optimized.pkl"), &w.finish())?;
    let mut w = Writer::new(false);
    w.begin_object_scalar().begin_dict();
    for (k, frame) in frames.iter().enumerate() {
        let s = &frame.alignment;
        // Row i of A's 3×3 block is column i of s R; the last row is t.
        let mut a: Vec<f64> = (0..9).map(|k| s.scale * s.rotation[k % 3][k / 3]).collect();
        a.extend(s.translation);
        w.str(&frame_name(k)).array(&[4, 3], &a, true);
    }
    w.end_dict().end_object_scalar();
    write_bytes(&root.join("alignments.npy"), &npy_object_bytes(&w.finish()))?;
    if !test.is_empty() {
        let listed: String = test
            .iter()
            .map(|&k| format!("{}\n", frame_name(k)))
            .collect();
        write_bytes(&root.join("test_split.txt"), listed.as_bytes())?;
    }
    Ok(())
}
