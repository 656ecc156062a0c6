//! The mean body as a smooth union of ellipsoids and round cones: torso, neck, head with a
//! jaw, nose and ears, arms with deltoids, hands (palm, joined fingers, thumb), legs with calves,
//! and feet. Each solid names the joints whose bones may own its surface and the edge length its
//! surface gets (finer on the face and hands).

use super::sdf::{Body, Primitive, Solid, V3};

/// Blend radius of the smooth union, metres.
const BLEND: f64 = 0.022;

const TORSO_EDGE: f64 = 0.024;
const LIMB_EDGE: f64 = 0.020;
const HEAD_EDGE: f64 = 0.013;
const FACE_EDGE: f64 = 0.007;
const HAND_EDGE: f64 = 0.008;
const FOOT_EDGE: f64 = 0.013;

fn ellipsoid(centre: V3, radii: V3, joints: &[usize], edge: f64) -> Primitive {
    Primitive {
        solid: Solid::Ellipsoid { centre, radii },
        joints: joints.to_vec(),
        edge,
    }
}

fn cone(a: V3, b: V3, ra: f64, rb: f64, joints: &[usize], edge: f64) -> Primitive {
    Primitive {
        solid: Solid::RoundCone { a, b, ra, rb },
        joints: joints.to_vec(),
        edge,
    }
}

/// Mirrors a left-side solid to the right (x → −x, left joint → right joint).
fn mirrored(p: &Primitive) -> Primitive {
    let flip = |v: V3| [-v[0], v[1], v[2]];
    let solid = match p.solid {
        Solid::Ellipsoid { centre, radii } => Solid::Ellipsoid {
            centre: flip(centre),
            radii,
        },
        Solid::RoundCone { a, b, ra, rb } => Solid::RoundCone {
            a: flip(a),
            b: flip(b),
            ra,
            rb,
        },
    };
    // SMPL numbers left/right pairs consecutively (left first) except the central chain.
    let joints = p
        .joints
        .iter()
        .map(|&j| match j {
            1 | 4 | 7 | 10 | 13 | 16 | 18 | 20 | 22 => j + 1,
            _ => j,
        })
        .collect();
    Primitive {
        solid,
        joints,
        edge: p.edge,
    }
}

/// The mean body's implicit surface.
pub fn mean_body() -> Body {
    let central = vec![
        // Pelvis and buttocks, belly, chest, shoulder girdle.
        ellipsoid(
            [0.0, -0.255, 0.005],
            [0.160, 0.105, 0.110],
            &[0, 3],
            TORSO_EDGE,
        ),
        ellipsoid(
            [0.0, -0.085, 0.012],
            [0.140, 0.130, 0.105],
            &[0, 3, 6],
            TORSO_EDGE,
        ),
        ellipsoid(
            [0.0, 0.105, 0.002],
            [0.160, 0.145, 0.112],
            &[6, 9],
            TORSO_EDGE,
        ),
        // Neck.
        cone(
            [0.0, 0.20, -0.022],
            [0.0, 0.36, 0.002],
            0.058,
            0.050,
            &[12],
            LIMB_EDGE,
        ),
        // Head: skull, jaw, nose.
        ellipsoid([0.0, 0.432, 0.022], [0.078, 0.105, 0.096], &[15], HEAD_EDGE),
        ellipsoid([0.0, 0.372, 0.048], [0.058, 0.058, 0.068], &[15], FACE_EDGE),
        ellipsoid([0.0, 0.412, 0.118], [0.012, 0.022, 0.018], &[15], FACE_EDGE),
    ];
    let left = vec![
        ellipsoid(
            [0.072, -0.305, -0.045],
            [0.082, 0.085, 0.080],
            &[0, 1],
            TORSO_EDGE,
        ),
        // Shoulder girdle and deltoid.
        cone(
            [0.02, 0.225, -0.022],
            [0.185, 0.228, -0.020],
            0.060,
            0.050,
            &[9, 13],
            TORSO_EDGE,
        ),
        ellipsoid(
            [0.205, 0.222, -0.020],
            [0.068, 0.058, 0.058],
            &[13, 16],
            LIMB_EDGE,
        ),
        // Ear.
        ellipsoid(
            [0.078, 0.425, 0.008],
            [0.012, 0.030, 0.020],
            &[15],
            FACE_EDGE,
        ),
        // Arm.
        cone(
            [0.20, 0.227, -0.020],
            [0.454, 0.221, -0.040],
            0.050,
            0.038,
            &[16],
            LIMB_EDGE,
        ),
        cone(
            [0.454, 0.221, -0.040],
            [0.712, 0.229, -0.046],
            0.037,
            0.026,
            &[18],
            LIMB_EDGE,
        ),
        // Hand: palm (palms face −y in the T-pose), joined fingers, thumb.
        ellipsoid(
            [0.782, 0.226, -0.050],
            [0.058, 0.017, 0.044],
            &[20],
            HAND_EDGE,
        ),
        ellipsoid(
            [0.868, 0.222, -0.058],
            [0.058, 0.012, 0.039],
            &[22],
            HAND_EDGE,
        ),
        cone(
            [0.750, 0.214, -0.010],
            [0.815, 0.208, 0.040],
            0.014,
            0.010,
            &[20],
            HAND_EDGE,
        ),
        // Leg.
        cone(
            [0.076, -0.33, 0.020],
            [0.104, -0.678, 0.014],
            0.085,
            0.054,
            &[1],
            LIMB_EDGE,
        ),
        cone(
            [0.104, -0.678, 0.014],
            [0.088, -1.090, -0.027],
            0.051,
            0.034,
            &[4],
            LIMB_EDGE,
        ),
        ellipsoid(
            [0.100, -0.800, -0.020],
            [0.048, 0.100, 0.052],
            &[4],
            LIMB_EDGE,
        ),
        // Foot: sole at y = −1.175, heel to toe along +z.
        ellipsoid(
            [0.102, -1.140, 0.035],
            [0.045, 0.035, 0.108],
            &[7, 10],
            FOOT_EDGE,
        ),
    ];
    let mut primitives = central;
    for p in &left {
        primitives.push(p.clone());
        primitives.push(mirrored(p));
    }
    Body::new(primitives, BLEND)
}
