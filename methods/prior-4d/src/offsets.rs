//! The pose-dependent offsets `ΔV_pose(θ)`, `ΔS_pose(θ)` of Eq. 2 (§4.3.1 of Prior-4D; no
//! architecture in the paper, the spec takes ExAvatar's geometry-offset network): an MLP on each
//! canonical Gaussian's position code `γ(x̄)` and the frame's body pose (6-D rotations of every
//! joint but the root, detached) with two heads, a centre offset (3) and a log-radius offset
//! (1). Both heads start at zero, so step 0 of stage D reproduces the avatar prior exactly.
//!
//! It plugs into the skinned node as a canonical-space [`NonRigidField`]: offsets are added to
//! the canonical Gaussians *before* skinning (Eq. 2 then Eq. 3). The static identity offset
//! `ΔV_cloth` is the canonical centres' own departure from the template (the node's learnable
//! means); expression offsets are zero on the built-in body, which has none.

use burn::module::Module;
use burn::nn::Linear;
use burn::tensor::{Device, Tensor};
use serde::{Deserialize, Serialize};
use splatzoo_models::networks::encoding::{encoded_width, frequency_encoding};
use splatzoo_models::networks::mlp::{SkipMlp, head};
use splatzoo_models::rotation::matrix_to_rotation_6d;
use splatzoo_train::scene::skinned::{NonRigidField, Residual, ResidualInput, ResidualSpace};

/// The offset network's shape.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PoseOffsetConfig {
    /// Frequencies of the position code.
    pub position_levels: usize,
    /// Hidden layers and their width (ExAvatar: 3 × 128).
    pub depth: usize,
    pub width: usize,
}

impl Default for PoseOffsetConfig {
    fn default() -> Self {
        Self {
            position_levels: 4,
            depth: 3,
            width: 128,
        }
    }
}

#[derive(Module, Debug)]
pub struct PoseOffsetNet {
    pub trunk: SkipMlp,
    pub offset_head: Linear,
    pub scale_head: Linear,
}

/// Width of the pose code: 6-D rotations of the `joints − 1` non-root joints.
pub fn pose_width(joints: usize) -> usize {
    6 * joints.saturating_sub(1)
}

impl PoseOffsetNet {
    /// A network for a body with `joints` joints, heads at zero.
    pub fn new(config: &PoseOffsetConfig, joints: usize, device: &Device) -> Self {
        let inputs = encoded_width(3, config.position_levels) + pose_width(joints);
        let trunk = SkipMlp::new(inputs, config.depth, config.width, None, device);
        Self {
            offset_head: head(config.width, 3, true, device),
            scale_head: head(config.width, 1, true, device),
            trunk,
        }
    }

    /// The network's input rows `[G, 3 (1 + 2 L) + 6 (J − 1)]`: each canonical centre's code
    /// `γ(x̄)` (`[G, 3]` in) beside the frame's pose code from local joint rotations
    /// `[1, J, 3, 3]` (both detached: the network conditions on them, it does not move them).
    pub fn inputs(canonical: Tensor<2>, rotations: Tensor<4>, levels: usize) -> Tensor<2> {
        let [g, _] = canonical.dims();
        let [_, j, _, _] = rotations.dims();
        let pose =
            matrix_to_rotation_6d(rotations.detach().slice([0..1, 1..j, 0..3, 0..3]).reshape([
                j - 1,
                3,
                3,
            ]))
            .reshape([1, pose_width(j)])
            .expand([g, pose_width(j)]);
        let code = frequency_encoding(canonical.detach(), levels);
        Tensor::cat(vec![code, pose], 1)
    }

    /// Input rows → `[G, 4]`: centre offsets (3) then the log-radius offset (1). This is the
    /// graph the ONNX export writes.
    pub fn forward_inputs(&self, inputs: Tensor<2>) -> Tensor<2> {
        let hidden = self.trunk.forward(inputs);
        Tensor::cat(
            vec![
                self.offset_head.forward(hidden.clone()),
                self.scale_head.forward(hidden),
            ],
            1,
        )
    }

    /// Canonical centres `[G, 3]` and the frame's local joint rotations `[1, J, 3, 3]` →
    /// centre offsets `[G, 3]` and log-radius offsets `[G, 1]`.
    pub fn forward(
        &self,
        canonical: Tensor<2>,
        rotations: Tensor<4>,
        levels: usize,
    ) -> (Tensor<2>, Tensor<2>) {
        let g = canonical.dims()[0];
        let out = self.forward_inputs(Self::inputs(canonical, rotations, levels));
        (out.clone().slice([0..g, 0..3]), out.slice([0..g, 3..4]))
    }
}

/// [`PoseOffsetNet`] as the skinned node's canonical-space field (set each step with the
/// network's current parameters).
pub struct PoseOffsets {
    pub net: PoseOffsetNet,
    pub levels: usize,
}

impl NonRigidField for PoseOffsets {
    fn space(&self) -> ResidualSpace {
        ResidualSpace::Canonical
    }

    fn residual(&self, input: &ResidualInput) -> Residual {
        let g = input.canonical.len();
        let (offsets, log_scales) = self.net.forward(
            input.canonical.means.clone(),
            input.pose.clone(),
            self.levels,
        );
        Residual {
            means: Some(offsets),
            log_scales: Some(log_scales.expand([g, 3])),
            ..Default::default()
        }
    }
}
