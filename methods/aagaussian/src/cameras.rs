//! Random cameras as the base pipeline draws them (HumanGaussian's `uncond` data, spec §4),
//! and the fixed face camera (U7).
//!
//! A batch is one of three kinds, drawn per batch: body views (distance U[1.5, 2.0], fovy
//! U[40°, 70°], elevation half of the time uniform in degrees on [−30°, 30°] and half uniform
//! on the sphere over the same band, azimuths stratified over the batch across 360°, looking at
//! the origin); from `zoom_start` on, head-zoom views with probability `head.probability`
//! (distance U[0.4, 0.6], front hemisphere, target and eye raised to the head's height) and
//! back-zoom views with probability `back.probability` (U[0.6, 0.8], back hemisphere).
//! Azimuth 0 looks at the body's face (+z); the body's up is +y.

use crate::score::ViewClass;
use crate::sds::SdsView;
use serde::{Deserialize, Serialize};
use splatzoo_datasets::synth::rng::Rng;
use splatzoo_rasterizer::Camera;

/// A zoomed view's knobs.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ZoomConfig {
    /// Chance per batch.
    pub probability: f64,
    pub distance: [f64; 2],
    /// Azimuth range in degrees.
    pub azimuth: [f64; 2],
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CameraConfig {
    pub distance: [f64; 2],
    pub fovy_degrees: [f64; 2],
    pub elevation_degrees: [f64; 2],
    /// Share of batches whose elevations are uniform on the sphere (the rest uniform in
    /// degrees).
    pub sphere_fraction: f64,
    /// Zoomed views are drawn from this optimiser step on (the face-loss start).
    pub zoom_start: usize,
    pub head: ZoomConfig,
    pub back: ZoomConfig,
}

impl Default for CameraConfig {
    fn default() -> Self {
        Self {
            distance: [1.5, 2.0],
            fovy_degrees: [40.0, 70.0],
            elevation_degrees: [-30.0, 30.0],
            sphere_fraction: 0.5,
            zoom_start: 1200,
            head: ZoomConfig {
                probability: 0.25,
                distance: [0.4, 0.6],
                azimuth: [-90.0, 90.0],
            },
            back: ZoomConfig {
                probability: 0.2,
                distance: [0.6, 0.8],
                azimuth: [90.0, 270.0],
            },
        }
    }
}

/// What a batch was drawn as.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum BatchKind {
    Body,
    HeadZoom,
    BackZoom,
}

/// One sampled camera with the values it was drawn from.
#[derive(Debug, Clone, Copy)]
pub struct SampledView {
    pub camera: Camera,
    pub azimuth_degrees: f64,
    pub elevation_degrees: f64,
    pub distance: f64,
    pub fovy_degrees: f64,
    pub kind: BatchKind,
}

impl SampledView {
    pub fn view_class(&self) -> ViewClass {
        ViewClass::of(self.azimuth_degrees, self.elevation_degrees)
    }

    pub fn sds_view(&self) -> SdsView {
        SdsView {
            camera: self.camera,
            view: self.view_class(),
        }
    }
}

/// A camera at `distance` from `target` in direction (azimuth, elevation), looking at it, the
/// body's +y up, square `size` pixels with vertical field of view `fovy`.
pub fn orbit_camera(
    target: [f64; 3],
    azimuth_degrees: f64,
    elevation_degrees: f64,
    distance: f64,
    fovy_degrees: f64,
    size: u32,
) -> Camera {
    let (az, el) = (azimuth_degrees.to_radians(), elevation_degrees.to_radians());
    let direction = [el.cos() * az.sin(), el.sin(), el.cos() * az.cos()];
    let position = [0, 1, 2].map(|c| (target[c] + distance * direction[c]) as f32);
    let mut camera = Camera::look_at(
        position,
        target.map(|v| v as f32),
        [0.0, 1.0, 0.0],
        fovy_degrees as f32,
        size,
        size,
    );
    camera.near = 0.05;
    camera
}

impl CameraConfig {
    /// `batch` views for optimiser step `step` (0-based); `head_height` is the canonical head's
    /// height above the origin, in the body's normalised units.
    pub fn sample(
        &self,
        step: usize,
        batch: usize,
        size: u32,
        head_height: f64,
        rng: &mut Rng,
    ) -> Vec<SampledView> {
        let zoom = step >= self.zoom_start;
        let draw = rng.next();
        let kind = if zoom && draw < self.head.probability {
            BatchKind::HeadZoom
        } else if zoom && draw < self.head.probability + self.back.probability {
            BatchKind::BackZoom
        } else {
            BatchKind::Body
        };
        let on_sphere = rng.next() < self.sphere_fraction;
        let (azimuth, distance, target) = match kind {
            BatchKind::Body => ([-180.0, 180.0], self.distance, [0.0; 3]),
            BatchKind::HeadZoom => (
                self.head.azimuth,
                self.head.distance,
                [0.0, head_height, 0.0],
            ),
            BatchKind::BackZoom => (
                self.back.azimuth,
                self.back.distance,
                [0.0, head_height, 0.0],
            ),
        };
        (0..batch)
            .map(|i| {
                let az =
                    azimuth[0] + (azimuth[1] - azimuth[0]) * (i as f64 + rng.next()) / batch as f64;
                let [lo, hi] = self.elevation_degrees;
                let el = if on_sphere {
                    let (a, b) = (lo.to_radians().sin(), hi.to_radians().sin());
                    rng.range(a, b).asin().to_degrees()
                } else {
                    rng.range(lo, hi)
                };
                let d = rng.range(distance[0], distance[1]);
                let fovy = rng.range(self.fovy_degrees[0], self.fovy_degrees[1]);
                SampledView {
                    camera: orbit_camera(target, az, el, d, fovy, size),
                    azimuth_degrees: (az + 180.0).rem_euclid(360.0) - 180.0,
                    elevation_degrees: el,
                    distance: d,
                    fovy_degrees: fovy,
                    kind,
                }
            })
            .collect()
    }

    pub fn validate(&self) -> Result<(), String> {
        let ordered = |name: &str, r: [f64; 2], lo: f64, hi: f64| {
            if r[0] <= r[1] && r[0] >= lo && r[1] <= hi {
                Ok(())
            } else {
                Err(format!(
                    "cameras.{name} must be an ordered pair in [{lo}, {hi}], got {r:?}"
                ))
            }
        };
        ordered("distance", self.distance, 1e-3, 1e3)?;
        ordered("fovy_degrees", self.fovy_degrees, 1.0, 170.0)?;
        ordered("elevation_degrees", self.elevation_degrees, -89.0, 89.0)?;
        ordered("head.distance", self.head.distance, 1e-3, 1e3)?;
        ordered("back.distance", self.back.distance, 1e-3, 1e3)?;
        let p = self.head.probability + self.back.probability;
        if !(0.0..=1.0).contains(&self.sphere_fraction) || !(0.0..=1.0).contains(&p) {
            return Err("cameras: probabilities must lie in [0, 1] (head + back ≤ 1)".into());
        }
        Ok(())
    }
}
