//! The synthetic capture's prompted identity written as a user's portrait would come
//! ([`crate::photo`]): a PNG from the synthetic portrait camera (40° across) in a standing pose
//! that is not the canonical one, and OpenPose's JSON beside it (BODY_25, the 70 face points and
//! both hands, projected from the true mesh with pixel noise, OpenPose's integer pixel
//! centres). It tries `data.photo` without a user's photo, and grades that path against a truth.

use crate::data::PortraitCapture;
use crate::error::AagError;
use crate::identities::planar_rgb;
use crate::photo::default_keypoints_path;
use crate::portrait_fit::portrait_camera;
use burn::tensor::Device;
use splatzoo_datasets::openpose::{PersonKeypoints, write_keypoints};
use splatzoo_datasets::synth::keypoints::{DetectorNoise, detect, pinhole};
use splatzoo_datasets::synth::rng::Rng;
use splatzoo_datasets::synth::scene::posed_once;
use splatzoo_models::body::builtin_body;
use splatzoo_models::body::fit::{KeypointTarget, PersonTargets};
use std::path::{Path, PathBuf};

/// The photographed pose: arms lowered, elbows bent, the head turned a little, the whole body
/// turned 10° from the camera.
pub fn photo_pose() -> [f64; 72] {
    let mut pose = [0.0; 72];
    let mut set = |joint: usize, v: [f64; 3]| pose[3 * joint..3 * joint + 3].copy_from_slice(&v);
    set(0, [0.0, 0.17, 0.0]);
    set(15, [0.05, 0.1, 0.0]);
    set(16, [0.0, 0.0, -1.1]);
    set(17, [0.0, 0.0, 1.1]);
    set(18, [0.0, -0.4, 0.0]);
    set(19, [0.0, 0.4, 0.0]);
    pose
}

/// Writes `<dir>/portrait.png` (`size`², the prompted identity of the synthetic `capture` in
/// [`photo_pose`]) and `<dir>/portrait_keypoints.json` (its keypoints with `noise_px` of noise,
/// seeded); returns the photo's path.
pub fn write_synthetic_photo(
    capture: &PortraitCapture,
    dir: &Path,
    size: u32,
    noise_px: f64,
    seed: u64,
    device: &Device,
) -> Result<PathBuf, AagError> {
    let truth = capture.truth.as_ref().ok_or_else(|| {
        AagError::input(
            "data.photo",
            "the capture is a user's photo: only the synthetic identities can be written",
        )
    })?;
    let label = capture.config.prompt;
    let bank = &truth.bank;
    let posed = posed_once(
        &bank.identities[label].identity.betas,
        &photo_pose(),
        device,
    );
    let camera = portrait_camera(size);
    let image = planar_rgb(&bank.render_posed(label, &posed.vertices, &camera));
    let plane = (size * size) as usize;
    let bytes: Vec<u8> = (0..plane)
        .flat_map(|p| (0..3).map(move |c| c * plane + p))
        .map(|k| (image[k].clamp(0.0, 1.0) * 255.0).round() as u8)
        .collect();
    std::fs::create_dir_all(dir)
        .map_err(|e| AagError::input(dir.display().to_string(), format!("cannot create ({e})")))?;
    let path = dir.join("portrait.png");
    image::RgbImage::from_raw(size, size, bytes)
        .expect("sized by the render")
        .save(&path)
        .map_err(|e| AagError::input(path.display().to_string(), format!("cannot write ({e})")))?;
    let body = builtin_body();
    let targets = PersonTargets::new(&body.model, |n| body.landmark(n));
    let noise = DetectorNoise {
        pixel_sigma: noise_px,
        miss_rate: 0.0,
    };
    let mut rng = Rng(seed);
    let pinhole = pinhole(&camera);
    let mut points = |slots: &[Option<KeypointTarget>]| -> Vec<[f32; 3]> {
        detect(&posed, slots, &pinhole, None, &noise, &mut rng)
            .into_iter()
            .map(|p| match p {
                Some([x, y]) => [(x - 0.5) as f32, (y - 0.5) as f32, 0.9],
                None => [0.0; 3],
            })
            .collect()
    };
    let person = PersonKeypoints {
        body: points(&targets.body),
        face: points(&targets.face),
        left_hand: points(&targets.left_hand),
        right_hand: points(&targets.right_hand),
    };
    write_keypoints(&default_keypoints_path(&path), &person)
        .map_err(|e| AagError::Train(e.into()))?;
    Ok(path)
}
