//! Which joint an accessory hangs from, and where its Gaussians start (§II-D).
//!
//! The masks carry no class, so the paper's semantic rule (backpack → torso, suitcase →
//! wrist) becomes the label-free one of the spec: among the candidate joints (pelvis, the
//! three spine joints, both wrists), the parent is the joint in whose frame the accessory's
//! centroid stays most still, `k* = argmin_k spread_t[T_k(t)⁻¹ c_acc(t)]`, with `c_acc(t)`
//! the centroid of the LiDAR returns inside `M_acc^h` at frame `t` and `T_k(t)` the prior's
//! forward kinematics. Both statistics are robust (a per-axis median for the centroid, the
//! median distance to the median for the spread, instead of the spec's mean and variance;
//! joints whose spreads tie within 15 % are told apart by which is nearest the accessory):
//! a person's box can hold another person's bag or a mask's edge can catch the street behind,
//! and one such frame would otherwise decide. The returns carried into the chosen joint's
//! frame, within `INLIER_RADIUS` of their median, are the accessory's initial Gaussians.
//! An accessory node forced on (`decouple.accessories = true`) for a person whose mask has too
//! few returns to decide starts on the pelvis from [`fallback_points`].

use crate::data::{ApfCapture, TrackedPerson};
use splatzoo_datasets::posing::PosedFrame;
use splatzoo_datasets::synth::rng::Rng;
use splatzoo_train::views::InitPoints;
use splatzoo_train::views::init_points::{back_project, nearest_neighbour_scales};

/// SMPL's pelvis, spine1–3 and wrists.
pub const CANDIDATE_JOINTS: [usize; 6] = [0, 3, 6, 9, 20, 21];

/// Spreads within this fraction of the least are a tie.
pub const TIE: f64 = 0.15;

/// Initial points farther than this (metres) from the median of the returns in the parent
/// frame are outliers.
pub const INLIER_RADIUS: f32 = 0.4;

/// Per-axis median of points.
fn median(points: &[[f32; 3]]) -> [f32; 3] {
    std::array::from_fn(|a| {
        let mut v: Vec<f32> = points.iter().map(|p| p[a]).collect();
        v.sort_by(f32::total_cmp);
        v[v.len() / 2]
    })
}

fn distance(a: [f32; 3], b: [f32; 3]) -> f32 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// World points (with colours) of person `h`'s accessory mask under LiDAR and inside their
/// 3-D box, per frame.
pub fn accessory_returns(capture: &ApfCapture, h: usize) -> Vec<Vec<([f32; 3], [f32; 3])>> {
    let mut per_frame = vec![Vec::new(); capture.frames];
    for &i in &capture.train {
        let view = &capture.views[i];
        let Some(lidar) = &view.lidar else { continue };
        // One pixel in from the mask's edge, where a return may hit what lies behind.
        let inner = view.people[h].accessory.erode(1);
        if inner.area() == 0 {
            continue;
        }
        let depth: Vec<f32> = lidar
            .iter()
            .zip(&inner.data)
            .map(|(&d, &on)| if on { d } else { f32::NAN })
            .collect();
        let mut points = InitPoints::default();
        let srgb = splatzoo_train::host_f32(&view.image);
        back_project(&view.camera, &depth, &srgb, 1, &mut points);
        // A return outside the person's 3-D box belongs to someone or something else.
        let inside = |p: &[f32; 3]| {
            capture.people[h].boxes[view.frame]
                .is_some_and(|b| (0..3).all(|a| p[a] >= b[0][a] && p[a] <= b[1][a]))
        };
        per_frame[view.frame].extend(
            points
                .positions
                .into_iter()
                .zip(points.colours)
                .filter(|(p, _)| inside(p)),
        );
    }
    per_frame
}

/// `p` in joint `k`'s frame at a posed frame: `R_kᵀ (p − o_k)`.
pub fn to_joint_frame(frame: &PosedFrame, k: usize, p: [f32; 3]) -> [f32; 3] {
    let r = frame.joint_rotations[k];
    let o = frame.joints[k];
    let d = [p[0] - o[0], p[1] - o[1], p[2] - o[2]];
    std::array::from_fn(|c| (0..3).map(|i| r[i][c] * d[i]).sum())
}

