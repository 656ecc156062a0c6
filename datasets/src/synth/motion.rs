//! Procedural SMPL-layout motion: walk cycles along a heading, turns on the spot, a wave, sitting
//! down and standing up, chained with cross-fades into one continuous pose sequence with a global
//! trajectory on the ground plane (y up, ground at y = 0).
//!
//! Joint conventions (SMPL rest pose, facing +z, left on +x): a leg swings forward with a
//! negative rotation about x at the hip and the knee bends with a positive one; an arm is lowered
//! from the T-pose about z (negative on the left); an elbow bends forward about y (negative on the
//! left). Global orientation is a heading about y.

use crate::pose_sequence::PoseSequence;
use std::f64::consts::PI;

type M3 = [[f64; 3]; 3];

fn rot(axis: [f64; 3], angle: f64) -> M3 {
    let n = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
    let k = [axis[0] / n, axis[1] / n, axis[2] / n];
    let (s, c) = angle.sin_cos();
    let mut r = [[0.0; 3]; 3];
    for (i, row) in r.iter_mut().enumerate() {
        for (j, x) in row.iter_mut().enumerate() {
            *x = if i == j { c } else { 0.0 } + (1.0 - c) * k[i] * k[j];
        }
    }
    r[0][1] -= s * k[2];
    r[0][2] += s * k[1];
    r[1][0] += s * k[2];
    r[1][2] -= s * k[0];
    r[2][0] -= s * k[1];
    r[2][1] += s * k[0];
    r
}

fn mul(a: M3, b: M3) -> M3 {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
}

/// Axis-angle of a rotation matrix (angle in [0, π]).
fn log(r: M3) -> [f64; 3] {
    let cos = ((r[0][0] + r[1][1] + r[2][2] - 1.0) * 0.5).clamp(-1.0, 1.0);
    let angle = cos.acos();
    let v = [r[2][1] - r[1][2], r[0][2] - r[2][0], r[1][0] - r[0][1]];
    if angle < 1e-9 {
        return [0.5 * v[0], 0.5 * v[1], 0.5 * v[2]];
    }
    if PI - angle < 1e-6 {
        // Axis from the largest diagonal term of (R + I) / 2.
        let i = (0..3)
            .max_by(|&a, &b| r[a][a].total_cmp(&r[b][b]))
            .expect("3 axes");
        let mut axis = [0.0; 3];
        for (j, a) in axis.iter_mut().enumerate() {
            *a = 0.5 * (r[i][j] + r[j][i]) + if i == j { 0.5 } else { 0.0 };
        }
        let n = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
        return axis.map(|a| a / n * angle);
    }
    let s = angle / (2.0 * angle.sin());
    v.map(|x| x * s)
}

/// One segment of a motion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Motion {
    /// Walking at `speed` m/s, turning at `turn_rate` rad/s.
    Walk {
        seconds: f64,
        speed: f64,
        turn_rate: f64,
    },
    /// Turning on the spot by `angle` radians with small steps.
    Turn { seconds: f64, angle: f64 },
    /// Waving the right hand overhead.
    Wave { seconds: f64 },
    /// Sitting down onto a seat `seat_drop` metres lower, holding, standing up again.
    SitStand { seconds: f64, seat_drop: f64 },
    /// Standing still (relaxed arms).
    Idle { seconds: f64 },
}

impl Motion {
    fn seconds(&self) -> f64 {
        match *self {
            Motion::Walk { seconds, .. }
            | Motion::Turn { seconds, .. }
            | Motion::Wave { seconds }
            | Motion::SitStand { seconds, .. }
            | Motion::Idle { seconds } => seconds,
        }
    }
}

/// Local joint rotations of one frame (joint 0 excluded: heading is applied separately) and how
/// far the pelvis is lowered.
struct Frame {
    local: [M3; 24],
    drop: f64,
}

fn relaxed() -> [M3; 24] {
    let mut local = [rot([1.0, 0.0, 0.0], 0.0); 24];
    local[16] = rot([0.0, 0.0, 1.0], -1.25);
    local[17] = rot([0.0, 0.0, 1.0], 1.25);
    local[18] = rot([0.0, 1.0, 0.0], -0.15);
    local[19] = rot([0.0, 1.0, 0.0], 0.15);
    local
}

/// The SMPL-layout pose (72 axis-angle values, root at identity) of standing relaxed with the
/// arms lowered: the pose accessories are fitted in.
pub fn relaxed_pose() -> [f64; 72] {
    let local = relaxed();
    let mut pose = [0.0; 72];
    for j in 1..24 {
        pose[3 * j..3 * j + 3].copy_from_slice(&log(local[j]));
    }
    pose
}

/// A gait cycle at phase `phase` (radians), amplitude scaled by `amount` in [0, 1].
fn gait(phase: f64, amount: f64) -> Frame {
    let mut local = relaxed();
    let x = [1.0, 0.0, 0.0];
    let s = phase.sin();
    // Hips swing in antiphase; each knee bends most while its leg swings forward.
    local[1] = rot(x, -0.45 * amount * s);
    local[2] = rot(x, 0.45 * amount * s);
    local[4] = rot(
        x,
        amount * (0.15 + 0.55 * (phase + 0.6 * PI).sin().max(0.0)),
    );
    local[5] = rot(
        x,
        amount * (0.15 + 0.55 * (phase - 0.4 * PI).sin().max(0.0)),
    );
    local[7] = rot(x, -0.15 * amount * s);
    local[8] = rot(x, 0.15 * amount * s);
    // Arms swing against the legs.
    local[16] = mul(rot(x, 0.35 * amount * s), local[16]);
    local[17] = mul(rot(x, -0.35 * amount * s), local[17]);
    local[3] = rot([0.0, 1.0, 0.0], 0.08 * amount * s);
    let drop = 0.02 * amount * (1.0 - (2.0 * phase).cos()) * 0.5;
    Frame { local, drop }
}

