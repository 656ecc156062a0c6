//! Stage C, initialisation on the acting video (§4.2 of Prior-4D): the floor plane π by RANSAC
//! on the scene prior's ground points, and the initial global scale σ₀ that puts the prior
//! body's feet on it. The acting cameras `E^t` (SfM, registered in the scene frame), masks,
//! normal maps and the camera-space body fit are the capture's inputs.
//!
//! Ground points (spec §4.2, our choice): centres of scene Gaussians with opacity > 0.5 that
//! project into the ground masks of at least two scan views ([`GroundConfig`]). The RANSAC
//! threshold is `plane.ransac.threshold` × the scan cameras' extent; the plane is oriented so the
//! scan cameras are above it.

use crate::camera::camera_to_world;
use crate::data::Prior4dCapture;
use crate::error::Prior4dError;
use crate::plane::{Plane, PlaneFit, RansacConfig, ScaleFrame, initial_scale, ransac_plane};
use splatzoo_datasets::masks::Mask;
use splatzoo_rasterizer::{Camera, Splats};
use splatzoo_train::avatar::project;
use splatzoo_train::host_f32;

/// How ground points are chosen and the plane fitted.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GroundConfig {
    /// Scene Gaussians at least this opaque are candidates (spec: 0.5).
    pub min_opacity: f64,
    /// Ground-mask hits a candidate needs.
    pub min_views: usize,
    /// RANSAC; its `threshold` is a fraction of the scan cameras' extent.
    pub ransac: RansacConfig,
}

impl Default for GroundConfig {
    fn default() -> Self {
        Self {
            min_opacity: 0.5,
            min_views: 2,
            ransac: RansacConfig::default(),
        }
    }
}

/// What stage C found.
#[derive(Debug, Clone)]
pub struct Initialisation {
    pub fit: PlaneFit,
    /// Ground-point candidates RANSAC saw.
    pub candidates: usize,
    /// From the plane, or the configured value.
    pub sigma0: f64,
}

/// Centres of the scene's Gaussians at least `min_opacity` opaque seen inside the ground mask
/// of at least `min_views` scan views (the acting frames' where no scan view has a ground pixel:
/// a real scan given without ground masks).
pub fn ground_points(
    scene: &Splats,
    capture: &Prior4dCapture,
    config: &GroundConfig,
) -> Vec<[f64; 3]> {
    let logit = (config.min_opacity / (1.0 - config.min_opacity)).ln() as f32;
    let means = host_f32(&scene.means);
    let opacity = host_f32(&scene.opacity_logits);
    let points: Vec<[f32; 3]> = means
        .chunks(3)
        .zip(&opacity)
        .filter(|(_, o)| **o >= logit)
        .map(|(p, _)| [p[0], p[1], p[2]])
        .collect();
    let mut hits = vec![0usize; points.len()];
    let masked: Vec<(&Camera, &Mask)> = if capture.scene_scan.iter().any(|v| v.ground.area() > 0) {
        capture
            .scene_scan
            .iter()
            .map(|v| (&v.camera, &v.ground))
            .collect()
    } else {
        capture
            .trained_frames()
            .map(|f| (&f.camera, &f.ground))
            .collect()
    };
    for (camera, ground) in masked {
        let (w, h) = (ground.width, ground.height);
        for (k, (u, v, z)) in project(camera, &points).into_iter().enumerate() {
            if z > 0.0
                && u >= 0.0
                && v >= 0.0
                && (u as usize) < w
                && (v as usize) < h
                && ground.get(u as usize, v as usize)
            {
                hits[k] += 1;
            }
        }
    }
    points
        .iter()
        .zip(hits)
        .filter(|(_, n)| *n >= config.min_views)
        .map(|(p, _)| p.map(f64::from))
        .collect()
}

/// π from the scene prior's ground points, oriented towards the scan cameras.
pub fn fit_floor(
    scene: &Splats,
    capture: &Prior4dCapture,
    config: &GroundConfig,
    extent: f64,
) -> Result<(PlaneFit, usize), Prior4dError> {
    let points = ground_points(scene, capture, config);
    let ransac = RansacConfig {
        threshold: config.ransac.threshold * extent,
        ..config.ransac
    };
    let mut fit = ransac_plane(&points, &ransac)?;
    let n = capture.scene_scan.len().max(1) as f64;
    let mean_centre = [0, 1, 2].map(|k| {
        capture
            .scene_scan
            .iter()
            .map(|v| f64::from(v.camera.position()[k]))
            .sum::<f64>()
            / n
    });
    fit.plane = fit.plane.oriented_towards(mean_centre);
    Ok((fit, points.len()))
}

/// σ₀ from π: each acting frame's SfM camera and the prior body's camera-space foot vertices
/// (`feet[t]`, metres).
pub fn sigma_from_plane(
    plane: &Plane,
    capture: &Prior4dCapture,
    feet: &[Vec<[f64; 3]>],
    contact_count: usize,
) -> Result<f64, Prior4dError> {
    let frames: Vec<ScaleFrame> = capture
        .acting
        .iter()
        .zip(feet)
        .map(|(frame, feet)| {
            let (rotation, centre) = camera_to_world(&frame.camera);
            ScaleFrame {
                rotation,
                centre,
                feet,
            }
        })
        .collect();
    initial_scale(plane, &frames, contact_count)
}
