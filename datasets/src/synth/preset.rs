//! The scenes each method trains on by default, built from a seed: a multi-view studio subject
//! (NLF-GS), a person in a room filmed hand-held (Prior-4D, Illum), pedestrians with
//! accessories crossing a street in front of a car (APF-GS), a static yard (3DGS).
//!
//! The driving scene carries what makes APF-GS's claims measurable (its spec, "Synthetic-only
//! testing"): a window of frames where the prior fails ([`PriorCorruption`]), clothing relief the
//! body model lacks ([`super::clothing`]), an untracked passer-by, a swinging handbag
//! ([`super::accessory::Swing`]), people tall on screen and 60 frames. A LiDAR stand-in and
//! coarse-mask variants come from any rendered view ([`super::sensors`]).

use super::accessory::AccessoryKind;
use super::environment::{self, CROSSING_Z, Environment, KERB, ROAD_HALF_WIDTH};
use super::identity::Identity;
use super::motion::{Motion, Start, generate};
use super::prior::{PriorCorruption, PriorNoise};
use super::rig::{self, CameraTrack, EgoPath, Lens};
use super::rng::Rng;
use super::scene::{Person, Preset, Scene, standing_height};
use crate::render::{Light, Lighting, RenderSettings};
use burn::tensor::Device;
use glam::DVec3;
use std::f64::consts::PI;

/// Who a person is, how they move, where they start (ground position, heading, ground
/// height), what they carry and whether a body tracker follows them.
struct Role<'a> {
    identity: Identity,
    motions: &'a [Motion],
    start: ([f64; 2], f64, f64),
    accessories: &'a [(AccessoryKind, [f32; 3])],
    tracked: bool,
}

/// What to build.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneConfig {
    pub preset: Preset,
    pub seed: u64,
    pub width: u32,
    pub height: u32,
    /// Frames to generate; the preset's default when `None`.
    pub frames: Option<usize>,
    pub noise: PriorNoise,
    /// A tracker failure added to every tracked person's prior after `noise`; the driving
    /// preset's is [`PriorCorruption::driving`], the others have none.
    pub corruption: Option<PriorCorruption>,
    /// Whether people wear the clothing relief ([`super::clothing`]); on for the driving preset
    /// only.
    pub clothing_relief: bool,
    /// Samples per pixel along each axis.
    pub supersample: usize,
    /// Shadow-map resolution; `None` turns shadows off.
    pub shadow_resolution: Option<usize>,
}

impl SceneConfig {
    /// The preset's defaults.
    pub fn new(preset: Preset, seed: u64) -> Self {
        let (width, height) = match preset {
            Preset::Multiview | Preset::Static => (256, 256),
            Preset::Monocular => (320, 240),
            Preset::Driving => (384, 216),
        };
        Self {
            preset,
            seed,
            width,
            height,
            frames: None,
            noise: PriorNoise::default(),
            corruption: (preset == Preset::Driving).then(PriorCorruption::driving),
            clothing_relief: preset == Preset::Driving,
            supersample: 2,
            shadow_resolution: Some(1024),
        }
    }

    fn lens(&self, fov_x_degrees: f64) -> Lens {
        Lens {
            width: self.width,
            height: self.height,
            fov_x_degrees,
        }
    }

    /// Builds the scene: people posed for every frame, cameras placed; nothing rendered yet.
    pub fn build(&self, device: &Device) -> Scene {
        match self.preset {
            Preset::Multiview => self.multiview(device),
            Preset::Monocular => self.monocular(device),
            Preset::Driving => self.driving(device),
            Preset::Static => self.yard(device),
        }
    }

    /// The scene around `people`; `light` is the light and the ambient level.
    fn scene(
        &self,
        fps: f64,
        environment: Environment,
        people: Vec<Person>,
        tracks: Vec<CameraTrack>,
        (light, ambient): (Light, f32),
    ) -> Scene {
        Scene {
            frame_count: tracks[0].cameras.len(),
            preset: self.preset,
            seed: self.seed,
            fps,
            environment,
            people,
            tracks,
            lighting: Lighting {
                ambient: [ambient; 3],
                environment: None,
                light: Some(light),
                shadow_resolution: self.shadow_resolution,
            },
            noise: self.noise,
            corruption: self.corruption.clone(),
            settings: RenderSettings {
                background: [0.0; 3],
                supersample: self.supersample,
            },
        }
    }

    fn person(&self, role: Role, fps: f64, frames: usize, salt: u64, device: &Device) -> Person {
        let Role {
            identity,
            motions,
            start: (position, heading, ground),
            accessories,
            tracked,
        } = role;
        let start = Start {
            position,
            heading,
            standing_height: ground + standing_height(&identity.betas, device),
        };
        let mut motion = generate(motions, start, fps);
        truncate(&mut motion, frames);
        let mut person = Person::new(
            identity,
            &motion,
            accessories,
            &self.noise,
            self.seed ^ salt,
            device,
        );
        person.tracked = tracked;
        person.clothed = self.clothing_relief;
        if let (true, Some(corruption)) = (tracked, &self.corruption) {
            corruption.apply(&mut person.prior);
        }
        person
    }

