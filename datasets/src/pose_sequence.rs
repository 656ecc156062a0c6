//! SMPL-layout pose sequences in the AMASS `.npz` layout.
//!
//! Keys read:
//! - `poses` `[T, 3J]`: axis-angle per joint in the model's joint order, joint 0 the global
//!   orientation (72 for SMPL, 156 for SMPL-H, 165 for SMPL-X);
//! - `trans` `[T, 3]` (also accepted: `transl`, `translations`), metres; zeros when absent;
//! - `betas` `[S]` (one shape for the sequence, as AMASS) or `[T, S]`; zeros when absent;
//! - `mocap_framerate` or `mocap_frame_rate` (scalar), optional.
//!
//! A sequence made for a bigger skeleton drives a smaller one the way AMASS users do: an SMPL-H
//! or SMPL-X sequence on a 24-joint body keeps its 22 body joints and leaves the two hand joints
//! at rest; an SMPL sequence drives SMPL-H/X by its 22 body joints, the rest at rest. Anything
//! else that does not fit is an error naming the key and the shape expected.

use crate::DatasetError;
use crate::files::write_atomically;
use npyz::WriterBuilder;
use npyz::npz::{NpzArchive, NpzWriter};
use splatzoo_models::body::npz::{Array, decode_npy};
use std::path::Path;

/// A pose sequence, row-major, `f64`.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseSequence {
    /// Joints per frame (`poses` has `3 J` columns).
    pub joints: usize,
    /// `[T, 3J]` axis-angle.
    pub poses: Vec<f64>,
    /// `[T, 3]` global translation.
    pub translations: Vec<f64>,
    /// Shape coefficients per frame, `[T, S]`.
    pub betas: Vec<f64>,
    pub shape_count: usize,
    pub fps: Option<f64>,
}

impl PoseSequence {
    pub fn frames(&self) -> usize {
        self.translations.len() / 3
    }

    /// Frame `t`'s pose vector.
    pub fn pose(&self, t: usize) -> &[f64] {
        &self.poses[t * 3 * self.joints..(t + 1) * 3 * self.joints]
    }

    pub fn translation(&self, t: usize) -> [f64; 3] {
        [
            self.translations[3 * t],
            self.translations[3 * t + 1],
            self.translations[3 * t + 2],
        ]
    }

    pub fn frame_betas(&self, t: usize) -> &[f64] {
        &self.betas[t * self.shape_count..(t + 1) * self.shape_count]
    }

    /// This sequence for a model with `joints` joints and `shape_count` shape coefficients:
    /// the SMPL-H/X → SMPL body-joint mapping described in the module doc, and betas cut or
    /// zero-padded to the model's count. `file` names the source in errors.
    pub fn for_model(
        &self,
        joints: usize,
        shape_count: usize,
        file: &Path,
    ) -> Result<Self, DatasetError> {
        let t = self.frames();
        let poses = if self.joints == joints {
            self.poses.clone()
        } else if joints == 24 && (self.joints == 52 || self.joints == 55) {
            let mut out = vec![0.0; t * 72];
            for f in 0..t {
                out[f * 72..f * 72 + 66].copy_from_slice(&self.pose(f)[..66]);
            }
            out
        } else if self.joints == 24 && (joints == 52 || joints == 55) {
            // An SMPL-layout sequence on SMPL-H/X: the 22 body joints, hands (and SMPL-X's jaw
            // and eyes) at rest.
            let mut out = vec![0.0; t * 3 * joints];
            for f in 0..t {
                out[f * 3 * joints..f * 3 * joints + 66].copy_from_slice(&self.pose(f)[..66]);
            }
            out
        } else {
            return Err(DatasetError::field(
                file,
                "poses",
                format!(
                    "[T, {}] poses cannot drive a {joints}-joint model: expected [T, {}]",
                    3 * self.joints,
                    3 * joints
                ),
            ));
        };
        let mut betas = vec![0.0; t * shape_count];
        let keep = shape_count.min(self.shape_count);
        for f in 0..t {
            betas[f * shape_count..f * shape_count + keep]
                .copy_from_slice(&self.frame_betas(f)[..keep]);
        }
        Ok(Self {
            joints,
            poses,
            translations: self.translations.clone(),
            betas,
            shape_count,
            fps: self.fps,
        })
    }
}

/// Which world axis is up in a pose file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum UpAxis {
    /// AMASS and most mocap releases.
    Z,
    /// Already in the bodies' frame (the `synth` command's tracks, refined tracks).
    Y,
}

