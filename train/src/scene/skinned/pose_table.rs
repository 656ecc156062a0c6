//! Per-frame body parameters refined during training: a 6-D rotation delta on every joint of
//! the prior (`R_j = R_j^prior · O_j · Δ_j`, joint 0 the global orientation; Zhou et al.'s 6-D
//! representation) and a root-translation delta, one row per frame, with an optional offset
//! `O_j` shared by every frame (a pose estimator's systematic bias is the same in each frame,
//! so all frames' gradients correct it at once). Only frames with training
//! images are refined; the pose at any other frame is interpolated from the nearest trained
//! frames on each side (slerp of the deltas, linear translation), so no held-out image is read.
//! A temporal-smoothness term ties consecutive trained frames.

use crate::adam::{AdamConfig, AdamState};
use crate::checkpoint::{Checkpoint, CheckpointError};
use crate::host_f32;
use burn::tensor::{Device, Gradients, Int, Tensor, TensorData};
use splatzoo_datasets::pose_sequence::PoseSequence;
use splatzoo_models::rotation::rotation_6d_to_matrix;
use splatzoo_models::rotation_scalar::{axis_angle_matrix, matrix_axis_angle};

/// The 6-D representation of the identity (its first two rows).
pub const IDENTITY_6D: [f32; 6] = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0];

type Matrix = [[f64; 3]; 3];

/// What the table refines.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Refinement {
    pub rotations: bool,
    pub translation: bool,
    /// The per-joint offset shared by all frames (with `rotations`).
    pub sequence_offset: bool,
}

/// One step's autodiff leaves of a table.
pub struct TableLeaves {
    /// `[F, J, 6]`.
    pub deltas: Tensor<3>,
    /// `[F, 3]`.
    pub translations: Tensor<2>,
    /// `[J, 6]`.
    pub offsets: Tensor<2>,
}

/// A frame's body parameters as tensors: `[1, J, 3, 3]` local rotations and `[1, 3]` root
/// translation (autodiff leaves' descendants at trained frames during a step).
pub struct FramePose {
    pub rotations: Tensor<4>,
    pub translation: Tensor<2>,
}

pub struct PoseTable {
    joints: usize,
    /// `[F, J, 3, 3]` the prior's local rotations.
    prior_rotations: Tensor<4>,
    /// `[F, 3]`.
    prior_translations: Tensor<2>,
    /// `[F, J, 6]` the refinement, identity at the start.
    pub deltas: Tensor<3>,
    /// `[F, 3]` metres, zero at the start.
    pub translation_deltas: Tensor<2>,
    /// `[J, 6]` the shared offset, identity at the start.
    pub offsets: Tensor<2>,
    trained: Vec<bool>,
    refine: Refinement,
    leaves: Option<TableLeaves>,
    rotation_adam: AdamState<3>,
    translation_adam: AdamState<2>,
    offset_adam: AdamState<2>,
}

/// Adam for body parameters (ε = 1e-8, not the 3DGS 1e-15: these are not Gaussians).
pub(super) fn adam() -> AdamConfig {
    AdamConfig {
        epsilon: 1e-8,
        ..AdamConfig::default()
    }
}

impl PoseTable {
    /// A table over `prior` (one row per frame), refining the frames where `trained` is true.
    pub fn new(
        prior: &PoseSequence,
        trained: Vec<bool>,
        refine: Refinement,
        device: &Device,
    ) -> Self {
        let (f, j) = (prior.frames(), prior.joints);
        assert_eq!(trained.len(), f, "one trained flag per frame");
        let rotations: Vec<f32> = (0..f)
            .flat_map(|t| {
                let pose = prior.pose(t).to_vec();
                (0..j).flat_map(move |k| {
                    axis_angle_matrix([pose[3 * k], pose[3 * k + 1], pose[3 * k + 2]])
                        .into_iter()
                        .flatten()
                        .map(|v| v as f32)
                })
            })
            .collect();
        let translations: Vec<f32> = prior.translations.iter().map(|&v| v as f32).collect();
        let deltas = Tensor::<3>::from_data(
            TensorData::new(IDENTITY_6D.repeat(f * j), [f, j, 6]),
            device,
        );
        let translation_deltas = Tensor::<2>::zeros([f, 3], device);
        let offsets =
            Tensor::<2>::from_data(TensorData::new(IDENTITY_6D.repeat(j), [j, 6]), device);
        Self {
            offset_adam: AdamState::new(&offsets),
            offsets,
            joints: j,
            prior_rotations: Tensor::from_data(TensorData::new(rotations, [f, j, 3, 3]), device),
            prior_translations: Tensor::from_data(TensorData::new(translations, [f, 3]), device),
            rotation_adam: AdamState::new(&deltas),
            translation_adam: AdamState::new(&translation_deltas),
            deltas,
            translation_deltas,
            trained,
            refine,
            leaves: None,
        }
    }

