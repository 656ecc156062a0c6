//! A capture on disk as Illum's video (`data.capture`): NeuMan folders (with their depth maps),
//! ZJU-MoCap and every other format the loaders read with person masks and a pose track, through
//! the engine's avatar bridge ([`splatzoo_train::avatar::capture::load`]), the same reader
//! `train-avatar` uses.
//!
//! - **Frames**: the bridge's training views are the trained frames; its held-out frames (the
//!   capture's own test split, e.g. NeuMan's `test_split.txt`, else every `data.test_every`-th
//!   frame) and its novel views (cameras outside `data.train_cameras`, at every 4th training
//!   frame) are the held-out frames Illum scores. Images are box-filtered by `data.downscale`
//!   and undistorted (the pixels left empty count in no loss or score:
//!   [`IllumFrame::on_real_pixels`]); frames where the person has no fit are dropped.
//! - **Units**: the person's track is folded into the world and the world rescaled so the body
//!   keeps its own size in metres (NeuMan's alignment scale, [`splatzoo_train::views::people`]);
//!   cameras, scene points and depth maps follow, so the light volume's spacing and padding (in
//!   body heights) mean what they mean on the synthetic capture.
//! - **The body**: the built-in body driven by the track's SMPL-layout pose; a fit's SMPL shape
//!   coefficients mean nothing to it, so it starts from its rest shape and stage 1's F_Δ
//!   refines it (the bridge's rule).
//! - **Depth** for the background depth term: the view's depth map where the capture gives
//!   one (NeuMan's `depth_maps/`), unknown elsewhere (the term then compares nothing there).
//! - **Scene points**: the capture's sparse points, else its depth maps outside the person
//!   (the bridge's choice), else random points in the training cameras' box (3DGS's fallback).
//! - **Background colour**: the mean of the training frames' pixels off the person.
//! - **No truth**: a capture on disk has no albedo buffer, person-free view, relit frames,
//!   novel-pose clip or analytic light, so those scores are absent (`IllumScores::truth`) and
//!   the shadow decoder's rule, which needs the person-free view, builds it (the paper's full
//!   model) unless `ablation.shadow` says otherwise ([`crate::needs`]).
//!
//! [`write_as_neuman`] writes the synthetic capture's video as such a folder, every value
//! known, to try and test this path without NeuMan's data.

use crate::IllumError;
use crate::data::{IllumCapture, IllumDataConfig, IllumFrame};
use burn::tensor::Device;
use splatzoo_datasets::formats::Similarity;
use splatzoo_datasets::formats::neuman_writer::{NeumanFrame, write_neuman_scene};
use splatzoo_datasets::masks::Mask;
use splatzoo_models::body::builtin_body;
use splatzoo_train::avatar::capture::load;
use splatzoo_train::avatar::data::AvatarDataConfig;
use splatzoo_train::host_f32;
use splatzoo_train::views::init_points::random_points;
use splatzoo_train::views::people::scale_camera_world;
use splatzoo_train::views::{ColourSum, Frame};
use std::path::Path;

/// NeuMan's fits carry SMPL's 10 shape coefficients.
pub const NEUMAN_BETAS: usize = 10;

