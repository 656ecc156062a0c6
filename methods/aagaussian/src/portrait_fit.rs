//! The body prior from the portrait (§3.2 of AAGaussian; spec §7): the prompted identity
//! photographed from the front in its canonical pose by a known camera, its BODY_25 keypoints
//! projected from the true mesh with pixel noise (what an OpenPose detector would give), and
//! the keypoint fit of [`splatzoo_models::body::fit`] recovering the shape of the avatar's body
//! model ([`AvatarBody`]: the built-in body, or a user's SMPL-family body) with the floor
//! known. The
//! avatar's canonical mesh is the fitted body, never the true one; the identity's truth only
//! grades the fit (its joints against the fitted model's first 22, which every SMPL-layout body
//! shares).

use crate::body_prior::AvatarBody;
use crate::error::AagError;
use burn::tensor::Device;
use serde::{Deserialize, Serialize};
use splatzoo_datasets::openpose::PersonKeypoints;
use splatzoo_datasets::synth::keypoints::{DetectorNoise, detect, pinhole};
use splatzoo_datasets::synth::rng::Rng;
use splatzoo_datasets::synth::scene::posed_once;
use splatzoo_models::body::builtin_body;
use splatzoo_models::body::fit::{
    FitConfig, KeypointTarget, PersonTargets, TORSO, fit_body, foot_targets,
};
use splatzoo_rasterizer::Camera;

/// How the portrait's body was fitted, and how well (against the identity's truth).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PortraitFit {
    pub betas: Vec<f64>,
    pub reprojection_rms_px: f64,
    /// The fitted body's rest height, metres.
    pub rest_height_m: f64,
    /// Mean 3-D error of the 22 body joints in the portrait's pose, metres (none for a user's
    /// photo: no truth).
    pub mpjpe_m: Option<f64>,
    /// Fitted rest height (of the avatar's body model) over true rest height, minus 1 (none for
    /// a user's photo).
    pub height_error: Option<f64>,
    /// The keypoints the fit saw (BODY_25; confidence 0 where the body marks nothing).
    #[serde(skip)]
    pub keypoints: Option<PersonKeypoints>,
}

/// Where the portrait camera stands and looks (metres, body space), and its field of view.
pub const PORTRAIT_EYE: [f32; 3] = [0.0, -0.1, 3.2];
pub const PORTRAIT_TARGET: [f32; 3] = [0.0, -0.1, 0.0];
pub const PORTRAIT_FOVY_DEGREES: f32 = 40.0;

/// The portrait camera: front, 3.2 m away at chest height, 40° across, `size`² pixels.
pub fn portrait_camera(size: u32) -> Camera {
    Camera::look_at(
        PORTRAIT_EYE,
        PORTRAIT_TARGET,
        [0.0, 1.0, 0.0],
        PORTRAIT_FOVY_DEGREES,
        size,
        size,
    )
}

/// Top to bottom of `vertices`, along +y.
pub(crate) fn rest_height(vertices: &[[f32; 3]]) -> f64 {
    let (lo, hi) = vertices
        .iter()
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), v| {
            (a.min(v[1]), b.max(v[1]))
        });
    f64::from(hi - lo)
}

/// Fits `avatar`'s body model to an identity of shape `betas` (on the built-in body) seen in
/// `pose` from a `size`² front portrait with keypoint noise `noise_px` (seeded).
pub fn fit_portrait(
    avatar: &AvatarBody,
    betas: &[f64],
    pose: &[f64; 72],
    size: u32,
    noise_px: f64,
    seed: u64,
    device: &Device,
) -> Result<PortraitFit, AagError> {
    let body = builtin_body();
    let truth = posed_once(betas, pose, device);
    let camera = pinhole(&portrait_camera(size));
    let point = |t: KeypointTarget| -> [f64; 3] {
        t.locate(
            |j| truth.joints[j].map(f64::from),
            |v| truth.vertices[v].map(f64::from),
        )
    };
    let noise = DetectorNoise {
        pixel_sigma: noise_px,
        miss_rate: 0.0,
    };
    // BODY_25 only, as the default run's figures were measured with (the fit reads face and
    // hand points where a detector gives them: `video_poses`).
    let seen = PersonTargets::new(&body.model, |n| body.landmark(n));
    let detected = detect(&truth, &seen.body, &camera, None, &noise, &mut Rng(seed));
    let keypoints = PersonKeypoints {
        body: seen
            .body
            .iter()
            .zip(detected)
            .map(|(target, pixel)| match (target, pixel) {
                (Some(_), Some(pixel)) => [pixel[0] as f32, pixel[1] as f32, 0.9],
                _ => [0.0; 3],
            })
            .collect(),
        face: Vec::new(),
        left_hand: Vec::new(),
        right_hand: Vec::new(),
    };
    let ground = foot_targets(|n| body.landmark(n))
        .iter()
        .map(|&f| point(f)[1])
        .fold(f64::INFINITY, f64::min);
    // The detector saw the identity; the fit reads the same pixels as marks of the avatar's
    // body.
    let observations = avatar.targets().observations(
        &keypoints.body,
        &keypoints.face,
        &keypoints.left_hand,
        &keypoints.right_hand,
    );
    let feet = foot_targets(|n| avatar.landmark(n));
    let config = FitConfig {
        ground: Some(ground),
        feet,
        ..FitConfig::default()
    };
    let fit = fit_body(
        &avatar.model,
        &observations,
        &camera,
        &TORSO,
        &config,
        None,
        device,
    )
    .map_err(|e| AagError::input("portrait keypoints", e.to_string()))?;
    let fitted = avatar.posed(&fit.betas, &avatar.smpl_pose(&fit.pose), device);
    let fitted_rest = avatar.posed(&fit.betas, &[0.0; 72], device);
    let mpjpe_m = (0..22)
        .map(|j| {
            let (a, b) = (fitted.joints[j], truth.joints[j]);
            (0..3)
                .map(|k| (f64::from(a[k]) + fit.translation[k] - f64::from(b[k])).powi(2))
                .sum::<f64>()
                .sqrt()
        })
        .sum::<f64>()
        / 22.0;
    let rest_height_m = rest_height(&fitted_rest.vertices);
    Ok(PortraitFit {
        height_error: Some(
            rest_height_m / rest_height(&posed_once(betas, &[0.0; 72], device).vertices) - 1.0,
        ),
        rest_height_m,
        betas: fit.betas,
        reprojection_rms_px: fit.reprojection_rms_px,
        mpjpe_m: Some(mpjpe_m),
        keypoints: Some(keypoints),
    })
}