    pub fn frames(&self) -> usize {
        self.trained.len()
    }

    pub fn joints(&self) -> usize {
        self.joints
    }

    pub fn is_trained(&self, frame: usize) -> bool {
        self.trained.get(frame).copied().unwrap_or(false)
    }

    pub fn refinement(&self) -> Refinement {
        self.refine
    }

    /// Fresh autodiff leaves of the refined parameters.
    pub fn begin_step(&mut self) {
        if self.refine.rotations || self.refine.translation {
            self.leaves = Some(TableLeaves {
                deltas: self.deltas.clone().autodiff().require_grad(),
                translations: self.translation_deltas.clone().autodiff().require_grad(),
                offsets: self.offsets.clone().autodiff().require_grad(),
            });
        }
    }

    /// This step's leaves, inside a step.
    pub fn leaves(&self) -> Option<&TableLeaves> {
        self.leaves.as_ref()
    }

    fn current(&self) -> (Tensor<3>, Tensor<2>) {
        match &self.leaves {
            Some(l) => (l.deltas.clone(), l.translations.clone()),
            None => (self.deltas.clone(), self.translation_deltas.clone()),
        }
    }

    /// `[J, 3, 3]` the shared offset's rotations (identity when it is off).
    fn offset_rotations(&self, autodiff: bool) -> Option<Tensor<3>> {
        if !(self.refine.rotations && self.refine.sequence_offset) {
            return None;
        }
        let offsets = match &self.leaves {
            Some(l) if autodiff => l.offsets.clone(),
            _ if autodiff => self.offsets.clone().autodiff(),
            _ => self.offsets.clone(),
        };
        Some(rotation_6d_to_matrix(offsets))
    }

    /// The pose at `frame`: the refined row where the frame was trained, otherwise interpolated
    /// from its trained neighbours (the prior alone where none was trained). `autodiff` lifts
    /// the constants into the autodiff graph (inside a training step).
    pub fn frame(&self, frame: usize, autodiff: bool) -> FramePose {
        assert!(frame < self.frames(), "frame {frame} of {}", self.frames());
        let j = self.joints;
        let device = self.deltas.device();
        let lift4 = |t: Tensor<4>| if autodiff { t.autodiff() } else { t };
        let lift3 = |t: Tensor<3>| if autodiff { t.autodiff() } else { t };
        let lift2 = |t: Tensor<2>| if autodiff { t.autodiff() } else { t };
        let prior_rot = lift4(self.prior_rotations.clone())
            .slice([frame..frame + 1, 0..j, 0..3, 0..3])
            .reshape([j, 3, 3]);
        let prior_trans = lift2(self.prior_translations.clone()).slice([frame..frame + 1, 0..3]);
        let (delta_rot, delta_trans) = if self.is_trained(frame) {
            // Outside the graph (`autodiff` false) the plain values, even within a step.
            let (d, t) = if autodiff {
                self.current()
            } else {
                (self.deltas.clone(), self.translation_deltas.clone())
            };
            let d = lift3(d)
                .slice([frame..frame + 1, 0..j, 0..6])
                .reshape([j, 6]);
            (
                rotation_6d_to_matrix(d),
                lift2(t).slice([frame..frame + 1, 0..3]),
            )
        } else {
            let (rot, trans) = self.interpolated(frame);
            let rot: Vec<f32> = rot.iter().flatten().flatten().map(|&v| v as f32).collect();
            (
                lift3(Tensor::<3>::from_data(
                    TensorData::new(rot, [j, 3, 3]),
                    &device,
                )),
                lift2(Tensor::<2>::from_data(
                    TensorData::new(trans.map(|v| v as f32).to_vec(), [1, 3]),
                    &device,
                )),
            )
        };
        let delta_rot = match self.offset_rotations(autodiff) {
            Some(offset) => offset.matmul(delta_rot),
            None => delta_rot,
        };
        let rotations = if self.refine.rotations {
            prior_rot.matmul(delta_rot)
        } else {
            prior_rot
        };
        let translation = if self.refine.translation {
            prior_trans + delta_trans
        } else {
            prior_trans
        };
        FramePose {
            rotations: rotations.reshape([1, j, 3, 3]),
            translation,
        }
    }

