//! Furniture hiding the person: one of the two conditions under which Fig. 5 of Prior-4D shows
//! the avatar prior mattering. The other, an acting video that never films the person's back,
//! the default capture already has: the hand-held camera and the person turn together, so every
//! acting frame sees her within about 50° of her front, while the fixed evaluation camera sees
//! her back (tested). The cabinet stands between the acting camera and where the person stops,
//! hiding her legs while she stands (the second half of the default clip); an avatar fitted to such a video
//! alone has no back and no shins to show the evaluation camera, and the human scan has both.

use glam::DVec3;
use splatzoo_datasets::pose_sequence::PoseSequence;
use splatzoo_datasets::synth::environment::{Prop, cabinet};
use splatzoo_rasterizer::Camera;

/// The cabinet's size (width, height, depth, metres) and its distance in front of where the
/// person stops: from an eye-height camera about 2.6 m away its top at 0.85 m hides the body
/// below about 0.6 m.
pub const CABINET_SIZE: [f64; 3] = [1.0, 0.85, 0.45];
pub const CABINET_AHEAD: f64 = 0.7;

/// The first frame from which `motion`'s root stays put (to 1 mm), or its last frame.
pub fn stopping_frame(motion: &PoseSequence) -> usize {
    let last = motion.frames().saturating_sub(1);
    let end = DVec3::from(motion.translation(last));
    (0..=last)
        .rev()
        .take_while(|&t| DVec3::from(motion.translation(t)).distance(end) < 1e-3)
        .last()
        .unwrap_or(last)
}

/// The cabinet [`CABINET_AHEAD`] from where `motion` ends towards where `cameras` (the acting
/// camera, one per frame, metres) stands halfway through the standing part, square to that
/// direction: it hides her legs from the acting camera while she stands.
pub fn occluder(motion: &PoseSequence, cameras: &[Camera], seed: u64) -> Prop {
    let last = motion.frames().saturating_sub(1);
    let middle = (stopping_frame(motion) + last) / 2;
    let pelvis = DVec3::from(motion.translation(last));
    let feet = DVec3::new(pelvis.x, 0.0, pelvis.z);
    let towards = cameras
        .get(middle.min(cameras.len().saturating_sub(1)))
        .map(|c| {
            let centre = DVec3::from(c.position().map(f64::from));
            DVec3::new(centre.x, 0.0, centre.z) - feet
        })
        .unwrap_or(DVec3::Z)
        .normalize_or(DVec3::Z);
    cabinet(
        seed,
        feet + towards * CABINET_AHEAD,
        DVec3::from(CABINET_SIZE),
        towards.x.atan2(towards.z),
    )
}
