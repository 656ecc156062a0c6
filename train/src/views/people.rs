//! A capture's person track ([`PoseTrack`]: SMPL-layout parameters per frame, each placed in
//! the format's world by a similarity) as a [`PoseSequence`] for the body model a node skins,
//! in the frame the trainers use.
//!
//! SMPL poses a body as `R_g (x − J₀) + J₀ + transl` (`R_g` the global orientation, `J₀` the
//! rest root joint for the frame's shape); the format then places it by `x_w = s R x + t`. The
//! rotation and translation fold into SMPL's own parameters: `R_g' = R R_g` and
//! `transl' = R (J₀ + transl) + t/s − J₀`. The scale cannot (a body model has no size knob),
//! so the world is rescaled by `1/s` instead: cameras keep their rotations and divide their
//! translations by `s` ([`scale_camera_world`]), which leaves every image unchanged. NeuMan's
//! alignments carry such a scale; a scale that drifts across frames is reported.
//!
//! Frames where the person is invalid take the nearest earlier valid frame's parameters and
//! are flagged, so no image of them is trained on.

use super::DataError;
use splatzoo_datasets::formats::{BodyFrame, Dataset, PoseTrack};
use splatzoo_datasets::pose_sequence::PoseSequence;
use splatzoo_models::body::BodyModel;
use splatzoo_models::rotation_scalar::{axis_angle_matrix, matrix_axis_angle};
use splatzoo_rasterizer::Camera;

/// A person's track ready for a skinned node.
#[derive(Debug, Clone)]
pub struct PersonSequence {
    /// One row per capture frame, on the model's joints and shape coefficients.
    pub sequence: PoseSequence,
    /// Whether the capture has the person at each frame.
    pub valid: Vec<bool>,
    /// The world is scaled by this (`1/s` of the format's similarity); apply it to cameras.
    pub world_scale: f64,
    /// What the conversion decided (printed at start).
    pub notes: Vec<String>,
}

/// Where `model`'s root joint rests for `betas` (zero-padded or cut to the model's count).
pub fn rest_root(model: &BodyModel, betas: &[f64]) -> [f64; 3] {
    let (v, s) = (model.vertex_count(), model.shape_count());
    let mut root = [0.0f64; 3];
    for k in 0..v {
        let weight = model.joint_regressor[k] as f64;
        if weight == 0.0 {
            continue;
        }
        for (a, axis) in root.iter_mut().enumerate() {
            let offset: f64 = (0..s.min(betas.len()))
                .map(|j| model.shape_dirs[(k * 3 + a) * s + j] as f64 * betas[j])
                .sum();
            *axis += weight * (model.template[k * 3 + a] as f64 + offset);
        }
    }
    root
}

fn mat_mul(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
}

fn mat_vec(a: &[[f64; 3]; 3], x: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|i| (0..3).map(|k| a[i][k] * x[k]).sum())
}

/// One frame's SMPL parameters with the format's rotation and translation folded in (world
/// scaled by `world_scale`): `(global orientation, transl)`.
pub fn fold_placement(frame: &BodyFrame, j0: [f64; 3], world_scale: f64) -> ([f64; 3], [f64; 3]) {
    let m = &frame.world_from_smpl;
    let transl = frame.smpl_transl(j0);
    let orient = mat_mul(&m.rotation, &axis_angle_matrix(frame.global_orient));
    let rotated = mat_vec(&m.rotation, std::array::from_fn(|a| j0[a] + transl[a]));
    let placed = std::array::from_fn(|a| rotated[a] + m.translation[a] * world_scale - j0[a]);
    (matrix_axis_angle(&orient), placed)
}

/// A camera of the format's world seen in the world scaled by `scale`.
pub fn scale_camera_world(camera: &Camera, scale: f64) -> Camera {
    let mut out = *camera;
    for row in &mut out.world_to_camera {
        row[3] = (row[3] as f64 * scale) as f32;
    }
    out
}

/// SMPL-X's joints after the 22 body joints, by the parameter that poses them.
const SMPLX_EXTRAS: [(&str, usize); 5] = [
    ("jaw_pose", 1),
    ("leye_pose", 1),
    ("reye_pose", 1),
    ("left_hand_pose", 15),
    ("right_hand_pose", 15),
];

/// A frame's axis-angle rows beyond the root: `body_pose`, completed from the SMPL-X extras
/// when the track holds SMPL-X's 21 body joints and the model has more (SMPL's two hand joints
/// stay at rest; SMPL-H takes the hands; SMPL-X jaw, eyes and hands). Returns the rows and
/// whether something was left at rest for want of a parameter.
fn completed_pose(frame: &BodyFrame, model_joints: usize) -> (Vec<f64>, bool) {
    let mut pose = frame.body_pose.clone();
    if pose.len() != 63 || model_joints <= 22 {
        return (pose, false);
    }
    let extras: &[(&str, usize)] = match model_joints {
        52 => &SMPLX_EXTRAS[3..],
        55 => &SMPLX_EXTRAS,
        _ => &[],
    };
    let mut at_rest = extras.is_empty();
    for &(key, joints) in extras {
        match frame.extra.get(key) {
            Some(values) if values.len() == 3 * joints => pose.extend_from_slice(values),
            _ => {
                pose.extend(std::iter::repeat_n(0.0, 3 * joints));
                at_rest = true;
            }
        }
    }
    pose.resize(3 * (model_joints - 1), 0.0);
    (pose, at_rest)
}