    /// The deltas at an untrained `frame`, from the trained frames before and after it.
    pub fn interpolated(&self, frame: usize) -> (Vec<Matrix>, [f64; 3]) {
        let before = (0..frame).rev().find(|&t| self.trained[t]);
        let after = (frame + 1..self.frames()).find(|&t| self.trained[t]);
        let j = self.joints;
        let deltas = host_f32(&self.deltas);
        let trans = host_f32(&self.translation_deltas);
        let row = |t: usize| -> (Vec<Matrix>, [f64; 3]) {
            let rot = (0..j)
                .map(|k| {
                    let r6: [f64; 6] = std::array::from_fn(|c| deltas[(t * j + k) * 6 + c] as f64);
                    matrix_from_6d(r6)
                })
                .collect();
            (rot, std::array::from_fn(|a| trans[3 * t + a] as f64))
        };
        match (before, after) {
            (Some(a), Some(b)) => {
                let s = (frame - a) as f64 / (b - a) as f64;
                let (ra, ta) = row(a);
                let (rb, tb) = row(b);
                let rot = ra.iter().zip(&rb).map(|(x, y)| slerp(x, y, s)).collect();
                (rot, std::array::from_fn(|k| ta[k] + s * (tb[k] - ta[k])))
            }
            (Some(t), None) | (None, Some(t)) => row(t),
            (None, None) => (vec![IDENTITY; j], [0.0; 3]),
        }
    }

    /// Mean squared distance of the refinement from the prior: rotation deltas (and the shared
    /// offset) from the identity in 6-D, translation deltas from zero (metres), on this step's
    /// leaves.
    pub fn prior_distance(&self) -> Option<Tensor<1>> {
        let leaves = self.leaves.as_ref()?;
        let device = leaves.deltas.device();
        let identity = Tensor::<1>::from_floats(IDENTITY_6D, &device);
        let mut term = Tensor::<1>::zeros([1], &device);
        if self.refine.rotations {
            let d = leaves.deltas.clone() - identity.clone().reshape([1, 1, 6]);
            term = term + d.powi_scalar(2).mean();
            if self.refine.sequence_offset {
                let o = leaves.offsets.clone() - identity.reshape([1, 6]);
                term = term + o.powi_scalar(2).mean();
            }
        }
        if self.refine.translation {
            term = term + leaves.translations.clone().powi_scalar(2).mean();
        }
        Some(term)
    }

    /// Mean squared difference of consecutive trained frames' deltas (6-D rows and
    /// translations, metres), on this step's leaves.
    pub fn smoothness(&self) -> Option<Tensor<1>> {
        self.leaves.as_ref()?;
        let trained: Vec<i64> = (0..self.frames())
            .filter(|&t| self.trained[t])
            .map(|t| t as i64)
            .collect();
        if trained.len() < 2 {
            return None;
        }
        let (d, t) = self.current();
        let device = d.device();
        let index = |v: &[i64]| {
            Tensor::<1, Int>::from_data(TensorData::new(v.to_vec(), [v.len()]), &device)
        };
        let (a, b) = (index(&trained[..trained.len() - 1]), index(&trained[1..]));
        let mut term = Tensor::<1>::zeros([1], &device);
        if self.refine.rotations {
            term = term
                + (d.clone().select(0, a.clone()) - d.select(0, b.clone()))
                    .powi_scalar(2)
                    .mean();
        }
        if self.refine.translation {
            term = term
                + (t.clone().select(0, a) - t.select(0, b))
                    .powi_scalar(2)
                    .mean();
        }
        Some(term)
    }

