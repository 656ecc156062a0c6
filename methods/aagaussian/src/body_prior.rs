//! The avatar's body model (§3.2 of AAGaussian: SMPL-X in the paper): the built-in body by
//! default, or a user's SMPL / SMPL-H / SMPL-X file (`data.body_model`) with its surface marks
//! (the SMPL-family tables of [`splatzoo_models::body::marks`], or `data.body_marks` for any
//! other mesh). The method works in 72-D SMPL-layout poses (HumanGaussian's canonical A-pose,
//! the 21 driving body joints of U9): on a bigger skeleton the first 22 joints are the body's
//! and the hands, jaw and eyes stay at rest.
//!
//! The synthetic identities the oracle is made of stay on the built-in body: a user's body is
//! fitted to their keypoints like any detector's output, so the held-out scores still compare
//! the avatar against a truth no part of the pipeline rendered with the splat rasterizer.

use crate::error::AagError;
use burn::tensor::Device;
use splatzoo_datasets::pose_sequence::PoseSequence;
use splatzoo_datasets::posing::{PosedFrame, pose_frames_with_joints};
use splatzoo_models::body::fit::PersonTargets;
use splatzoo_models::body::{BodyModel, SurfaceMarks, builtin_body, load_body_model};
use std::path::Path;

/// Values of a 72-D pose the 22 body joints take.
const BODY_POSE_VALUES: usize = 66;

/// A body model with what the face loss and keypoint fits need of its surface.
#[derive(Debug, Clone)]
pub struct AvatarBody {
    pub model: BodyModel,
    pub marks: SurfaceMarks,
    /// `[F]` triangles of the model.
    pub faces: Vec<[u32; 3]>,
    /// Where the model came from (`built-in` or the file).
    pub source: String,
}

impl AvatarBody {
    /// The built-in body.
    pub fn builtin() -> Self {
        Self::new(
            builtin_body().model.clone(),
            SurfaceMarks::builtin(),
            "built-in".into(),
        )
    }

    /// The built-in body, or the model at `model` with the marks of `marks` (else its family's
    /// table). A marks file without a model is refused: it would mark the built-in body.
    pub fn load(model: Option<&Path>, marks: Option<&Path>) -> Result<Self, AagError> {
        let body_error = |e: splatzoo_models::body::BodyModelError| {
            AagError::input("data.body_model", e.to_string())
        };
        match (model, marks) {
            (None, None) => Ok(Self::builtin()),
            (None, Some(path)) => Err(AagError::input(
                "data.body_marks",
                format!(
                    "{} marks a user's body model: set data.body_model too",
                    path.display()
                ),
            )),
            (Some(path), marks) => {
                let loaded = load_body_model(path).map_err(body_error)?;
                if loaded.joint_count() < 22 {
                    return Err(AagError::input(
                        path.display().to_string(),
                        format!(
                            "{} joints: the avatar needs an SMPL-layout body (the 22 body joints first)",
                            loaded.joint_count()
                        ),
                    ));
                }
                let marks = match marks {
                    Some(file) => SurfaceMarks::from_file(&loaded, file),
                    None => SurfaceMarks::for_model(&loaded, &path.display().to_string()),
                }
                .map_err(body_error)?;
                Ok(Self::new(loaded, marks, path.display().to_string()))
            }
        }
    }

    fn new(model: BodyModel, marks: SurfaceMarks, source: String) -> Self {
        let faces = model.faces.chunks(3).map(|f| [f[0], f[1], f[2]]).collect();
        Self {
            model,
            marks,
            faces,
            source,
        }
    }

    pub fn landmark(&self, name: &str) -> Option<u32> {
        self.marks.landmark(name)
    }

    /// What an OpenPose person (body, face, hands) marks on this body.
    pub fn targets(&self) -> PersonTargets {
        PersonTargets::new(&self.model, |n| self.landmark(n))
    }

    /// A full pose vector of this model from a 72-D SMPL-layout pose (module doc).
    pub fn pose_vector(&self, pose: &[f64; 72]) -> Vec<f64> {
        let j3 = 3 * self.model.joint_count();
        if j3 == 72 {
            return pose.to_vec();
        }
        let mut full = vec![0.0; j3];
        full[..BODY_POSE_VALUES].copy_from_slice(&pose[..BODY_POSE_VALUES]);
        full
    }

    /// The 72-D SMPL-layout pose of this model's full pose vector (hands at rest where the
    /// model's joints 22 and 23 are not SMPL's hands).
    pub fn smpl_pose(&self, full: &[f64]) -> [f64; 72] {
        let mut pose = [0.0; 72];
        let keep = if self.model.joint_count() == 24 {
            72
        } else {
            BODY_POSE_VALUES
        };
        pose[..keep].copy_from_slice(&full[..keep]);
        pose
    }

    /// The body of shape `betas` (cut or zero-padded to the model's count) in `pose`, at the
    /// origin.
    pub fn posed(&self, betas: &[f64], pose: &[f64; 72], device: &Device) -> PosedFrame {
        let shape_count = self.model.shape_count();
        let mut shape = vec![0.0; shape_count];
        let keep = shape_count.min(betas.len());
        shape[..keep].copy_from_slice(&betas[..keep]);
        let sequence = PoseSequence {
            joints: self.model.joint_count(),
            poses: self.pose_vector(pose),
            translations: vec![0.0; 3],
            betas: shape,
            shape_count,
            fps: None,
        };
        pose_frames_with_joints(&self.model, &sequence, device)
            .pop()
            .expect("one frame")
    }
}
