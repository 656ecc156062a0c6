//! Poses from a motion video (§3.4 of AAGaussian: OpenPose on every frame, then a body fit per
//! frame): a folder of OpenPose JSON files, one per frame (body, and face and hands where
//! present), fitted frame by frame by
//! [`splatzoo_models::body::fit::fit_sequence`] (the first frame in full, each next one from
//! the previous with the shape held) into a pose sequence that drives the avatar. The fit is
//! of the avatar's own body model ([`AvatarBody`]: the built-in body or a user's SMPL-family
//! body); the
//! sequence keeps the 22 body joints in the SMPL layout the animation reads.
//!
//! The video's camera: a pinhole of focal length `focal_px` with the principal point at the
//! image centre, at the world origin looking down −z with +y up (the world the fitted root
//! orientation is expressed in; the avatar is driven by the 21 body joints only, \[P\]).

use crate::animate::JOINTS;
use crate::body_prior::AvatarBody;
use crate::error::AagError;
use burn::tensor::Device;
use splatzoo_datasets::openpose::{PersonKeypoints, keypoint_files, read_main_person};
use splatzoo_datasets::pose_sequence::PoseSequence;
use splatzoo_models::body::fit::{
    BodyFit, FitConfig, Observation, PersonTargets, PinholeCamera, TORSO, fit_sequence,
};
use std::path::Path;

/// The video camera's intrinsics.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VideoCamera {
    pub focal_px: f64,
    pub width: u32,
    pub height: u32,
}

impl VideoCamera {
    /// The pinhole at the origin looking down −z, +y up, image y down.
    pub fn pinhole(&self) -> PinholeCamera {
        PinholeCamera {
            fx: self.focal_px,
            fy: self.focal_px,
            cx: 0.5 * f64::from(self.width),
            cy: 0.5 * f64::from(self.height),
            world_to_camera: [
                [1.0, 0.0, 0.0, 0.0],
                [0.0, -1.0, 0.0, 0.0],
                [0.0, 0.0, -1.0, 0.0],
            ],
        }
    }
}

/// OpenPose puts pixel centres on integers; the cameras here put them at +0.5.
const OPENPOSE_PIXEL_CENTRE: f32 = 0.5;

/// One frame's keypoints (BODY_25, and the face and hands where the file has them) as
/// observations of the body `targets` marks, moved to this crate's pixel centres.
pub fn observations(targets: &PersonTargets, person: &PersonKeypoints) -> Vec<Observation> {
    let centred = |points: &[[f32; 3]]| -> Vec<[f32; 3]> {
        points
            .iter()
            .map(|k| {
                [
                    k[0] + OPENPOSE_PIXEL_CENTRE,
                    k[1] + OPENPOSE_PIXEL_CENTRE,
                    k[2],
                ]
            })
            .collect()
    };
    targets.observations(
        &centred(&person.body),
        &centred(&person.face),
        &centred(&person.left_hand),
        &centred(&person.right_hand),
    )
}

/// Fits `body` to every frame of `dir` and returns the driving sequence (24 joints, no
/// translation) and each frame's fit.
pub fn poses_from_keypoints(
    body: &AvatarBody,
    dir: &Path,
    camera: VideoCamera,
    fps: f64,
    device: &Device,
) -> Result<(PoseSequence, Vec<BodyFit>), AagError> {
    let dataset = |e| AagError::Train(splatzoo_train::TrainError::Dataset(e));
    let files = keypoint_files(dir).map_err(dataset)?;
    let mut frames = Vec::with_capacity(files.len());
    let targets = body.targets();
    for file in &files {
        let person = read_main_person(file).map_err(dataset)?.ok_or_else(|| {
            AagError::input(file.display().to_string(), "no person in this frame")
        })?;
        frames.push(observations(&targets, &person));
    }
    let model = &body.model;
    let fits = fit_sequence(
        model,
        &frames,
        &camera.pinhole(),
        &TORSO,
        &FitConfig::default(),
        device,
    )
    .map_err(|e| AagError::input(dir.display().to_string(), e.to_string()))?;
    let shape_count = model.shape_count();
    let mut sequence = PoseSequence {
        joints: JOINTS,
        poses: Vec::with_capacity(fits.len() * 3 * JOINTS),
        translations: vec![0.0; 3 * fits.len()],
        betas: Vec::with_capacity(fits.len() * shape_count),
        shape_count,
        fps: Some(fps),
    };
    for fit in &fits {
        sequence.poses.extend_from_slice(&body.smpl_pose(&fit.pose));
        sequence.betas.extend_from_slice(&fit.betas);
    }
    Ok((sequence, fits))
}
