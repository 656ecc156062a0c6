//! Writing a synthetic scene to disk, in the project's own layout and, beside it, as a
//! nerfstudio `transforms.json`, so nerfstudio, gsplat and Brush train on exactly the same
//! images and cameras. Every file is written atomically.
//!
//! Layout (`{view}` is `{frame:04}_{camera track}`):
//! - `scene.json`: preset, seed, fps, label legend, light, prior noise and corruption, people
//!   (identity, whether tracked, accessories with their grip and swing, pose files) and every
//!   camera (intrinsics, OpenCV world-to-camera) per frame;
//! - `images/{view}.png` (sRGB) and `images_unshadowed/{view}.png`;
//! - `masks/{human,accessory,coarse}/{view}.png` (255 inside) and `labels/{view}.png` (raw
//!   labels, see [`super::scene`]);
//! - `depth/{view}.npy` (`f32 [H, W]`, camera z in metres, 0 where nothing was hit) and
//!   `depth_mm/{view}.png` (16-bit millimetres, for nerfstudio);
//! - `normals/{view}.npy` (`f32 [H, W, 3]`, world space, zero where nothing was hit);
//! - `people/person_{k}_{truth,prior}.npz` (AMASS layout, 24 joints, 12 betas per frame), for
//!   tracked people only: an untracked person has no pose track for a method to pick up;
//! - `transforms.json` (nerfstudio; `time` per frame for dynamic scenes; masks referenced for
//!   scenes without surroundings).

use super::scene::{Scene, ViewTruth, accessory_label, body_label};
use crate::DatasetError;
use crate::files::{write_atomically, write_bytes};
use crate::image_io::{write_mask_png, write_rgb_png};
use crate::nerfstudio::{NerfstudioFrame, write_transforms};
use crate::pose_sequence::write_pose_sequence;
use crate::render::Light;
use npyz::WriterBuilder;
use serde_json::json;
use splatzoo_rasterizer::Camera;
use std::path::Path;

fn io_error(path: &Path, e: impl std::fmt::Display) -> DatasetError {
    DatasetError::file(path, format!("cannot write ({e})"))
}

/// Writes `values` (row-major, `shape`) as a little-endian `f32` `.npy`.
pub fn write_npy_f32(path: &Path, shape: &[u64], values: &[f32]) -> Result<(), DatasetError> {
    assert_eq!(
        shape.iter().product::<u64>() as usize,
        values.len(),
        "npy shape"
    );
    write_atomically(path, |tmp| {
        let file = std::io::BufWriter::new(std::fs::File::create(tmp)?);
        let mut writer = npyz::WriteOptions::new()
            .default_dtype()
            .shape(shape)
            .writer(file)
            .begin_nd()?;
        writer.extend(values.iter().copied())?;
        writer.finish()
    })
}

fn write_depth_mm(
    path: &Path,
    width: usize,
    height: usize,
    depth: &[f32],
) -> Result<(), DatasetError> {
    let mm: Vec<u16> = depth
        .iter()
        .map(|&d| {
            if d.is_finite() {
                (d * 1000.0).round().clamp(0.0, 65535.0) as u16
            } else {
                0
            }
        })
        .collect();
    let image =
        image::ImageBuffer::<image::Luma<u16>, _>::from_raw(width as u32, height as u32, mm)
            .expect("sized from the render");
    write_atomically(path, |tmp| {
        image
            .save_with_format(tmp, image::ImageFormat::Png)
            .map_err(std::io::Error::other)
    })
}

fn camera_json(camera: &Camera) -> serde_json::Value {
    json!({
        "fx": camera.fx, "fy": camera.fy, "cx": camera.cx, "cy": camera.cy,
        "width": camera.width, "height": camera.height,
        "world_to_camera": camera.world_to_camera,
    })
}

fn light_json(light: &Option<Light>) -> serde_json::Value {
    match light {
        None => serde_json::Value::Null,
        Some(Light::Directional { direction, color }) => {
            json!({"kind": "directional", "direction": direction, "color": color})
        }
        Some(Light::Point { position, color }) => {
            json!({"kind": "point", "position": position, "color": color})
        }
    }
}

/// The name of a (frame, track) view's files, without extension.
pub fn view_name(scene: &Scene, frame: usize, track: usize) -> String {
    format!("{frame:04}_{}", scene.tracks[track].name)
}