    /// One subject turning on the spot and waving, seen by the 16-camera ring 2 m away at −8°
    /// pitch, looking at (0, 0.85, 0), in an empty studio.
    fn multiview(&self, device: &Device) -> Scene {
        let fps = 2.0;
        let frames = self.frames.unwrap_or(4);
        let motions = [
            Motion::Turn {
                seconds: 1.0,
                angle: 0.4,
            },
            Motion::Wave { seconds: 1.0 },
            Motion::Idle { seconds: 60.0 },
        ];
        let person = self.person(
            Role {
                identity: Identity::sample(self.seed),
                motions: &motions,
                start: ([0.0, 0.0], 0.0, 0.0),
                accessories: &[],
                tracked: true,
            },
            fps,
            frames,
            1,
            device,
        );
        let cameras = rig::ring(16, 2.0, -8.0, DVec3::new(0.0, 0.85, 0.0), self.lens(50.0));
        let tracks = cameras
            .into_iter()
            .enumerate()
            .map(|(k, camera)| CameraTrack {
                name: format!("ring_{k:02}"),
                cameras: vec![camera; frames],
            })
            .collect();
        self.scene(
            fps,
            Environment::default(),
            vec![person],
            tracks,
            (
                Light::Directional {
                    direction: [0.3, -1.0, -0.6],
                    color: [0.65; 3],
                },
                0.45,
            ),
        )
    }

    /// A person walking a circle in a furnished room, waving, then standing; a hand-held camera
    /// circles them and a fixed camera watches from a corner. Lit by a ceiling point light.
    fn monocular(&self, device: &Device) -> Scene {
        let fps = 10.0;
        let frames = self.frames.unwrap_or(60);
        let radius = 0.8;
        let speed = 0.7;
        let motions = [
            Motion::Walk {
                seconds: 3.0,
                speed,
                turn_rate: speed / radius,
            },
            Motion::Wave { seconds: 2.0 },
            Motion::Idle { seconds: 60.0 },
        ];
        let person = self.person(
            Role {
                identity: Identity::sample(self.seed),
                motions: &motions,
                start: ([-radius, 0.0], 0.0, 0.0),
                accessories: &[],
                tracked: true,
            },
            fps,
            frames,
            1,
            device,
        );
        let targets: Vec<DVec3> = (0..frames)
            .map(|f| {
                let t = person.motion.translation(f);
                DVec3::new(t[0], t[1], t[2])
            })
            .collect();
        let lens = self.lens(65.0);
        let tracks = vec![
            CameraTrack {
                name: "handheld".into(),
                cameras: rig::handheld_orbit(&targets, 2.6, 12.0, fps, self.seed, lens),
            },
            CameraTrack {
                name: "fixed".into(),
                cameras: rig::fixed(
                    DVec3::new(3.0, 1.8, 3.0),
                    DVec3::new(0.0, 0.8, 0.0),
                    frames,
                    lens,
                ),
            },
        ];
        let mut rng = Rng(self.seed ^ 0x1164_7000);
        let light = Light::Point {
            position: [
                rng.range(-1.5, 1.5) as f32,
                2.7,
                rng.range(-1.5, 1.5) as f32,
            ],
            color: [5.0, 4.7, 4.2],
        };
        self.scene(
            fps,
            environment::room(self.seed, 8.0, 3.0),
            vec![person],
            tracks,
            (light, 0.3),
        )
    }