/// Reads the capture at `path` as [`IllumCapture`] (the module docs say how).
pub fn read_capture(
    config: &IllumDataConfig,
    path: &Path,
    device: &Device,
) -> Result<IllumCapture, IllumError> {
    let bridge = AvatarDataConfig {
        path: Some(path.to_path_buf()),
        format: config.format.clone(),
        person: config.person,
        train_cameras: config.train_cameras.clone(),
        downscale: config.downscale,
        holdout_every: config.test_every,
        ..AvatarDataConfig::default()
    };
    let body = builtin_body();
    let avatar = load(&bridge, &body.model, device)?;
    let mut frames = Vec::new();
    let mut background = ColourSum::default();
    let mut with_depth = 0;
    for (views, held_out) in [
        (&avatar.train, false),
        (&avatar.novel_pose, true),
        (&avatar.novel_view, true),
    ] {
        for view in views {
            let Frame {
                image,
                person: mask,
                valid,
            } = avatar
                .store
                .frame(view.key)
                .map_err(splatzoo_train::TrainError::from)?;
            let mask = mask.ok_or_else(|| {
                IllumError::input(view.name.clone(), "no person mask beside the image")
            })?;
            let [h, w, _] = image.dims();
            let person: Vec<bool> = host_f32(&mask).iter().map(|&m| m > 0.5).collect();
            if !person.iter().any(|&p| p) {
                return Err(IllumError::input(
                    view.name.clone(),
                    "the person mask has no person pixel",
                ));
            }
            let depth = match avatar.depth(view)? {
                Some(depth) => {
                    with_depth += usize::from(!held_out);
                    depth
                }
                None => vec![f32::NAN; w * h],
            };
            if !held_out {
                let off_person = Mask::new(w, h, person.clone());
                background.add(&host_f32(&image), Some(&off_person));
            }
            frames.push(IllumFrame {
                frame: view.frame,
                held_out,
                camera: view.camera,
                image,
                mask,
                depth,
                person,
                valid,
                truth: None,
            });
        }
    }
    // Time order, each frame's trained views before its held-out ones.
    frames.sort_by_key(|f| (f.frame, f.held_out));
    let trained = avatar.train.len();
    if avatar.novel_pose.is_empty() && avatar.novel_view.is_empty() {
        return Err(IllumError::input(
            path.display().to_string(),
            "no held-out frame to score (the capture's split holds out nothing; set \
             data.test_every or give a test split)",
        ));
    }
    let mut decisions = avatar.decisions.clone();
    let (scene_points, source) = if avatar.scenery_points.is_empty() {
        let cameras: Vec<_> = frames
            .iter()
            .filter(|f| !f.held_out)
            .map(|f| f.camera)
            .collect();
        (
            random_points(&cameras, config.scene_points, config.seed ^ 0xD15C),
            "random points in the training cameras' box (the capture has neither sparse points \
             nor depth)",
        )
    } else {
        (
            avatar
                .scenery_points
                .clone()
                .thinned(config.scene_points, config.seed ^ 0xD15C),
            avatar.scenery_source.unwrap_or("the capture"),
        )
    };
    decisions.push(format!(
        "scene: {} points from {source}; background colour {:.3?} (the training frames off the \
         person)",
        scene_points.len(),
        background.mean()
    ));
    decisions.push(format!(
        "depth maps for the background depth term: {with_depth} of {trained} training views"
    ));
    decisions.push(
        "no truth on disk: albedo, relit, shadow-region, novel-pose and probe scores are not \
         computed"
            .into(),
    );
    Ok(IllumCapture {
        config: config.clone(),
        frames,
        prior: avatar.prior.clone(),
        scene_points,
        background: background.mean(),
        decisions,
        truth: None,
    })
}

/// Writes the synthetic `capture`'s video as a NeuMan scene under `root` whose COLMAP world
/// is the capture's metres times `scale` (a real reconstruction's unit is arbitrary): images,
/// person masks, cameras, the scene points, depth maps (`depth_maps/`, scaled alike), the
/// prior track as SMPL's pose with the alignment `s = scale`, `R = I`, `t = scale ·
/// translation` (the first [`NEUMAN_BETAS`] shape coefficients), and the held-out frames as
/// the test split. [`read_capture`] reads back the same cameras, masks, images (to 8 bits),
/// depth and track, in metres. Only the synthetic capture (one view a frame, frame `k` the
/// `k`-th) is written.
pub fn write_as_neuman(capture: &IllumCapture, root: &Path, scale: f64) -> Result<(), IllumError> {
    let one_view_a_frame = capture.frames.iter().enumerate().all(|(k, f)| f.frame == k);
    if capture.truth.is_none() || !one_view_a_frame {
        return Err(IllumError::input(
            "capture",
            "only the synthetic capture (one view a frame, in order) is written as NeuMan",
        ));
    }
    let prior = &capture.prior;
    if prior.joints != 24 || prior.shape_count < NEUMAN_BETAS {
        return Err(IllumError::input(
            "prior track",
            format!(
                "{} joints and {} shape coefficients; NeuMan's SMPL fits take 24 and \
                 {NEUMAN_BETAS}",
                prior.joints, prior.shape_count
            ),
        ));
    }
    if !(scale.is_finite() && scale > 0.0) {
        return Err(IllumError::input("scale", format!("{scale}, expected > 0")));
    }
    let s = scale as f32;
    let frames: Vec<NeumanFrame> = capture
        .frames
        .iter()
        .map(|frame| {
            let camera = scale_camera_world(&frame.camera, scale);
            let t = frame.frame;
            NeumanFrame {
                camera,
                rgb: host_f32(&frame.image)
                    .iter()
                    .map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8)
                    .collect(),
                person: frame.person.clone(),
                pose: prior.pose(t).to_vec(),
                betas: prior.frame_betas(t)[..NEUMAN_BETAS].to_vec(),
                alignment: Similarity {
                    scale,
                    rotation: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
                    translation: prior.translation(t).map(|v| v * scale),
                },
                depth: Some(frame.depth.iter().map(|&d| d * s).collect()),
            }
        })
        .collect();
    let mut points = capture.scene_points.clone();
    points.positions.iter_mut().flatten().for_each(|v| *v *= s);
    let test: Vec<usize> = (0..frames.len())
        .filter(|&k| capture.frames[k].held_out)
        .collect();
    write_neuman_scene(root, &frames, &points.to_sparse(), &test)
        .map_err(|e| IllumError::Train(e.into()))
}
