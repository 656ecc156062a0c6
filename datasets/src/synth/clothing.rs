//! Clothing relief: geometry the body model lacks. The built-in body is a smooth skin; clothes
//! add folds. Here they are a displacement of each vertex along its posed normal, a scalar fixed
//! per vertex in the rest pose (so folds travel with the cloth):
//!
//! - wrinkle bands on the torso and the thighs (bones 0, 3, 6, 9 and 1, 2): two slightly tilted
//!   sinusoids across the body's height, 6 mm at 5 cm and 3 mm at 3.3 cm wavelength, faded out
//!   above the knees and below the armpits so the surface stays continuous where they end;
//! - a jacket hem: a ridge standing 15 mm out, 1.2 cm wide (Gaussian profile), around the hips
//!   just above the trousers' waistband, the wrinkles flattening under it.
//!
//! Every displacement stays within 15 mm. A scene renders its people with the relief while their
//! poses, joints and the body model the methods fit stay the plain ones, so the relief is what a
//! residual field has to learn.
//!
//! [`pose_relief`] adds clothing that moves with the pose, which no static offset can represent
//! (Prior-4D's ΔV_pose, spec §7's "trouser swing driven by hip and knee angles"):
//!
//! - trousers bunching at each knee: a ring 15 mm out at full bend, 4 cm wide (Gaussian profile
//!   about the rest knee height), growing with that knee's bend angle (full at 90°);
//! - the jacket hem flaring with the stride: its ridge stands up to 15 mm further out as the
//!   hips' bend angles sum to 60°.

use crate::render::vertex_normals;
use splatzoo_models::body::builtin_body;
use std::f64::consts::TAU;
use std::sync::OnceLock;

/// Bones whose surface is clothed with relief: pelvis and spine, thighs.
const CLOTHED_PARTS: [u8; 6] = [0, 3, 6, 9, 1, 2];

/// Wrinkle bands: amplitude (m), wavelength (m), and tilt (height change per metre across).
const WRINKLES: [(f64, f64, f64); 2] = [(0.006, 0.05, 0.2), (0.003, 0.033, -0.35)];

/// Rest-pose height of the jacket hem (the trousers start at −0.16), its half width and how far
/// it stands out, metres.
const HEM: (f64, f64, f64) = (-0.15, 0.012, 0.015);

/// Heights (rest pose) where the wrinkles fade in above the knees (−0.68) and fade out below
/// the collar bones and armpits (from about 0.14 up): each a ramp 8 cm long from its start.
const FADE_IN: f64 = -0.60;
const FADE_OUT: f64 = 0.04;
const FADE_LENGTH: f64 = 0.08;

fn smoothstep(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

/// Each built-in body vertex's displacement along its normal, metres, outwards positive.
pub fn relief() -> &'static [f32] {
    static RELIEF: OnceLock<Vec<f32>> = OnceLock::new();
    RELIEF.get_or_init(|| {
        let body = builtin_body();
        let t = &body.model.template;
        body.part_of_vertex
            .iter()
            .enumerate()
            .map(|(v, part)| {
                if !CLOTHED_PARTS.contains(part) {
                    return 0.0;
                }
                let (x, y) = (f64::from(t[3 * v]), f64::from(t[3 * v + 1]));
                let region = smoothstep((y - FADE_IN) / FADE_LENGTH)
                    * (1.0 - smoothstep((y - FADE_OUT) / FADE_LENGTH));
                let wrinkles: f64 = WRINKLES
                    .iter()
                    .map(|&(amplitude, wavelength, tilt)| {
                        amplitude * (TAU * (y + tilt * x) / wavelength).sin()
                    })
                    .sum();
                let (hem_height, hem_width, hem_ridge) = HEM;
                let hem = (-((y - hem_height) / hem_width).powi(2)).exp();
                (hem_ridge * hem + (1.0 - hem) * region * wrinkles) as f32
            })
            .collect()
    })
}

/// The knee bunching at full bend (m), its half width, the rest knee height, and the bend of
/// full bunching (radians).
const KNEE_RING: (f64, f64, f64, f64) = (0.015, 0.04, -0.678, std::f64::consts::FRAC_PI_2);

/// How far the hem flares at full stride (m), and the summed hip bend of a full stride.
const HEM_FLARE: (f64, f64) = (0.015, std::f64::consts::FRAC_PI_3);

/// Thigh and shin bones of each leg (left, right) and its knee joint.
const LEGS: [([u8; 2], usize); 2] = [([1, 4], 4), ([2, 5], 5)];

/// Hip joints.
const HIPS: [usize; 2] = [1, 2];

/// The bend of joint `j` in an SMPL-layout axis-angle `pose`: its rotation angle.
fn bend(pose: &[f64], j: usize) -> f64 {
    pose.get(3 * j..3 * j + 3)
        .map_or(0.0, |v| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt())
}

/// Each built-in body vertex's pose-dependent displacement along its normal (metres, outwards)
/// at `pose` (SMPL-layout axis-angles, `[72]`): see the module doc. Zero in the rest pose.
pub fn pose_relief(pose: &[f64]) -> Vec<f32> {
    let body = builtin_body();
    let t = &body.model.template;
    let (ring, ring_width, knee_height, full_bend) = KNEE_RING;
    let (flare, full_stride) = HEM_FLARE;
    let (hem_height, hem_width, _) = HEM;
    let knees = LEGS.map(|(_, knee)| ring * (bend(pose, knee) / full_bend).min(1.0));
    let stride = flare * ((bend(pose, HIPS[0]) + bend(pose, HIPS[1])) / full_stride).min(1.0);
    body.part_of_vertex
        .iter()
        .enumerate()
        .map(|(v, part)| {
            let y = f64::from(t[3 * v + 1]);
            let knee: f64 = LEGS
                .iter()
                .zip(knees)
                .filter(|((bones, _), _)| bones.contains(part))
                .map(|(_, amplitude)| amplitude * (-((y - knee_height) / ring_width).powi(2)).exp())
                .sum();
            let hem = if CLOTHED_PARTS.contains(part) {
                stride * (-((y - hem_height) / hem_width).powi(2)).exp()
            } else {
                0.0
            };
            (knee + hem) as f32
        })
        .collect()
}

/// A posed built-in body (`vertices`, triangles `faces`) with [`relief`] applied along its
/// vertex normals, and the pose-dependent [`pose_relief`] of `pose` where given.
pub fn dress(vertices: &[[f32; 3]], faces: &[[u32; 3]], pose: Option<&[f64]>) -> Vec<[f32; 3]> {
    let normals = vertex_normals(vertices, faces);
    let moving = pose.map(pose_relief);
    vertices
        .iter()
        .zip(&normals)
        .zip(relief())
        .enumerate()
        .map(|(v, ((p, n), &d))| {
            let d = d + moving.as_ref().map_or(0.0, |m| m[v]);
            [p[0] + d * n[0], p[1] + d * n[1], p[2] + d * n[2]]
        })
        .collect()
}
