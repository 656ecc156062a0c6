//! Where the two priors come from (§3 of Prior-4D). The paper trains the scene prior on a scan
//! of the empty room (stage A) and the avatar prior on a scan of the person (stage B); Fig. 5
//! shows what is lost without either, that prior then trained on the acting video itself, and
//! the spec's ExAvatar-like baseline (§7) takes both from it. [`PriorSource::Acting`] swaps the
//! scan for the acting video before the stages are built, so stages A–D run unchanged:
//!
//! - **scene**: the acting frames as scan views through their given (SfM) cameras, the person's
//!   pixels (its given masks) kept out of the loss, with their monocular depth and floor masks,
//!   starting from the acting video's own points ([`Prior4dCapture::acting_points`]);
//! - **avatar**: the acting frames in each frame's camera frame (identity extrinsics, metres:
//!   how ExAvatar fits a monocular video) with the person masks and the camera-space body prior
//!   (after stage C's keypoint refinement when that is on).
//!
//! Every acting frame but a real capture's held-out ones ([`crate::data::ActingFrame::held_out`])
//! is offered to the stage, which holds out its own share as it does on a scan; the evaluation
//! camera stays unseen.

use crate::camera::camera_at_origin;
use crate::data::{HumanScanView, Prior4dCapture, SceneScanView};
use serde::{Deserialize, Serialize};

/// The video a prior is trained on.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PriorSource {
    /// Its own scan (the paper).
    #[default]
    Scan,
    /// The acting video (Fig. 5's "without the prior"; the ExAvatar-like baseline).
    Acting,
}

/// What a prior from the acting video replaces: its scan's views, or nothing.
fn replaced(scanned: usize) -> String {
    if scanned == 0 {
        "a scan (the capture has none)".to_owned()
    } else {
        format!("the {scanned}-view scan")
    }
}

impl Prior4dCapture {
    /// Replaces the scene scan and its points by the acting video's; returns the decision.
    pub fn scene_from_acting(&mut self) -> String {
        let scanned = self.scene_scan.len();
        self.scene_scan = self
            .trained_frames()
            .map(|frame| SceneScanView {
                camera: frame.camera,
                image: frame.image.clone(),
                mono_inverse_depth: frame.mono_inverse_depth.clone(),
                depth: frame.depth.clone(),
                ground: frame.ground.clone(),
                person: Some(frame.mask.clone()),
            })
            .collect();
        self.scene_points = self.acting_points.clone();
        format!(
            "scene prior from the acting video (scene.source = \"acting\"): {} frames and {} of \
             its points in place of {}, the person masked out of the loss",
            self.scene_scan.len(),
            self.scene_points.len(),
            replaced(scanned)
        )
    }

    /// Replaces the human scan and its body fit by the acting video's, each frame in its own
    /// camera frame; returns the decision.
    pub fn avatar_from_acting(&mut self) -> String {
        let scanned = self.human_scan.len();
        let prior = &self.acting_prior;
        let trained = self.trained_indices();
        self.human_scan = trained
            .iter()
            .map(|&t| &self.acting[t])
            .map(|frame| HumanScanView {
                camera: camera_at_origin(&frame.camera),
                image: frame.image.clone(),
                mask: frame.mask.clone(),
            })
            .collect();
        self.scan_prior = prior.frames_subset(&trained);
        format!(
            "avatar prior from the acting video (avatar.source = \"acting\"): {} frames in \
             each camera's frame, with the camera-space body prior, in place of {}",
            self.human_scan.len(),
            replaced(scanned)
        )
    }
}
