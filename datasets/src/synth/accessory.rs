//! Accessories carried by the synthetic people, each its own mesh attached to one joint: a
//! backpack to the upper spine, a suitcase or a handbag to the left wrist (the right hand
//! waves). They are what APF-GS splits into child nodes of the human, and what its coarse
//! (human ∪ accessory) masks fail to separate.
//!
//! Each accessory is modelled in the world around the body in the relaxed carrying pose (arms
//! lowered; see [`crate::synth::motion::relaxed_pose`]) and stored in its joint's frame, so at
//! any frame `x = R_joint · x_local + p_joint`. The backpack and the suitcase are rigid in that
//! frame; the handbag is not: it swings as a pendulum about its grip ([`Swing`]), so at time `t`
//! `x_local = R_swing(t) · (x_rest − grip) + grip`.

use super::mesh::MeshBuilder;
use crate::posing::PosedFrame;
use glam::{DMat3, DVec3};

/// The joint a backpack hangs from (SMPL `spine3`).
pub const BACKPACK_JOINT: usize = 9;
/// The joint a suitcase or handbag hangs from (SMPL `left_wrist`).
pub const CARRY_JOINT: usize = 20;

#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum AccessoryKind {
    Backpack,
    Suitcase,
    Handbag,
}

/// A pendulum swing about the grip: `amplitude · sin(2π t / period)` radians about `axis`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Swing {
    /// Radians.
    pub amplitude: f64,
    /// Seconds.
    pub period: f64,
    /// Unit axis in the joint's frame: across the walking direction (the body's left-right).
    pub axis: [f64; 3],
}

/// The handbag's swing: ±15° …
const HANDBAG_SWING_DEGREES: f64 = 15.0;
/// … with a 1.2 s period (about a 36 cm pendulum's).
const HANDBAG_SWING_PERIOD: f64 = 1.2;

#[derive(Debug, Clone, PartialEq)]
pub struct Accessory {
    pub kind: AccessoryKind,
    /// The joint it is attached to.
    pub joint: usize,
    /// Mesh in the joint's frame (positions), with colours per vertex; at rest for a swinging
    /// accessory.
    pub mesh: MeshBuilder,
    /// Where it is held, in the joint's frame: the bags' grip, the backpack's carrying loop.
    /// A swing turns about it.
    pub grip: [f64; 3],
    /// `None` for a rigid accessory.
    pub swing: Option<Swing>,
}

fn mat(m: &[[f32; 3]; 3]) -> DMat3 {
    DMat3::from_cols_array_2d(&m.map(|r| r.map(f64::from))).transpose()
}

fn vec(p: [f32; 3]) -> DVec3 {
    DVec3::from(p.map(f64::from))
}