/// The parent joint from per-frame returns, with each candidate's spread (metres, the median
/// distance of the frames' centroids from their median); `None` with fewer than two frames of
/// returns.
pub fn select_parent(
    person: &TrackedPerson,
    returns: &[Vec<([f32; 3], [f32; 3])>],
) -> Option<(usize, Vec<(usize, f64)>)> {
    let centroids: Vec<(usize, [f32; 3])> = returns
        .iter()
        .enumerate()
        .filter(|(_, r)| r.len() >= 3)
        .map(|(t, r)| (t, median(&r.iter().map(|(p, _)| *p).collect::<Vec<_>>())))
        .collect();
    if centroids.len() < 2 {
        return None;
    }
    // (joint, spread, distance of the accessory from the joint), in the joint's frame.
    let stats: Vec<(usize, f64, f64)> = CANDIDATE_JOINTS
        .iter()
        .map(|&k| {
            let local: Vec<[f32; 3]> = centroids
                .iter()
                .map(|&(t, c)| to_joint_frame(&person.prior_frames[t], k, c))
                .collect();
            let centre = median(&local);
            let mut d: Vec<f32> = local.iter().map(|&p| distance(p, centre)).collect();
            d.sort_by(f32::total_cmp);
            (
                k,
                f64::from(d[d.len() / 2]),
                f64::from(distance(centre, [0.0; 3])),
            )
        })
        .collect();
    let least = stats.iter().map(|s| s.1).fold(f64::INFINITY, f64::min);
    // Joints that move together (the spine's) tie within the centroid's noise; the nearest of
    // the tied joints is the parent.
    let best = stats
        .iter()
        .filter(|s| s.1 <= least * (1.0 + TIE))
        .min_by(|a, b| a.2.total_cmp(&b.2))
        .map(|s| s.0)?;
    let spreads = stats.iter().map(|s| (s.0, s.1)).collect();
    Some((best, spreads))
}

/// The accessory's initial points in joint `k`'s frame: every return carried by its frame's
/// prior, thinned to `keep`, with 3DGS's nearest-neighbour scales.
pub fn initial_points(
    person: &TrackedPerson,
    returns: &[Vec<([f32; 3], [f32; 3])>],
    k: usize,
    keep: usize,
    seed: u64,
) -> InitPoints {
    let mut all: Vec<([f32; 3], [f32; 3])> = returns
        .iter()
        .enumerate()
        .flat_map(|(t, r)| {
            r.iter()
                .map(move |&(p, c)| (to_joint_frame(&person.prior_frames[t], k, p), c))
        })
        .collect();
    if !all.is_empty() {
        let centre = median(&all.iter().map(|(p, _)| *p).collect::<Vec<_>>());
        all.retain(|(p, _)| distance(*p, centre) <= INLIER_RADIUS);
    }
    if all.len() > keep {
        Rng(seed).shuffle(&mut all);
        all.truncate(keep);
    }
    let positions: Vec<[f32; 3]> = all.iter().map(|(p, _)| *p).collect();
    InitPoints {
        sigmas: nearest_neighbour_scales(&positions, 3),
        colours: all.iter().map(|(_, c)| *c).collect(),
        positions,
    }
}

/// The pelvis (the fallback parent).
pub const PELVIS: usize = 0;

/// Where a forced accessory node starts when the LiDAR cannot place it: `keep` grey points
/// spread uniformly in a ball of 0.15 m around the pelvis, in its frame.
pub fn fallback_points(keep: usize, seed: u64) -> InitPoints {
    const RADIUS: f64 = 0.15;
    let mut rng = Rng(seed);
    let mut positions = Vec::with_capacity(keep);
    while positions.len() < keep {
        let p = [0; 3].map(|_: i32| rng.range(-RADIUS, RADIUS));
        if p.iter().map(|v| v * v).sum::<f64>() <= RADIUS * RADIUS {
            positions.push(p.map(|v| v as f32));
        }
    }
    InitPoints {
        sigmas: nearest_neighbour_scales(&positions, 3),
        colours: vec![[0.5; 3]; positions.len()],
        positions,
    }
}
