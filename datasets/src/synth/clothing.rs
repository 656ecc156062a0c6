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

/// A posed built-in body (`vertices`, triangles `faces`) with [`relief`] applied along its
/// vertex normals.
pub fn dress(vertices: &[[f32; 3]], faces: &[[u32; 3]]) -> Vec<[f32; 3]> {
    let normals = vertex_normals(vertices, faces);
    vertices
        .iter()
        .zip(&normals)
        .zip(relief())
        .map(|((p, n), &d)| [p[0] + d * n[0], p[1] + d * n[1], p[2] + d * n[2]])
        .collect()
}
