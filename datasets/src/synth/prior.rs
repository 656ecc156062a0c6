//! Unreliable body priors: a copy of the true pose and shape with per-frame noise and a
//! per-sequence bias, standing in for the estimates of an off-the-shelf body tracker that
//! APF-GS gates with its reliability weight and Prior-4D refines; on top of that, a window of
//! frames where the tracker fails ([`PriorCorruption`]), so a reliability weight has something
//! to detect, and the injected error per frame ([`joint_angle_error`]) to correlate it with.

use super::rng::Rng;
use crate::pose_sequence::PoseSequence;
use glam::{DQuat, DVec3};

/// Noise and bias levels (standard deviations) of the perturbed priors.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PriorNoise {
    /// Per-frame noise on every axis-angle component, radians.
    pub pose_noise: f64,
    /// A fixed offset per axis-angle component for the whole sequence, radians.
    pub pose_bias: f64,
    /// Per-frame noise on the root translation, metres.
    pub translation_noise: f64,
    /// A fixed offset of the root translation, metres.
    pub translation_bias: f64,
    /// Noise on each shape coefficient (one draw per sequence).
    pub shape_noise: f64,
}

impl Default for PriorNoise {
    fn default() -> Self {
        Self {
            pose_noise: 0.04,
            pose_bias: 0.05,
            translation_noise: 0.01,
            translation_bias: 0.03,
            shape_noise: 0.3,
        }
    }
}

impl PriorNoise {
    /// No perturbation: the prior equals the truth.
    pub fn none() -> Self {
        Self {
            pose_noise: 0.0,
            pose_bias: 0.0,
            translation_noise: 0.0,
            translation_bias: 0.0,
            shape_noise: 0.0,
        }
    }

    /// `truth` with noise and bias added to the axis-angle pose, translation and shape.
    pub fn perturb(&self, truth: &PoseSequence, seed: u64) -> PoseSequence {
        let mut rng = Rng(seed ^ 0x9A10_4000);
        let j3 = 3 * truth.joints;
        let pose_bias: Vec<f64> = (0..j3).map(|_| self.pose_bias * rng.normal()).collect();
        let translation_bias: Vec<f64> = (0..3)
            .map(|_| self.translation_bias * rng.normal())
            .collect();
        let shape_offset: Vec<f64> = (0..truth.shape_count)
            .map(|_| self.shape_noise * rng.normal())
            .collect();
        let mut out = truth.clone();
        for frame in out.poses.chunks_mut(j3) {
            for (x, b) in frame.iter_mut().zip(&pose_bias) {
                *x += b + self.pose_noise * rng.normal();
            }
        }
        for frame in out.translations.chunks_mut(3) {
            for (x, b) in frame.iter_mut().zip(&translation_bias) {
                *x += b + self.translation_noise * rng.normal();
            }
        }
        if truth.shape_count > 0 {
            for frame in out.betas.chunks_mut(truth.shape_count) {
                for (x, o) in frame.iter_mut().zip(&shape_offset) {
                    *x += o;
                }
            }
        }
        out
    }
}

/// A tracker failure: over frames `first_frame..=last_frame` the prior's local rotation of each
/// of `joints` is turned by `bias` radians about the x axis of its parent's frame (a leg or an
/// arm swung backwards, a knee bent further), on top of the [`PriorNoise`].
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PriorCorruption {
    pub first_frame: usize,
    /// The last corrupted frame (inclusive).
    pub last_frame: usize,
    /// SMPL joint indices (1..24; 0 is the global orientation).
    pub joints: Vec<usize>,
    /// Radians.
    pub bias: f64,
}

impl PriorCorruption {
    /// One arm chain (left shoulder 16, left elbow 18) and one leg chain (right hip 2, right
    /// knee 5) of every tracked person turned by 0.35 rad over frames 12–22: the driving
    /// preset's default.
    pub fn driving() -> Self {
        Self {
            first_frame: 12,
            last_frame: 22,
            joints: vec![16, 18, 2, 5],
            bias: 0.35,
        }
    }

    /// Whether `frame` lies in the corrupted window.
    pub fn contains(&self, frame: usize) -> bool {
        (self.first_frame..=self.last_frame).contains(&frame)
    }

    /// Corrupts the window's frames of `prior` (a [`PriorNoise::perturb`] output); frames past
    /// its end are left alone.
    pub fn apply(&self, prior: &mut PoseSequence) {
        let turn = DQuat::from_rotation_x(self.bias);
        let j3 = 3 * prior.joints;
        for (frame, pose) in prior.poses.chunks_mut(j3).enumerate() {
            if !self.contains(frame) {
                continue;
            }
            for &j in &self.joints {
                let local = &mut pose[3 * j..3 * j + 3];
                let rotation = DQuat::from_scaled_axis(DVec3::from_slice(local));
                let turned = (turn * rotation).normalize().to_scaled_axis();
                local.copy_from_slice(&turned.to_array());
            }
        }
    }
}

/// Per frame, the mean over the body joints (1.., the global orientation excluded) of the
/// angle in radians between `truth`'s and `prior`'s local rotations: the error a tracker made,
/// for correlating with what a method infers about the prior's reliability.
pub fn joint_angle_error(truth: &PoseSequence, prior: &PoseSequence) -> Vec<f64> {
    assert_eq!(
        (truth.joints, truth.frames()),
        (prior.joints, prior.frames()),
        "truth and prior of different layouts"
    );
    (0..truth.frames())
        .map(|t| {
            let (a, b) = (truth.pose(t), prior.pose(t));
            let joints = 1..truth.joints;
            let count = joints.len().max(1) as f64;
            joints
                .map(|j| {
                    let q = |p: &[f64]| DQuat::from_scaled_axis(DVec3::from_slice(&p[3 * j..]));
                    q(a).angle_between(q(b))
                })
                .sum::<f64>()
                / count
        })
        .collect()
}
