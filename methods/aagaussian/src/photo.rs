//! A user's own portrait (§3.2 of AAGaussian: "a portrait image"): a photo file (`data.photo`,
//! PNG or JPEG) and OpenPose's JSON for it (`data.photo_keypoints`; by default
//! `<stem>_keypoints.json` beside the photo, the name OpenPose's `--write_json` gives), run with
//! `--face` (the face crop's alignment needs the face points) and optionally `--hand`.
//!
//! From it come the body prior — the avatar's body model fitted to every keypoint the file
//! gives (BODY_25, face, hands; [`splatzoo_models::body::fit::fit_body`]) with no floor and no
//! truth to grade it — and U8's face crop, cut from the photo by its face points
//! ([`crate::face_align::crop_from_portrait`]). The photo's camera is a pinhole of vertical
//! field of view `data.photo_fovy_degrees` with the principal point at the image centre.
//!
//! A single photo fixes the body's proportions, not its size: the fitted height trades against
//! the distance to the camera, and the shape prior settles it (the avatar is normalised to a
//! fixed extent anyway, HumanGaussian's units).

use crate::body_prior::AvatarBody;
use crate::error::AagError;
use crate::portrait_fit::{PortraitFit, rest_height};
use crate::video_poses::{VideoCamera, observations};
use burn::tensor::Device;
use splatzoo_datasets::openpose::{FACE_POINTS, PersonKeypoints, read_main_person};
use splatzoo_models::body::fit::{FitConfig, TORSO, fit_body};
use std::path::{Path, PathBuf};

/// OpenPose's face points for [`crate::face_align::ALIGNMENT_LANDMARKS`]: the pupils (68 right, 69 left), the nose
/// tip (30), the upper inner lip's middle (62) and the chin (8).
pub const ALIGNMENT_FACE_POINTS: [usize; 5] = [68, 69, 30, 62, 8];

/// A user's portrait read from disk.
#[derive(Debug, Clone)]
pub struct Photo {
    pub path: PathBuf,
    pub keypoints_path: PathBuf,
    /// `[3, H, W]` in [0, 1], as the file's (sRGB) values.
    pub image: Vec<f32>,
    pub width: u32,
    pub height: u32,
    pub keypoints: PersonKeypoints,
    pub camera: VideoCamera,
}

/// Where OpenPose writes the keypoints of `photo`: `<dir>/<stem>_keypoints.json`.
pub fn default_keypoints_path(photo: &Path) -> PathBuf {
    let stem = photo
        .file_stem()
        .map_or_else(String::new, |s| s.to_string_lossy().into_owned());
    photo.with_file_name(format!("{stem}_keypoints.json"))
}

impl Photo {
    /// Reads `path` and its keypoints (`keypoints`, else beside it), seen through a camera of
    /// vertical field of view `fovy_degrees`.
    pub fn read(
        path: &Path,
        keypoints: Option<&Path>,
        fovy_degrees: f64,
    ) -> Result<Self, AagError> {
        let what = path.display().to_string();
        let picture = image::open(path)
            .map_err(|e| AagError::input(what.clone(), format!("cannot read the photo ({e})")))?
            .to_rgb8();
        let (width, height) = picture.dimensions();
        if width < 64 || height < 64 {
            return Err(AagError::input(
                what,
                format!("a {width}×{height} photo: the fit and the face crop need at least 64²"),
            ));
        }
        let plane = (width * height) as usize;
        let mut image = vec![0.0; 3 * plane];
        for (p, pixel) in picture.pixels().enumerate() {
            for c in 0..3 {
                image[c * plane + p] = f32::from(pixel[c]) / 255.0;
            }
        }
        let keypoints_path = keypoints.map_or_else(|| default_keypoints_path(path), Path::to_owned);
        if !keypoints_path.is_file() {
            return Err(AagError::input(
                "data.photo_keypoints",
                format!(
                    "no OpenPose JSON at {} for the photo {what} (run OpenPose with --face \
                     --write_json, or name the file)",
                    keypoints_path.display()
                ),
            ));
        }
        let person = read_main_person(&keypoints_path)
            .map_err(|e| AagError::Train(e.into()))?
            .ok_or_else(|| {
                AagError::input(
                    keypoints_path.display().to_string(),
                    "no person in the keypoint file",
                )
            })?;
        if person.face.len() != FACE_POINTS {
            return Err(AagError::input(
                keypoints_path.display().to_string(),
                "face_keypoints_2d is empty: the face crop is aligned by the 70 face points \
                 (run OpenPose with --face)",
            ));
        }
        let in_frame = person.body.iter().filter(|k| k[2] > 0.0).count();
        if in_frame < 8 {
            return Err(AagError::input(
                keypoints_path.display().to_string(),
                format!(
                    "pose_keypoints_2d has {in_frame} detected points: the body fit needs the \
                     whole person in the photo"
                ),
            ));
        }
        if !(fovy_degrees.is_finite() && fovy_degrees > 1.0 && fovy_degrees < 170.0) {
            return Err(AagError::input(
                "data.photo_fovy_degrees",
                format!("{fovy_degrees}: a vertical field of view in (1°, 170°)"),
            ));
        }
        let focal_px = 0.5 * f64::from(height) / (0.5 * fovy_degrees.to_radians()).tan();
        Ok(Self {
            path: path.to_owned(),
            keypoints_path,
            image,
            width,
            height,
            keypoints: person,
            camera: VideoCamera {
                focal_px,
                width,
                height,
            },
        })
    }

    /// The pixel of each of [`crate::face_align::ALIGNMENT_LANDMARKS`] (this crate's pixel centres at +0.5), `None`
    /// where OpenPose's confidence is below `min_confidence`.
    pub fn face_points(&self, min_confidence: f64) -> [Option<[f64; 2]>; 5] {
        ALIGNMENT_FACE_POINTS.map(|k| {
            let [x, y, confidence] = self.keypoints.face[k];
            (f64::from(confidence) >= min_confidence && confidence > 0.0)
                .then(|| [f64::from(x) + 0.5, f64::from(y) + 0.5])
        })
    }

    /// Fits `avatar`'s body model to every keypoint of the photo (no floor): the shape and how
    /// well the keypoints reproject; nothing to grade it against.
    pub fn fit(&self, avatar: &AvatarBody, device: &Device) -> Result<PortraitFit, AagError> {
        let seen = observations(&avatar.targets(), &self.keypoints);
        let fit = fit_body(
            &avatar.model,
            &seen,
            &self.camera.pinhole(),
            &TORSO,
            &FitConfig::default(),
            None,
            device,
        )
        .map_err(|e| AagError::input(self.keypoints_path.display().to_string(), e.to_string()))?;
        let rest = avatar.posed(&fit.betas, &[0.0; 72], device);
        Ok(PortraitFit {
            rest_height_m: rest_height(&rest.vertices),
            betas: fit.betas,
            reprojection_rms_px: fit.reprojection_rms_px,
            mpjpe_m: None,
            height_error: None,
            keypoints: Some(self.keypoints.clone()),
        })
    }
}