    /// One Adam step on the refined parameters, from this step's gradients.
    pub fn end_step(&mut self, grads: &Gradients, rotation_rate: f64, translation_rate: f64) {
        let Some(leaves) = self.leaves.take() else {
            return;
        };
        let (d, t) = (leaves.deltas, leaves.translations);
        if self.refine.rotations
            && let Some(g) = d.grad(grads)
        {
            self.deltas = self
                .rotation_adam
                .step(self.deltas.clone(), g, rotation_rate, &adam());
        }
        if self.refine.rotations
            && self.refine.sequence_offset
            && let Some(g) = leaves.offsets.grad(grads)
        {
            self.offsets = self
                .offset_adam
                .step(self.offsets.clone(), g, rotation_rate, &adam());
        }
        if self.refine.translation
            && let Some(g) = t.grad(grads)
        {
            self.translation_deltas = self.translation_adam.step(
                self.translation_deltas.clone(),
                g,
                translation_rate,
                &adam(),
            );
        }
    }

    pub fn save(&self, checkpoint: &mut Checkpoint, prefix: &str) {
        checkpoint.put(&format!("{prefix}.deltas"), &self.deltas);
        checkpoint.put(
            &format!("{prefix}.translation_deltas"),
            &self.translation_deltas,
        );
        self.rotation_adam
            .save(checkpoint, &format!("{prefix}.deltas"));
        checkpoint.put(&format!("{prefix}.offsets"), &self.offsets);
        self.offset_adam
            .save(checkpoint, &format!("{prefix}.offsets"));
        self.translation_adam
            .save(checkpoint, &format!("{prefix}.translation_deltas"));
    }

    pub fn load(&mut self, checkpoint: &Checkpoint, prefix: &str) -> Result<(), CheckpointError> {
        let device = self.deltas.device();
        let [f, j, _] = self.deltas.dims();
        self.deltas = checkpoint.tensor(
            &format!("{prefix}.deltas"),
            [Some(f), Some(j), Some(6)],
            &device,
        )?;
        self.translation_deltas = checkpoint.tensor(
            &format!("{prefix}.translation_deltas"),
            [Some(f), Some(3)],
            &device,
        )?;
        self.rotation_adam =
            AdamState::load(checkpoint, &format!("{prefix}.deltas"), &self.deltas)?;
        self.offsets =
            checkpoint.tensor(&format!("{prefix}.offsets"), [Some(j), Some(6)], &device)?;
        self.offset_adam =
            AdamState::load(checkpoint, &format!("{prefix}.offsets"), &self.offsets)?;
        self.translation_adam = AdamState::load(
            checkpoint,
            &format!("{prefix}.translation_deltas"),
            &self.translation_deltas,
        )?;
        self.leaves = None;
        Ok(())
    }
}

const IDENTITY: Matrix = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// Gram–Schmidt of the two rows of a 6-D representation (the scalar twin of
/// [`rotation_6d_to_matrix`]).
pub fn matrix_from_6d(r6: [f64; 6]) -> Matrix {
    let unit = |v: [f64; 3]| {
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt().max(1e-12);
        v.map(|c| c / n)
    };
    let b1 = unit([r6[0], r6[1], r6[2]]);
    let a2 = [r6[3], r6[4], r6[5]];
    let dot: f64 = (0..3).map(|k| b1[k] * a2[k]).sum();
    let b2 = unit(std::array::from_fn(|k| a2[k] - dot * b1[k]));
    let b3 = [
        b1[1] * b2[2] - b1[2] * b2[1],
        b1[2] * b2[0] - b1[0] * b2[2],
        b1[0] * b2[1] - b1[1] * b2[0],
    ];
    [b1, b2, b3]
}

fn product(a: &Matrix, b: &Matrix) -> Matrix {
    std::array::from_fn(|r| std::array::from_fn(|c| (0..3).map(|k| a[r][k] * b[k][c]).sum()))
}

fn transpose(a: &Matrix) -> Matrix {
    std::array::from_fn(|r| std::array::from_fn(|c| a[c][r]))
}

/// Geodesic interpolation `a · exp(s · log(aᵀ b))`.
pub fn slerp(a: &Matrix, b: &Matrix, s: f64) -> Matrix {
    let relative = matrix_axis_angle(&product(&transpose(a), b));
    product(a, &axis_angle_matrix(relative.map(|v| v * s)))
}