/// Person `person` of `dataset` as a sequence for `model`. With `use_betas` the track's shape
/// coefficients are kept (they mean the model's own only when the model is the one the capture
/// was fitted with); otherwise the rest shape, for the trainer to refine.
pub fn person_sequence(
    dataset: &Dataset,
    person: usize,
    model: &BodyModel,
    use_betas: bool,
) -> Result<PersonSequence, DataError> {
    let root = &dataset.root;
    let track: &PoseTrack = dataset.people.get(person).ok_or_else(|| {
        super::file_error(
            root,
            format!(
                "person {person} asked for, but the {:?} capture has {} pose track(s)",
                dataset.format,
                dataset.people.len()
            ),
        )
    })?;
    let first = track
        .frames
        .iter()
        .position(Option::is_some)
        .ok_or_else(|| {
            super::file_error(
                root,
                format!("person `{}` is valid in no frame", track.person),
            )
        })?;
    let frame_count = dataset.frame_count.max(track.frames.len());
    if track.frames.len() < dataset.frame_count {
        return Err(super::file_error(
            root,
            format!(
                "person `{}`: the pose track has {} frames, the capture {} (expected one row per frame)",
                track.person,
                track.frames.len(),
                dataset.frame_count
            ),
        ));
    }
    let valid: Vec<bool> = track.frames.iter().map(Option::is_some).collect();
    let mut scales: Vec<f64> = track
        .frames
        .iter()
        .flatten()
        .map(|f| f.world_from_smpl.scale)
        .collect();
    scales.sort_by(f64::total_cmp);
    let median = scales[scales.len() / 2];
    if !(median.is_finite() && median > 0.0) {
        return Err(super::file_error(
            root,
            format!(
                "person `{}`: placement scale {median}, expected > 0",
                track.person
            ),
        ));
    }
    let mut notes = Vec::new();
    let spread = scales.last().copied().unwrap_or(median) / scales[0];
    if (median - 1.0).abs() > 1e-9 {
        notes.push(format!(
            "world rescaled by 1/{median:.4} so the body keeps its own size"
        ));
    }
    if spread > 1.01 {
        notes.push(format!(
            "the placement scale varies by {:.1}% across frames; the median is used",
            (spread - 1.0) * 100.0
        ));
    }
    let world_scale = 1.0 / median;
    let first_frame = track.frames[first].as_ref().expect("first valid frame");
    let (first_pose, _) = completed_pose(first_frame, model.joint_count());
    let track_joints = first_pose.len() / 3 + 1;
    let mut rested = false;
    let s = model.shape_count();
    let mut poses = Vec::with_capacity(frame_count * 3 * track_joints);
    let mut translations = Vec::with_capacity(frame_count * 3);
    let mut betas_out = Vec::with_capacity(frame_count * s);
    let mut last = first_frame;
    let mut cached: Option<(Vec<f64>, [f64; 3])> = None;
    for (t, frame) in track.frames.iter().enumerate() {
        let frame = frame.as_ref().unwrap_or(last);
        last = frame;
        let (body_pose, at_rest) = completed_pose(frame, model.joint_count());
        rested |= at_rest;
        if body_pose.len() != 3 * (track_joints - 1) {
            return Err(super::file_error(
                root,
                format!(
                    "person `{}` frame {t}: body_pose has {} values, expected {} (as frame {first})",
                    track.person,
                    frame.body_pose.len(),
                    first_frame.body_pose.len()
                ),
            ));
        }
        let betas: Vec<f64> = (0..s)
            .map(|k| {
                if use_betas {
                    frame.betas.get(k).copied().unwrap_or(0.0)
                } else {
                    0.0
                }
            })
            .collect();
        let j0 = match &cached {
            Some((b, j0)) if *b == betas => *j0,
            _ => {
                let j0 = rest_root(model, &betas);
                cached = Some((betas.clone(), j0));
                j0
            }
        };
        let (orient, transl) = fold_placement(frame, j0, world_scale);
        poses.extend_from_slice(&orient);
        poses.extend_from_slice(&body_pose);
        translations.extend_from_slice(&transl);
        betas_out.extend_from_slice(&betas);
    }
    let sequence = PoseSequence {
        joints: track_joints,
        poses,
        translations,
        betas: betas_out,
        shape_count: s,
        fps: None,
    }
    .for_model(model.joint_count(), model.shape_count(), root)?;
    if rested {
        notes.push(
            "joints the track does not pose (hands, jaw, eyes without their parameters) kept at rest".into(),
        );
    }
    if track_joints != model.joint_count() {
        notes.push(format!(
            "the track's {track_joints} joints drive the model's {} (body joints kept)",
            model.joint_count()
        ));
    }
    Ok(PersonSequence {
        sequence,
        valid,
        world_scale,
        notes,
    })
}