/// A pose file made to drive a body of `joints` joints and `shape_count` shape coefficients:
/// read, fitted to the body ([`PoseSequence::for_model`]) and turned to the bodies' y-up world.
pub fn load_driving_sequence(
    path: &Path,
    joints: usize,
    shape_count: usize,
    up: UpAxis,
) -> Result<PoseSequence, DatasetError> {
    let fitted = load_pose_sequence(path)?.for_model(joints, shape_count, path)?;
    Ok(match up {
        UpAxis::Z => fitted.rotated_world(Z_UP_TO_Y_UP),
        UpAxis::Y => fitted,
    })
}

/// AMASS's world (z up) to the bodies' world (y up): `(x, y, z) → (x, z, −y)`, a −90° turn
/// about x.
pub const Z_UP_TO_Y_UP: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]];

impl PoseSequence {
    /// The sequence seen in a world turned by `rotation` about its origin: every root
    /// orientation (joint 0) pre-multiplied by it and every translation rotated. (A body's root
    /// turns about its pelvis, not the origin, so absolute placement moves by the rotated pelvis
    /// offset; callers that keep the body in place use relative translations.)
    pub fn rotated_world(&self, rotation: [[f64; 3]; 3]) -> Self {
        use splatzoo_models::rotation_scalar::{axis_angle_matrix, matrix_axis_angle};
        let mut out = self.clone();
        let r = rotation;
        for t in 0..self.frames() {
            let root = axis_angle_matrix(self.pose(t)[..3].try_into().expect("3 values"));
            let turned: [[f64; 3]; 3] = std::array::from_fn(|i| {
                std::array::from_fn(|j| (0..3).map(|k| r[i][k] * root[k][j]).sum())
            });
            let row = t * 3 * self.joints;
            out.poses[row..row + 3].copy_from_slice(&matrix_axis_angle(&turned));
            let tr = self.translation(t);
            for (i, row) in r.iter().enumerate() {
                out.translations[3 * t + i] = (0..3).map(|k| row[k] * tr[k]).sum();
            }
        }
        out
    }
}

impl PoseSequence {
    /// The sequence turned by `yaw_degrees` about the vertical (y) axis and moved along the
    /// floor so that its first frame's root translation has `(x, z) = at`, its height kept: the
    /// motion relative to its start is the same walk turned by the yaw. (The pelvis sits at
    /// the rest pelvis plus the translation, and the rest pelvis's `x, z` are within a few
    /// millimetres of zero on SMPL-family bodies, so the pelvis lands there too.)
    pub fn placed(&self, at: [f64; 2], yaw_degrees: f64) -> Self {
        let mut out = if yaw_degrees == 0.0 {
            self.clone() // exactly: no round trip through rotation matrices
        } else {
            let (sin, cos) = yaw_degrees.to_radians().sin_cos();
            self.rotated_world([[cos, 0.0, sin], [0.0, 1.0, 0.0], [-sin, 0.0, cos]])
        };
        if out.frames() > 0 {
            let start = out.translation(0);
            let shift = [at[0] - start[0], at[1] - start[2]];
            for t in 0..out.frames() {
                out.translations[3 * t] += shift[0];
                out.translations[3 * t + 2] += shift[1];
            }
        }
        out
    }

    /// Frames `frames` of this sequence, in that order (each index below [`Self::frames`]).
    pub fn frames_subset(&self, frames: &[usize]) -> Self {
        let mut out = Self {
            poses: Vec::with_capacity(frames.len() * 3 * self.joints),
            translations: Vec::with_capacity(frames.len() * 3),
            betas: Vec::with_capacity(frames.len() * self.shape_count),
            joints: self.joints,
            shape_count: self.shape_count,
            fps: self.fps,
        };
        for &f in frames {
            out.poses.extend_from_slice(self.pose(f));
            out.translations.extend(self.translation(f));
            out.betas.extend_from_slice(self.frame_betas(f));
        }
        out
    }

    /// `frames` frames of this sequence, looping (frame `f` is frame `f mod T`), each with the
    /// shape `betas` (the driven body's own, not the sequence's). `None` for an empty sequence.
    pub fn looped(&self, frames: usize, betas: &[f64]) -> Option<Self> {
        let t = self.frames();
        if t == 0 {
            return None;
        }
        let width = 3 * self.joints;
        let mut out = Self {
            joints: self.joints,
            poses: Vec::with_capacity(frames * width),
            translations: Vec::with_capacity(frames * 3),
            betas: Vec::with_capacity(frames * betas.len()),
            shape_count: betas.len(),
            fps: self.fps,
        };
        for f in 0..frames {
            out.poses.extend_from_slice(self.pose(f % t));
            out.translations.extend(self.translation(f % t));
            out.betas.extend_from_slice(betas);
        }
        Some(out)
    }
}