/// The right arm raised, forearm up, swaying side to side at 1.5 Hz.
fn wave(t: f64) -> Frame {
    let mut local = relaxed();
    let z = [0.0, 0.0, 1.0];
    let sway = (2.0 * PI * 1.5 * t).sin();
    local[17] = rot(z, -0.3);
    local[19] = rot(z, -1.4 + 0.35 * sway);
    local[21] = rot(z, 0.2 * sway);
    Frame { local, drop: 0.0 }
}

/// Sitting depth in [0, 1] → pose and pelvis drop.
fn sit(depth: f64, seat_drop: f64) -> Frame {
    let mut local = relaxed();
    let x = [1.0, 0.0, 0.0];
    local[1] = rot(x, -1.5 * depth);
    local[2] = rot(x, -1.5 * depth);
    local[4] = rot(x, 1.5 * depth);
    local[5] = rot(x, 1.5 * depth);
    local[3] = rot(x, 0.15 * depth);
    Frame {
        local,
        drop: seat_drop * depth,
    }
}

/// Smooth 0 → 1 over [0, 1].
fn smoothstep(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

/// Blends two rotations by `w` (geodesic).
fn slerp(a: M3, b: M3, w: f64) -> M3 {
    let at: M3 = std::array::from_fn(|i| std::array::from_fn(|j| a[j][i]));
    let d = log(mul(at, b));
    mul(a, rot_vec(d.map(|x| x * w)))
}

fn rot_vec(v: [f64; 3]) -> M3 {
    let angle = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if angle < 1e-12 {
        return rot([1.0, 0.0, 0.0], 0.0);
    }
    rot(v, angle)
}

/// Where and how the person starts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Start {
    /// Ground position (x, z).
    pub position: [f64; 2],
    /// Heading about y; 0 faces +z.
    pub heading: f64,
    /// Pelvis height (the body's `trans` y) when standing on the ground.
    pub standing_height: f64,
}

/// Seconds of cross-fade between segments (at most the new segment's length): long enough that
/// raising an arm from the side to overhead keeps hands under 2 m/s.
const BLEND: f64 = 1.0;

/// Chains `motions` into a sequence sampled at `fps`.
pub fn generate(motions: &[Motion], start: Start, fps: f64) -> PoseSequence {
    let total: f64 = motions.iter().map(Motion::seconds).sum();
    let frames = (total * fps).round().max(1.0) as usize;
    let dt = 1.0 / fps;
    let mut poses = Vec::with_capacity(frames * 72);
    let mut translations = Vec::with_capacity(frames * 3);
    let (mut x, mut z, mut heading) = (start.position[0], start.position[1], start.heading);
    let mut phase = 0.0f64;
    for f in 0..frames {
        let t = f as f64 * dt;
        let (mut i, mut t0) = (0, 0.0);
        while i + 1 < motions.len() && t >= t0 + motions[i].seconds() {
            t0 += motions[i].seconds();
            i += 1;
        }
        let local_t = t - t0;
        let pose_of = |m: &Motion, lt: f64, phase: f64| -> Frame {
            match *m {
                Motion::Walk { .. } => gait(phase, 1.0),
                Motion::Turn { .. } => gait(phase, 0.35),
                Motion::Wave { .. } => wave(lt),
                Motion::SitStand { seconds, seat_drop } => {
                    let u = lt / seconds;
                    let depth = smoothstep(u / 0.3) - smoothstep((u - 0.7) / 0.3);
                    sit(depth, seat_drop)
                }
                Motion::Idle { .. } => Frame {
                    local: relaxed(),
                    drop: 0.0,
                },
            }
        };
        let mut frame = pose_of(&motions[i], local_t, phase);
        // Cross-fade from the previous segment's final pose during the first BLEND seconds.
        let fade = BLEND.min(motions[i].seconds());
        if i > 0 && local_t < fade {
            let prev = pose_of(&motions[i - 1], motions[i - 1].seconds(), phase);
            let w = smoothstep(local_t / fade);
            for j in 0..24 {
                frame.local[j] = slerp(prev.local[j], frame.local[j], w);
            }
            frame.drop = prev.drop + w * (frame.drop - prev.drop);
        }
        let mut pose = [0.0; 72];
        pose[0..3].copy_from_slice(&log(rot([0.0, 1.0, 0.0], heading)));
        for j in 1..24 {
            pose[3 * j..3 * j + 3].copy_from_slice(&log(frame.local[j]));
        }
        poses.extend_from_slice(&pose);
        translations.extend_from_slice(&[x, start.standing_height - frame.drop, z]);
        // Advance the trajectory.
        match motions[i] {
            Motion::Walk {
                speed, turn_rate, ..
            } => {
                // Stride 0.7 m per step, two steps per cycle.
                phase += 2.0 * PI * speed / 1.4 * dt;
                heading += turn_rate * dt;
                x += speed * heading.sin() * dt;
                z += speed * heading.cos() * dt;
            }
            Motion::Turn { seconds, angle } => {
                phase += 2.0 * PI * 0.9 * dt;
                heading += angle / seconds * dt;
            }
            _ => {}
        }
    }
    PoseSequence {
        joints: 24,
        poses,
        translations,
        betas: Vec::new(),
        shape_count: 0,
        fps: Some(fps),
    }
}
