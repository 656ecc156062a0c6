//! The built-in body's skeleton and its shape space.
//!
//! The rest pose is SMPL's: a T-pose, metres, y up, facing +z, the body's left on +x, joints in
//! SMPL's order and tree (positions close to SMPL's neutral template, so a 72-D SMPL pose looks
//! right on it). Every joint owns one bone, a segment from the joint to its tail (its child, or an
//! end point for leaves); the surface is bound to bones (see `rig`), so a shape component is just
//! a change of bone ends and of radial scale around each bone. All of that is affine in the shape
//! coefficients, which makes the shape blend shapes exact.

use super::sdf::V3;
use crate::body::skeleton::SMPL_PARENTS;

pub const JOINTS: usize = 24;

/// What each shape coefficient does, at +1 (about one standard deviation of adults).
pub const SHAPE_COMPONENTS: [&str; 12] = [
    "height (uniform size)",
    "girth (torso and limb circumference)",
    "leg length",
    "arm length",
    "shoulder width",
    "hip width",
    "torso length",
    "chest depth",
    "belly",
    "head size",
    "neck length",
    "limb muscularity",
];

pub const SHAPE_COUNT: usize = SHAPE_COMPONENTS.len();

/// Mean rest joints, left side at +x (right side mirrored).
const MEAN_JOINTS: [V3; JOINTS] = [
    [0.0, -0.223, 0.028],    // pelvis
    [0.069, -0.314, 0.023],  // left_hip
    [-0.069, -0.314, 0.023], // right_hip
    [0.0, -0.104, -0.014],   // spine1
    [0.104, -0.678, 0.014],  // left_knee
    [-0.104, -0.678, 0.014], // right_knee
    [0.0, 0.031, 0.006],     // spine2
    [0.088, -1.098, -0.027], // left_ankle
    [-0.088, -1.098, -0.027],
    [0.0, 0.085, 0.030],    // spine3
    [0.120, -1.152, 0.094], // left_foot
    [-0.120, -1.152, 0.094],
    [0.0, 0.288, -0.024],   // neck
    [0.077, 0.190, -0.009], // left_collar
    [-0.077, 0.190, -0.009],
    [0.0, 0.351, 0.048],     // head
    [0.195, 0.237, -0.017],  // left_shoulder
    [-0.195, 0.237, -0.017], // right_shoulder
    [0.454, 0.221, -0.040],  // left_elbow
    [-0.454, 0.221, -0.040],
    [0.720, 0.230, -0.046], // left_wrist
    [-0.720, 0.230, -0.046],
    [0.806, 0.224, -0.064], // left_hand
    [-0.806, 0.224, -0.064],
];

/// Tail of each joint's bone. Non-leaves point at their (main) child.
const TAIL_OF: [Tail; JOINTS] = [
    Tail::Joint(3),  // pelvis → spine1
    Tail::Joint(4),  // hips → knees
    Tail::Joint(5),  //
    Tail::Joint(6),  // spine1 → spine2
    Tail::Joint(7),  // knees → ankles
    Tail::Joint(8),  //
    Tail::Joint(9),  // spine2 → spine3
    Tail::Joint(10), // ankles → feet
    Tail::Joint(11), //
    Tail::Joint(12), // spine3 → neck
    Tail::End([0.122, -1.160, 0.165]),
    Tail::End([-0.122, -1.160, 0.165]),
    Tail::Joint(15), // neck → head
    Tail::Joint(16), // collars → shoulders
    Tail::Joint(17),
    Tail::End([0.0, 0.535, 0.020]), // head → top of the skull
    Tail::Joint(18),                // shoulders → elbows
    Tail::Joint(19),
    Tail::Joint(20), // elbows → wrists
    Tail::Joint(21),
    Tail::Joint(22), // wrists → hands
    Tail::Joint(23),
    Tail::End([0.925, 0.221, -0.060]), // hands → fingertips
    Tail::End([-0.925, 0.221, -0.060]),
];

#[derive(Clone, Copy)]
enum Tail {
    Joint(usize),
    End(V3),
}

/// Radial scale of the surface around a bone: x, y, and z split into front (+z) and back.
pub type Radial = [f64; 4];

/// Bone ends and radial scales for one shape vector. Affine in the coefficients.
#[derive(Debug, Clone)]
pub struct Skeleton {
    pub heads: [V3; JOINTS],
    pub tails: [V3; JOINTS],
    pub radial: [Radial; JOINTS],
}

const TORSO: [usize; 4] = [0, 3, 6, 9];
const LEFT_ARM: [usize; 4] = [16, 18, 20, 22];
const RIGHT_ARM: [usize; 4] = [17, 19, 21, 23];
const LEFT_LEG: [usize; 4] = [1, 4, 7, 10];
const RIGHT_LEG: [usize; 4] = [2, 5, 8, 11];

fn is_limb(j: usize) -> bool {
    LEFT_ARM.contains(&j)
        || RIGHT_ARM.contains(&j)
        || LEFT_LEG.contains(&j)
        || RIGHT_LEG.contains(&j)
}

/// Joints strictly below `j` in the tree (its descendants).
fn descendants(j: usize) -> Vec<usize> {
    let mut out = Vec::new();
    for (k, &parent) in SMPL_PARENTS.iter().enumerate() {
        let mut p = parent;
        while let Some(q) = p {
            if q == j {
                out.push(k);
                break;
            }
            p = SMPL_PARENTS[q];
        }
    }
    out
}

