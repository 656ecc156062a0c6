//! Per-frame pose refinement only where the body track is an estimate. The skinned node
//! refines each trained frame's joint rotations and root translation, the sequence's shape and
//! a shared rotation offset, because a tracker's fit is off; a track that is the true motion
//! (a synthetic capture without tracker noise, a marker-based mocap stand-in) has nothing to
//! correct, and refining it costs the deltas' gradients and Adam steps and lets the pose
//! drift to absorb appearance errors. Every capture loaded from disk carries a tracker's
//! estimate. `pose_refinement` forces the decision either way; forced on, the node's own
//! `refine_*` switches still choose which parts are refined.

use super::AvatarConfig;
use super::data::AvatarCapture;
use crate::harness::ModuleChoice;

/// Whether the capture's track gets refined, and why.
pub fn decide(config: &AvatarConfig, capture: &AvatarCapture) -> ModuleChoice {
    let (needed, why) = if capture.track_is_truth {
        (false, "the body track is the true motion: kept as given")
    } else {
        (true, "the body track is an estimate: refined per frame")
    };
    ModuleChoice::decide(
        "pose refinement",
        "pose_refinement",
        config.pose_refinement,
        needed,
        why,
    )
}

/// `config` with the node's refinement switched off where `choice` leaves it out, and the
/// decision kept in `pose_refinement`.
pub fn apply(mut config: AvatarConfig, choice: &ModuleChoice) -> AvatarConfig {
    config.pose_refinement = Some(choice.enabled);
    if !choice.enabled {
        let node = &mut config.node;
        node.refine_rotations = false;
        node.refine_translation = false;
        node.refine_sequence_offset = false;
        node.refine_shape = false;
    }
    config
}