fn first_present(
    archive: &mut NpzArchive<std::io::BufReader<std::fs::File>>,
    path: &Path,
    keys: &[&str],
) -> Result<Option<(String, Array)>, DatasetError> {
    for &key in keys {
        let npy = archive
            .by_name(key)
            .map_err(|e| DatasetError::field(path, key, format!("cannot read ({e})")))?;
        if let Some(npy) = npy {
            let array = decode_npy(npy).map_err(|p| DatasetError::field(path, key, p))?;
            return Ok(Some((key.to_owned(), array)));
        }
    }
    Ok(None)
}

fn check_finite(path: &Path, key: &str, a: &Array, columns: usize) -> Result<(), DatasetError> {
    match a.values.iter().position(|v| !v.is_finite()) {
        None => Ok(()),
        Some(i) => Err(DatasetError::field(
            path,
            key,
            format!(
                "non-finite value at frame {}, column {}",
                i / columns.max(1),
                i % columns.max(1)
            ),
        )),
    }
}

/// Reads a pose sequence (layout in the module doc).
pub fn load_pose_sequence(path: &Path) -> Result<PoseSequence, DatasetError> {
    let mut archive = NpzArchive::open(path)
        .map_err(|e| DatasetError::file(path, format!("cannot open as .npz ({e})")))?;
    let (_, poses) = first_present(&mut archive, path, &["poses"])?.ok_or_else(|| {
        DatasetError::field(path, "poses", "missing: expected [T, 3J] axis-angle poses")
    })?;
    if poses.shape.len() != 2
        || poses.shape[1] % 3 != 0
        || poses.shape[0] == 0
        || poses.shape[1] == 0
    {
        return Err(DatasetError::field(
            path,
            "poses",
            format!(
                "shape {:?}: expected [T, 3J] with T > 0 (72 for SMPL)",
                poses.shape
            ),
        ));
    }
    let (t, width) = (poses.shape[0], poses.shape[1]);
    check_finite(path, "poses", &poses, width)?;

    let translations =
        match first_present(&mut archive, path, &["trans", "transl", "translations"])? {
            None => vec![0.0; 3 * t],
            Some((key, a)) => {
                if a.shape != [t, 3] {
                    return Err(DatasetError::field(
                        path,
                        &key,
                        format!("shape {:?}: expected [{t}, 3]", a.shape),
                    ));
                }
                check_finite(path, &key, &a, 3)?;
                a.values
            }
        };
    let (betas, shape_count) = match first_present(&mut archive, path, &["betas"])? {
        None => (Vec::new(), 0),
        Some((key, a)) => {
            check_finite(path, &key, &a, *a.shape.last().unwrap_or(&1))?;
            match a.shape.as_slice() {
                [s] => (a.values.repeat(t), *s),
                [rows, s] if *rows == t => (a.values, *s),
                [1, s] => (a.values.repeat(t), *s),
                other => {
                    return Err(DatasetError::field(
                        path,
                        &key,
                        format!("shape {other:?}: expected [S] or [{t}, S]"),
                    ));
                }
            }
        }
    };
    let fps = first_present(&mut archive, path, &["mocap_framerate", "mocap_frame_rate"])?
        .and_then(|(_, a)| a.values.first().copied())
        .filter(|f| f.is_finite() && *f > 0.0);
    Ok(PoseSequence {
        joints: width / 3,
        poses: poses.values,
        translations,
        betas,
        shape_count,
        fps,
    })
}

/// Writes a pose sequence in the same layout (`betas` as `[T, S]`), atomically.
pub fn write_pose_sequence(path: &Path, seq: &PoseSequence) -> Result<(), DatasetError> {
    let t = seq.frames() as u64;
    write_atomically(path, |tmp| {
        let mut npz = NpzWriter::create(tmp)?;
        {
            let mut put = |name: &str, shape: &[u64], values: &[f64]| -> std::io::Result<()> {
                let mut w = npz
                    .array::<f64>(name, Default::default())?
                    .default_dtype()
                    .shape(shape)
                    .begin_nd()?;
                w.extend(values.iter().copied())?;
                w.finish()
            };
            put("poses", &[t, 3 * seq.joints as u64], &seq.poses)?;
            put("trans", &[t, 3], &seq.translations)?;
            put("betas", &[t, seq.shape_count as u64], &seq.betas)?;
            if let Some(fps) = seq.fps {
                put("mocap_framerate", &[], &[fps])?;
            }
        }
        let mut file = npz.zip_writer().finish().map_err(std::io::Error::other)?;
        std::io::Write::flush(&mut file)?;
        file.get_ref().sync_all()
    })
}