impl Skeleton {
    /// The mean body.
    pub fn mean() -> Self {
        let heads = MEAN_JOINTS;
        let tails = std::array::from_fn(|j| match TAIL_OF[j] {
            Tail::Joint(k) => MEAN_JOINTS[k],
            Tail::End(p) => p,
        });
        Self {
            heads,
            tails,
            radial: [[1.0; 4]; JOINTS],
        }
    }

    /// The skeleton for shape coefficients `betas` (missing ones are 0).
    pub fn shaped(betas: &[f64]) -> Self {
        let mut s = Self::mean();
        let base = Self::mean();
        for (k, &b) in betas.iter().enumerate().take(SHAPE_COUNT) {
            if b != 0.0 {
                base.component(k, b, &mut s);
            }
        }
        s
    }

    /// Stretches the bone chain below joint `root` (joint positions and tails of its
    /// descendants, and its own tail) away from `root` by `factor` − 1, using mean positions.
    fn stretch_below(&self, root: usize, amount: f64, out: &mut Self) {
        let origin = self.heads[root];
        let mut moved = descendants(root);
        moved.push(root);
        for &k in &moved {
            for (c, &o) in origin.iter().enumerate() {
                if k != root {
                    out.heads[k][c] += amount * (self.heads[k][c] - o);
                }
                out.tails[k][c] += amount * (self.tails[k][c] - o);
            }
        }
    }

    /// Translates joint `root` and everything below it.
    fn translate_below(&self, root: usize, delta: V3, out: &mut Self) {
        let mut moved = descendants(root);
        moved.push(root);
        for &k in &moved {
            for (c, &d) in delta.iter().enumerate() {
                out.heads[k][c] += d;
                out.tails[k][c] += d;
            }
        }
    }

    /// Adds `b` times component `k` (evaluated on `self`, the mean) to `out`.
    fn component(&self, k: usize, b: f64, out: &mut Self) {
        let all = 0..JOINTS;
        match k {
            0 => {
                let a = 0.055 * b;
                for j in all {
                    for c in 0..3 {
                        out.heads[j][c] += a * self.heads[j][c];
                        out.tails[j][c] += a * self.tails[j][c];
                    }
                    for r in &mut out.radial[j] {
                        *r += a;
                    }
                }
            }
            1 => {
                for j in all {
                    let a = if TORSO.contains(&j) {
                        0.10
                    } else if is_limb(j) && ![20, 21, 22, 23, 7, 8, 10, 11].contains(&j) {
                        0.08
                    } else if j == 12 {
                        0.05
                    } else {
                        0.0
                    } * b;
                    for r in &mut out.radial[j] {
                        *r += a;
                    }
                }
                for (hip, side) in [(1, 1.0), (2, -1.0)] {
                    self.translate_below(hip, [0.008 * b * side, 0.0, 0.0], out);
                }
            }
            2 => {
                for hip in [1, 2] {
                    self.stretch_below(hip, 0.06 * b, out);
                }
            }
            3 => {
                for shoulder in [16, 17] {
                    self.stretch_below(shoulder, 0.06 * b, out);
                }
            }
            4 => {
                for (collar, side) in [(13, 1.0), (14, -1.0)] {
                    out.tails[collar][0] += 0.018 * b * side;
                    self.translate_below(collar + 3, [0.018 * b * side, 0.0, 0.0], out);
                }
                out.radial[9][0] += 0.06 * b;
            }
            5 => {
                for (hip, side) in [(1, 1.0), (2, -1.0)] {
                    self.translate_below(hip, [0.012 * b * side, 0.0, 0.0], out);
                }
                out.radial[0][0] += 0.09 * b;
                out.radial[3][0] += 0.04 * b;
            }
            6 => {
                // Spine and everything above the pelvis moves up in proportion to height above it.
                let origin_y = self.heads[0][1];
                let a = 0.07 * b;
                out.tails[0][1] += a * (self.tails[0][1] - origin_y);
                for j in [3, 6, 9] {
                    out.heads[j][1] += a * (self.heads[j][1] - origin_y);
                    out.tails[j][1] += a * (self.tails[j][1] - origin_y);
                }
                let neck_dy = a * (self.heads[12][1] - origin_y);
                self.translate_below(12, [0.0, neck_dy, 0.0], out);
                for collar in [13, 14] {
                    let dy = a * (self.heads[collar][1] - origin_y);
                    self.translate_below(collar, [0.0, dy, 0.0], out);
                }
            }
            7 => {
                for j in [6, 9] {
                    out.radial[j][2] += 0.12 * b;
                    out.radial[j][3] += 0.05 * b;
                }
            }
            8 => {
                for (j, a) in [(0, 0.10), (3, 0.22), (6, 0.12)] {
                    out.radial[j][2] += a * b;
                }
            }
            9 => {
                for c in 0..3 {
                    out.tails[15][c] += 0.07 * b * (self.tails[15][c] - self.heads[15][c]);
                }
                for r in &mut out.radial[15] {
                    *r += 0.07 * b;
                }
            }
            10 => {
                let dy = 0.018 * b;
                self.translate_below(15, [0.0, dy, 0.0], out);
                out.tails[12][1] += dy;
            }
            11 => {
                for j in all {
                    if is_limb(j) && ![22, 23, 10, 11].contains(&j) {
                        for r in &mut out.radial[j] {
                            *r += 0.08 * b;
                        }
                    }
                }
            }
            _ => unreachable!("shape component {k} of {SHAPE_COUNT}"),
        }
    }
}
