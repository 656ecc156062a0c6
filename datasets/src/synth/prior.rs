//! Unreliable body priors: a copy of the true pose and shape with per-frame noise and a
//! per-sequence bias, standing in for the estimates of an off-the-shelf body tracker that
//! APF-GS gates with its reliability weight and Prior-4D refines.

use super::rng::Rng;
use crate::pose_sequence::PoseSequence;

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