    /// A car creeping (1 m/s) towards a zebra crossing; three pedestrians (a backpack, a
    /// suitcase, a handbag) cross in front of it, a fourth (carrying nothing) walks along the
    /// left sidewalk towards the car, and a fifth, whom no tracker follows, along the right one
    /// (people 0–4 in that order).
    /// Front, front-left and front-right cameras; afternoon sun; 60 frames at 10 fps by
    /// default, so a stride-15 split holds out frames 14, 29, 44 and 59.
    ///
    /// Geometry (metres, the car drives along +z in the right lane, x = −1.75; left is +x): the
    /// roof cameras sit 1.5 m ahead of the car and 1.55 m up, at z = 13.5 + t, from 10.5 m
    /// before the crossing's centre (z = 24) to 4.6 m at frame 59, never reaching its near edge
    /// (z = 22). The crossing walkers keep to z = 23, 24.3 and 25.2, 9.5–11.7 m from the cameras
    /// at the start and 3.6–5.8 m at frame 59, so at 384×216 and 70° across (f ≈ 274 px) a
    /// 1.7 m person is 40–50 px tall at first and 80–130 px at the end, feet in view
    /// throughout (they leave the 4°-pitched image closer than 3.3 m). They walk at 0.9–1.05 m/s
    /// (slower on clips too long to cross otherwise) and stay between the kerbs, |x| ≤ 3.2,
    /// which the three cameras (±35° ahead and 10°–80° to either side) always cover.
    fn driving(&self, device: &Device) -> Scene {
        let fps = 10.0;
        let frames = self.frames.unwrap_or(60);
        let duration = frames.saturating_sub(1) as f64 / fps;
        let mut rng = Rng(self.seed ^ 0xD41F_E000);
        let walkers: [(AccessoryKind, f64, f64); 3] = [
            (AccessoryKind::Backpack, 1.0, -1.0),
            (AccessoryKind::Suitcase, -1.0, 0.3),
            (AccessoryKind::Handbag, 1.0, 1.2),
        ];
        let kerb = ROAD_HALF_WIDTH - 0.3;
        let mut people = Vec::new();
        for (k, &(kind, direction, dz)) in walkers.iter().enumerate() {
            // Crossing from one kerb towards the other, some already on their way, none
            // reaching the far kerb before the clip ends.
            let speed = rng.range(0.9, 1.05).min(2.0 * kerb / duration);
            let travel = speed * duration;
            let x = direction * (kerb - rng.range(0.0, (2.0 * kerb - travel).max(0.0)));
            let heading = if direction > 0.0 { -PI / 2.0 } else { PI / 2.0 };
            let colour = super::identity::colour_between(&mut rng, 0.15, 0.7);
            people.push(self.person(
                Role {
                    identity: Identity::sample(self.seed.wrapping_add(k as u64 + 1)),
                    motions: &[Motion::Walk {
                        seconds: 60.0,
                        speed,
                        turn_rate: 0.0,
                    }],
                    start: ([x, CROSSING_Z + dz], heading, 0.0),
                    accessories: &[(kind, colour)],
                    tracked: true,
                },
                fps,
                frames,
                k as u64 + 1,
                device,
            ));
        }
        // Along the sidewalks towards the car: side, start ahead of the crossing, speed, and
        // whether tracked.
        let sidewalks = [(1.0, 6.0, 1.3, true), (-1.0, 3.0, 0.8, false)];
        for (k, (side, ahead, speed, tracked)) in sidewalks.into_iter().enumerate() {
            let salt = k as u64 + 4;
            people.push(self.person(
                Role {
                    identity: Identity::sample(self.seed.wrapping_add(salt)),
                    motions: &[Motion::Walk {
                        seconds: 60.0,
                        speed,
                        turn_rate: 0.0,
                    }],
                    start: (
                        [side * (ROAD_HALF_WIDTH + 1.5), CROSSING_Z + ahead],
                        PI,
                        KERB,
                    ),
                    accessories: &[],
                    tracked,
                },
                fps,
                frames,
                salt,
                device,
            ));
        }
        let path = EgoPath {
            lane_x: -0.5 * ROAD_HALF_WIDTH,
            start_z: CROSSING_Z - 12.0,
            speed: 1.0,
        };
        let tracks = rig::vehicle(
            path,
            frames,
            fps,
            &[("front", 0.0), ("front_left", 45.0), ("front_right", -45.0)],
            self.lens(70.0),
        );
        self.scene(
            fps,
            environment::street(self.seed, CROSSING_Z + 60.0),
            people,
            tracks,
            (
                Light::Directional {
                    direction: [0.5, -0.8, 0.35],
                    color: [0.8, 0.78, 0.7],
                },
                0.35,
            ),
        )
    }

    /// A person standing still among crates in a paved yard, one frame seen by 48 cameras on
    /// three rings (0.6 m, 1.5 m and 2.6 m high, 3.5 m out).
    fn yard(&self, device: &Device) -> Scene {
        let frames = self.frames.unwrap_or(1);
        let person = self.person(
            Role {
                identity: Identity::sample(self.seed),
                motions: &[Motion::Idle { seconds: 60.0 }],
                start: ([0.0, 0.0], 0.3, 0.0),
                accessories: &[],
                tracked: true,
            },
            1.0,
            frames,
            1,
            device,
        );
        let target = DVec3::new(0.0, 0.7, 0.0);
        let mut tracks = Vec::new();
        for (ring, height) in [0.6, 1.5, 2.6].into_iter().enumerate() {
            let elevation = (height - target.y).atan2(3.5);
            let distance = 3.5 / elevation.cos();
            let cameras = rig::ring(
                16,
                distance,
                -elevation.to_degrees(),
                target,
                self.lens(60.0),
            );
            for (k, camera) in cameras.into_iter().enumerate() {
                tracks.push(CameraTrack {
                    name: format!("ring{ring}_{k:02}"),
                    cameras: vec![camera; frames],
                });
            }
        }
        self.scene(
            1.0,
            environment::yard(self.seed),
            vec![person],
            tracks,
            (
                Light::Directional {
                    direction: [-0.4, -0.9, -0.3],
                    color: [0.7; 3],
                },
                0.4,
            ),
        )
    }
}

fn truncate(seq: &mut crate::pose_sequence::PoseSequence, frames: usize) {
    assert!(
        seq.frames() >= frames,
        "motion of {} frames, {frames} asked",
        seq.frames()
    );
    seq.poses.truncate(frames * 3 * seq.joints);
    seq.translations.truncate(frames * 3);
    seq.betas.truncate(frames * seq.shape_count);
}