fn scene_json(scene: &Scene, frames: &[usize]) -> serde_json::Value {
    let people: Vec<_> = scene
        .people
        .iter()
        .enumerate()
        .map(|(k, p)| {
            let file = |which: &str| format!("people/person_{k:02}_{which}.npz");
            json!({
                "body_label": body_label(k),
                "accessory_label": accessory_label(k),
                "tracked": p.tracked,
                "clothed": p.clothed,
                "pose_clothing": p.pose_clothing,
                "identity": p.identity,
                "accessories": p.accessories.iter()
                    .map(|a| json!({
                        "kind": a.kind, "joint": a.joint, "grip": a.grip, "swing": a.swing
                    }))
                    .collect::<Vec<_>>(),
                // An untracked person has no pose files.
                "truth": p.tracked.then(|| file("truth")),
                "prior": p.tracked.then(|| file("prior")),
            })
        })
        .collect();
    let tracks: Vec<_> = scene
        .tracks
        .iter()
        .map(|t| {
            json!({
                "name": t.name,
                "cameras": frames.iter().map(|&f| camera_json(&t.cameras[f])).collect::<Vec<_>>(),
            })
        })
        .collect();
    json!({
        "preset": scene.preset,
        "seed": scene.seed,
        "fps": scene.fps,
        "frames": frames,
        "world": "metres, y up, ground at y = 0; cameras OpenCV (x right, y down, z forward)",
        "labels": {"0": "nothing", "1": "surroundings", "2 + 2k": "person k", "3 + 2k": "person k's accessories"},
        "lighting": {
            "ambient": scene.lighting.ambient,
            "light": light_json(&scene.lighting.light),
            "shadow_resolution": scene.lighting.shadow_resolution,
        },
        "prior_noise": scene.noise,
        "prior_corruption": scene.corruption,
        "people": people,
        "tracks": tracks,
    })
}

fn write_view(dir: &Path, name: &str, view: &ViewTruth) -> Result<(), DatasetError> {
    let r = &view.render;
    let (w, h) = (r.width, r.height);
    let at = |sub: &str, ext: &str| dir.join(sub).join(format!("{name}.{ext}"));
    write_rgb_png(&at("images", "png"), w, h, &r.color)?;
    write_rgb_png(&at("images_unshadowed", "png"), w, h, &r.color_unshadowed)?;
    write_mask_png(&at("masks/human", "png"), w, h, &view.human_mask())?;
    write_mask_png(&at("masks/accessory", "png"), w, h, &view.accessory_mask())?;
    write_mask_png(&at("masks/coarse", "png"), w, h, &view.coarse_mask())?;
    let labels = image::GrayImage::from_raw(w as u32, h as u32, r.label.clone())
        .expect("sized from the render");
    write_atomically(&at("labels", "png"), |tmp| {
        labels
            .save_with_format(tmp, image::ImageFormat::Png)
            .map_err(std::io::Error::other)
    })?;
    let depth: Vec<f32> = r
        .depth
        .iter()
        .map(|&d| if d.is_finite() { d } else { 0.0 })
        .collect();
    write_npy_f32(&at("depth", "npy"), &[h as u64, w as u64], &depth)?;
    write_depth_mm(&at("depth_mm", "png"), w, h, &r.depth)?;
    let normals: Vec<f32> = r.normal.iter().flatten().copied().collect();
    write_npy_f32(&at("normals", "npy"), &[h as u64, w as u64, 3], &normals)
}

/// Renders `frames` of every camera of `scene` into `dir` (created if needed); `progress` is
/// called after each frame with the number done.
pub fn write_scene(
    scene: &Scene,
    dir: &Path,
    frames: &[usize],
    mut progress: impl FnMut(usize),
) -> Result<(), DatasetError> {
    for &f in frames {
        assert!(f < scene.frame_count, "frame {f} of {}", scene.frame_count);
    }
    for sub in [
        "images",
        "images_unshadowed",
        "masks/human",
        "masks/accessory",
        "masks/coarse",
        "labels",
        "depth",
        "depth_mm",
        "normals",
        "people",
    ] {
        std::fs::create_dir_all(dir.join(sub)).map_err(|e| io_error(&dir.join(sub), e))?;
    }
    for (k, person) in scene.people.iter().enumerate() {
        if !person.tracked {
            continue;
        }
        let select = |seq: &crate::pose_sequence::PoseSequence| {
            let mut out = seq.clone();
            let j3 = 3 * seq.joints;
            out.poses = frames.iter().flat_map(|&f| seq.pose(f).to_vec()).collect();
            out.translations = frames.iter().flat_map(|&f| seq.translation(f)).collect();
            out.betas = frames
                .iter()
                .flat_map(|&f| seq.frame_betas(f).to_vec())
                .collect();
            debug_assert_eq!(out.poses.len(), frames.len() * j3);
            out
        };
        let people = dir.join("people");
        write_pose_sequence(
            &people.join(format!("person_{k:02}_truth.npz")),
            &select(&person.motion),
        )?;
        write_pose_sequence(
            &people.join(format!("person_{k:02}_prior.npz")),
            &select(&person.prior),
        )?;
    }
    let with_masks = scene.environment.props.is_empty();
    let dynamic = scene.frame_count > 1;
    let mut nerfstudio = Vec::new();
    for (done, &f) in frames.iter().enumerate() {
        for view in scene.render_frame(f) {
            let name = view_name(scene, f, view.track);
            write_view(dir, &name, &view)?;
            nerfstudio.push(NerfstudioFrame {
                file_path: format!("images/{name}.png"),
                mask_path: with_masks.then(|| format!("masks/coarse/{name}.png")),
                depth_file_path: Some(format!("depth_mm/{name}.png")),
                camera: view.camera,
                time: dynamic.then(|| f as f64 / (scene.frame_count - 1) as f64),
            });
        }
        progress(done + 1);
    }
    write_transforms(&dir.join("transforms.json"), &nerfstudio)?;
    let text = serde_json::to_string_pretty(&scene_json(scene, frames)).expect("plain data");
    write_bytes(&dir.join("scene.json"), text.as_bytes())
}