impl Accessory {
    /// Builds `kind` in `colour` around `reference`: the person's body posed in the carrying
    /// pose at the origin, heading +z, and `parts` the bone label of each vertex.
    pub fn fit(
        kind: AccessoryKind,
        colour: [f32; 3],
        reference: &PosedFrame,
        parts: &[u8],
    ) -> Self {
        let dark = colour.map(|c| c * 0.45);
        let mut world = MeshBuilder::default();
        let joints: Vec<DVec3> = reference.joints.iter().map(|&p| vec(p)).collect();
        let (joint, grip) = match kind {
            AccessoryKind::Backpack => {
                // Against the back between the lower and upper spine joints.
                let (low, high) = (joints[6].y - 0.05, joints[9].y + 0.08);
                let back = reference
                    .vertices
                    .iter()
                    .zip(parts)
                    .filter(|(p, part)| {
                        matches!(part, 0 | 3 | 6 | 9) && (low..high).contains(&(p[1] as f64))
                    })
                    .map(|(p, _)| p[2] as f64)
                    .fold(f64::INFINITY, f64::min);
                let (w, h, d) = (0.30, 0.42, 0.15);
                // 2 cm off the skin: clear of a jacket's folds ([`super::clothing`], ≤ 15 mm).
                let centre = DVec3::new(joints[9].x, 0.5 * (low + high), back - 0.02 - 0.5 * d);
                world.oriented_box(
                    centre,
                    DVec3::new(0.5 * w, 0.5 * h, 0.5 * d),
                    DMat3::IDENTITY,
                    colour,
                );
                // A front pocket and a carrying loop on top.
                world.oriented_box(
                    centre + DVec3::new(0.0, -0.08, -0.5 * d - 0.03),
                    DVec3::new(0.11, 0.1, 0.03),
                    DMat3::IDENTITY,
                    dark,
                );
                let loop_centre = centre + DVec3::new(0.0, 0.5 * h + 0.02, 0.0);
                world.oriented_box(
                    loop_centre,
                    DVec3::new(0.05, 0.02, 0.015),
                    DMat3::IDENTITY,
                    dark,
                );
                (BACKPACK_JOINT, loop_centre)
            }
            AccessoryKind::Suitcase | AccessoryKind::Handbag => {
                let wrist = joints[CARRY_JOINT];
                let elbow = joints[CARRY_JOINT - 2];
                // The grip sits a palm's length down the forearm's line, just below the wrist.
                let along = (wrist - elbow).normalize_or(DVec3::NEG_Y);
                let grip = wrist + along * 0.08;
                let (w, h, d, lift) = match kind {
                    AccessoryKind::Suitcase => (0.38, 0.50, 0.16, 0.07),
                    _ => (0.30, 0.22, 0.10, 0.12),
                };
                // Thin side towards the body, hanging straight down, pushed clear of the thigh.
                let top = grip.y - lift;
                let centre = DVec3::new(grip.x + 0.5 * d + 0.02, top - 0.5 * h, grip.z);
                world.oriented_box(
                    centre,
                    DVec3::new(0.5 * d, 0.5 * h, 0.5 * w),
                    DMat3::IDENTITY,
                    colour,
                );
                // Handle: two posts and a bar up to the grip.
                let post = 0.012;
                for side in [-1.0, 1.0] {
                    let foot = DVec3::new(centre.x, top, grip.z + side * 0.06);
                    world.oriented_box(
                        foot + DVec3::new(0.0, 0.5 * lift, 0.0),
                        DVec3::new(post, 0.5 * lift, post),
                        DMat3::IDENTITY,
                        dark,
                    );
                }
                let bar = DVec3::new(centre.x, grip.y, grip.z);
                world.oriented_box(
                    bar,
                    DVec3::new(post, post, 0.06 + post),
                    DMat3::IDENTITY,
                    dark,
                );
                (CARRY_JOINT, bar)
            }
        };
        // World (carrying pose) → joint frame.
        let inverse = mat(&reference.joint_rotations[joint]).transpose();
        let origin = joints[joint];
        for p in &mut world.positions {
            *p = (inverse * (vec(*p) - origin)).as_vec3().to_array();
        }
        // The handbag swings forwards and backwards: about the body's left-right axis (x in the
        // carrying pose, which faces +z).
        let swing = (kind == AccessoryKind::Handbag).then(|| Swing {
            amplitude: HANDBAG_SWING_DEGREES.to_radians(),
            period: HANDBAG_SWING_PERIOD,
            axis: (inverse * DVec3::X).normalize().to_array(),
        });
        Self {
            kind,
            joint,
            mesh: world,
            grip: (inverse * (grip - origin)).to_array(),
            swing,
        }
    }

    /// The swing's angle at `time` seconds (0 for a rigid accessory).
    pub fn swing_angle(&self, time: f64) -> f64 {
        self.swing.map_or(0.0, |s| {
            s.amplitude * (std::f64::consts::TAU * time / s.period).sin()
        })
    }

    /// World positions of the mesh in `frame`, at `time` seconds (which only a swing reads).
    pub fn place(&self, frame: &PosedFrame, time: f64) -> Vec<[f32; 3]> {
        let rotation = mat(&frame.joint_rotations[self.joint]);
        let origin = vec(frame.joints[self.joint]);
        let local: Vec<DVec3> = match self.swing {
            None => self.mesh.positions.iter().map(|&p| vec(p)).collect(),
            Some(swing) => {
                let angle = self.swing_angle(time);
                let turn = DMat3::from_axis_angle(DVec3::from(swing.axis), angle);
                let grip = DVec3::from(self.grip);
                self.mesh
                    .positions
                    .iter()
                    .map(|&p| turn * (vec(p) - grip) + grip)
                    .collect()
            }
        };
        local
            .into_iter()
            .map(|p| (rotation * p + origin).as_vec3().to_array())
            .collect()
    }

    /// World position of the grip in `frame`: the point a swing turns about.
    pub fn grip_in_world(&self, frame: &PosedFrame) -> [f32; 3] {
        let rotation = mat(&frame.joint_rotations[self.joint]);
        (rotation * DVec3::from(self.grip) + vec(frame.joints[self.joint]))
            .as_vec3()
            .to_array()
    }
}
