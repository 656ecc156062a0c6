//! The avatar's surroundings: a static background node ([`GaussianNode`], 3DGS with its own
//! optimiser and density control) beside the skinned human, where the capture has a scene to
//! reconstruct. It starts from the capture's sparse points (NeuMan's and COLMAP's SfM points),
//! or, when forced on a synthetic capture, from the rendered depth outside the person.
//!
//! A scene gets it only where the data calls for it: by default where the capture has sparse
//! points of its surroundings (a studio capture or a masked monocular video without them has
//! nothing for it to start from, and the avatar's scores are over the person); `scenery` in
//! the configuration forces the decision either way. With it, each step adds the composite
//! loss — human and background rendered in one rasterizer call against the whole image — to
//! the avatar's own masked loss, and evaluation adds full-image scores of the composite.

use super::AvatarConfig;
use super::data::AvatarCapture;
use crate::error::TrainError;
use crate::gaussians::GaussianSet;
use crate::harness::ModuleChoice;
use crate::scene::GaussianNode;
use crate::views::camera_extent;
use burn::tensor::Device;

/// The background node's name (its checkpoint prefix).
pub const SCENERY: &str = "background";

/// Whether the capture gets a background node, and why: where the capture has sparse points of
/// its surroundings (a studio capture with masked-out backgrounds has none); `scenery` forces it
/// either way (forced on without points, it starts from random points).
pub fn decide(config: &AvatarConfig, capture: &AvatarCapture) -> ModuleChoice {
    let (needed, why) = match capture.scenery_source {
        Some(from) if from.contains("sparse") => (
            true,
            format!("the capture has sparse points of its surroundings ({from})"),
        ),
        Some(from) => (
            false,
            format!("the capture has no sparse points of its surroundings (only {from})"),
        ),
        None => (
            false,
            "the capture has no points of its surroundings".to_owned(),
        ),
    };
    ModuleChoice::decide("background node", "scenery", config.scenery, needed, why)
}

/// The background node over the capture's scenery points (random points in the cameras' box
/// where there are none).
pub fn build_node(
    config: &AvatarConfig,
    capture: &AvatarCapture,
    device: &Device,
) -> Result<GaussianNode, TrainError> {
    let cameras: Vec<_> = capture.train.iter().map(|v| v.camera).collect();
    let extent = camera_extent(&cameras);
    let points = if capture.scenery_points.is_empty() {
        crate::views::init_points::random_points(&cameras, 20_000, config.seed)
    } else {
        capture.scenery_points.clone()
    };
    if points.is_empty() {
        return Err(TrainError::Config(
            "scenery: no points to start the background from".into(),
        ));
    }
    let set = GaussianSet::from_points(&points.positions, &points.colours, &points.sigmas, device);
    Ok(GaussianNode::new(
        SCENERY,
        set,
        config.rates,
        &config.scenery_densify,
        extent,
        config.seed ^ 0xA7A7_0002,
    ))
}
