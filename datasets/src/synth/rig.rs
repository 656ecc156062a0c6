//! Camera rigs of the synthetic captures: the THuman2.0/GHG multi-view ring, a hand-held camera
//! walking around a person with a fixed evaluation camera (the Prior-4D protocol), and
//! forward-facing cameras on a moving vehicle (a Waymo-like driving log). Cameras use the
//! rasterizer's OpenCV convention; the world is y up.

use super::rng::Rng;
use glam::DVec3;
use splatzoo_rasterizer::Camera;

/// One camera's pose and intrinsics at every frame (fixed cameras repeat).
#[derive(Debug, Clone, PartialEq)]
pub struct CameraTrack {
    pub name: String,
    pub cameras: Vec<Camera>,
}

/// Image size and horizontal field of view.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lens {
    pub width: u32,
    pub height: u32,
    pub fov_x_degrees: f64,
}

fn look_at(position: DVec3, target: DVec3, lens: Lens) -> Camera {
    Camera::look_at(
        position.as_vec3().to_array(),
        target.as_vec3().to_array(),
        [0.0, 1.0, 0.0],
        lens.fov_x_degrees as f32,
        lens.width,
        lens.height,
    )
}

/// `count` cameras evenly around `target` at `distance`, pitched by `pitch_degrees` (negative
/// looks down), the first in front of the person (+z).
pub fn ring(
    count: usize,
    distance: f64,
    pitch_degrees: f64,
    target: DVec3,
    lens: Lens,
) -> Vec<Camera> {
    let pitch = pitch_degrees.to_radians();
    (0..count)
        .map(|k| {
            let azimuth = k as f64 * std::f64::consts::TAU / count as f64;
            let back = DVec3::new(
                azimuth.sin() * pitch.cos(),
                -pitch.sin(),
                azimuth.cos() * pitch.cos(),
            );
            look_at(target + back * distance, target, lens)
        })
        .collect()
}

/// A hand-held camera circling the room's centre at `radius` and about eye height, one turn
/// per `period` seconds, aimed at the person (`targets`, one per frame) with the sway and aim
/// jitter of a walking operator.
pub fn handheld_orbit(
    targets: &[DVec3],
    radius: f64,
    period: f64,
    fps: f64,
    seed: u64,
    lens: Lens,
) -> Vec<Camera> {
    let mut rng = Rng(seed ^ 0x4A4D_0000);
    let phase = rng.range(0.0, std::f64::consts::TAU);
    let wobble: [f64; 6] = std::array::from_fn(|_| rng.range(0.0, std::f64::consts::TAU));
    targets
        .iter()
        .enumerate()
        .map(|(f, &target)| {
            let t = f as f64 / fps;
            let angle = phase + std::f64::consts::TAU * t / period;
            // Step bounce at ~1.8 Hz, slower drift in radius and aim.
            let bounce = 0.025 * (2.0 * std::f64::consts::PI * 1.8 * t + wobble[0]).sin();
            let r = radius + 0.15 * (0.7 * t + wobble[1]).sin();
            let position = DVec3::new(
                r * angle.sin(),
                1.45 + bounce + 0.05 * (0.5 * t + wobble[2]).sin(),
                r * angle.cos(),
            );
            let aim = DVec3::new(
                0.06 * (1.3 * t + wobble[3]).sin(),
                0.05 * (1.1 * t + wobble[4]).sin(),
                0.06 * (0.9 * t + wobble[5]).sin(),
            );
            look_at(position, target + aim, lens)
        })
        .collect()
}

/// A camera standing still at `position`, aimed at `target`, for `frames` frames.
pub fn fixed(position: DVec3, target: DVec3, frames: usize, lens: Lens) -> Vec<Camera> {
    vec![look_at(position, target, lens); frames]
}

/// The ego vehicle: driving along +z in a lane at constant speed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EgoPath {
    pub lane_x: f64,
    pub start_z: f64,
    pub speed: f64,
}

impl EgoPath {
    pub fn position(&self, t: f64) -> DVec3 {
        DVec3::new(self.lane_x, 0.0, self.start_z + self.speed * t)
    }
}

/// Cameras on the ego vehicle's roof, 1.55 m up and 1.5 m ahead of its origin, each yawed left
/// (positive, towards +x) or right from the driving direction and pitched 4° down.
pub fn vehicle(
    path: EgoPath,
    frames: usize,
    fps: f64,
    mounts: &[(&str, f64)],
    lens: Lens,
) -> Vec<CameraTrack> {
    let pitch = (-4.0f64).to_radians();
    mounts
        .iter()
        .map(|&(name, yaw_degrees)| {
            let yaw = yaw_degrees.to_radians();
            let forward = DVec3::new(
                yaw.sin() * pitch.cos(),
                pitch.sin(),
                yaw.cos() * pitch.cos(),
            );
            let cameras = (0..frames)
                .map(|f| {
                    let position = path.position(f as f64 / fps) + DVec3::new(0.0, 1.55, 1.5);
                    look_at(position, position + forward, lens)
                })
                .collect();
            CameraTrack {
                name: name.into(),
                cameras,
            }
        })
        .collect()
}
