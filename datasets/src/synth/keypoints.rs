//! A stand-in for a 2-D keypoint detector (OpenPose's BODY_25 and the like): the points a
//! body's [`KeypointTarget`]s mark on a posed body, projected by a pinhole camera, with
//! Gaussian pixel noise and random misses, as the methods whose papers run a detector receive
//! them (AAGaussian's portrait, Prior-4D's acting video).

use crate::posing::PosedFrame;
use crate::synth::rng::Rng;
use splatzoo_models::body::fit::{KeypointTarget, PinholeCamera};
use splatzoo_rasterizer::Camera;

/// The rasterizer's camera as the body fit's pinhole (the same pixel convention).
pub fn pinhole(camera: &Camera) -> PinholeCamera {
    PinholeCamera {
        fx: f64::from(camera.fx),
        fy: f64::from(camera.fy),
        cx: f64::from(camera.cx),
        cy: f64::from(camera.cy),
        world_to_camera: camera.world_to_camera.map(|row| row.map(f64::from)),
    }
}

/// How the stand-in detector errs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DetectorNoise {
    /// Standard deviation of each pixel coordinate.
    pub pixel_sigma: f64,
    /// Chance that a visible point is not reported.
    pub miss_rate: f64,
}

/// Where the detector reports each of `targets` on `frame` seen by `camera`: `None` for a slot
/// without a target, a point behind the camera or outside `image` (`[width, height]`; no bound
/// without it), or a miss. Random draws per reported slot, in order: one uniform for the miss
/// (only when `miss_rate > 0`), then the x and y noise.
pub fn detect(
    frame: &PosedFrame,
    targets: &[Option<KeypointTarget>],
    camera: &PinholeCamera,
    image: Option<[u32; 2]>,
    noise: &DetectorNoise,
    rng: &mut Rng,
) -> Vec<Option<[f64; 2]>> {
    let point = |t: KeypointTarget| -> [f64; 3] {
        t.locate(
            |j| frame.joints[j].map(f64::from),
            |v| frame.vertices[v].map(f64::from),
        )
    };
    let inside = |p: [f64; 2]| {
        image.is_none_or(|[w, h]| {
            p[0] >= 0.0 && p[1] >= 0.0 && p[0] < f64::from(w) && p[1] < f64::from(h)
        })
    };
    targets
        .iter()
        .map(|target| {
            let seen = target
                .and_then(|t| camera.project(point(t)))
                .filter(|&p| inside(p))?;
            if noise.miss_rate > 0.0 && rng.next() < noise.miss_rate {
                return None;
            }
            Some([
                seen[0] + noise.pixel_sigma * rng.normal(),
                seen[1] + noise.pixel_sigma * rng.normal(),
            ])
        })
        .collect()
}
