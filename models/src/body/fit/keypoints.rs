//! What 2-D keypoints mark on a body: joints or surface vertices, OpenPose's BODY_25 layout
//! on SMPL-layout bodies, and SMPLify's torso subset.

/// What a keypoint marks on the body.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum KeypointTarget {
    Joint(usize),
    Vertex(usize),
}

/// One 2-D keypoint: what it marks, where it is (pixels), how sure the detector was.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Observation {
    pub target: KeypointTarget,
    pub pixel: [f64; 2],
    pub confidence: f64,
}

/// What each BODY_25 keypoint marks on an SMPL-layout body (joints 0–23; SMPL-X shares its
/// first 22): body joints by index, and the face and feet points by the surface landmarks
/// `landmark` names (`nose_tip`, `left_eye`, `right_ear`, `left_toe`, `left_heel`, …; `None`
/// leaves a point unused, as the small toes always are).
pub fn body25_targets(landmark: impl Fn(&str) -> Option<u32>) -> [Option<KeypointTarget>; 25] {
    let joint = |j: usize| Some(KeypointTarget::Joint(j));
    let vertex = |name: &str| landmark(name).map(|v| KeypointTarget::Vertex(v as usize));
    [
        vertex("nose_tip"),
        joint(12),
        joint(17),
        joint(19),
        joint(21),
        joint(16),
        joint(18),
        joint(20),
        joint(0),
        joint(2),
        joint(5),
        joint(8),
        joint(1),
        joint(4),
        joint(7),
        vertex("right_eye"),
        vertex("left_eye"),
        vertex("right_ear"),
        vertex("left_ear"),
        vertex("left_toe"),
        None,
        vertex("left_heel"),
        vertex("right_toe"),
        None,
        vertex("right_heel"),
    ]
}

/// One frame's BODY_25 keypoints (`[x, y, confidence]` in pixels, OpenPose's order; a missed
/// point is `[0, 0, 0]`) as observations of a body whose points `targets` names
/// ([`body25_targets`]): the points without a target are dropped.
pub fn body25_observations(
    keypoints: &[[f32; 3]],
    targets: &[Option<KeypointTarget>; 25],
) -> Vec<Observation> {
    targets
        .iter()
        .zip(keypoints)
        .filter_map(|(target, k)| {
            target.map(|t| Observation {
                target: t,
                pixel: [f64::from(k[0]), f64::from(k[1])],
                confidence: f64::from(k[2]),
            })
        })
        .collect()
}

/// SMPLify's torso for the orientation stage: shoulders and hips (SMPL joints).
pub const TORSO: [KeypointTarget; 5] = [
    KeypointTarget::Joint(0),
    KeypointTarget::Joint(1),
    KeypointTarget::Joint(2),
    KeypointTarget::Joint(16),
    KeypointTarget::Joint(17),
];

/// The heels and big toes (surface landmarks `landmark` names), the points a floor constraint
/// ([`super::FitConfig::ground`]) holds; missing landmarks are left out.
pub fn foot_targets(landmark: impl Fn(&str) -> Option<u32>) -> Vec<KeypointTarget> {
    ["left_heel", "right_heel", "left_toe", "right_toe"]
        .iter()
        .filter_map(|n| landmark(n))
        .map(|v| KeypointTarget::Vertex(v as usize))
        .collect()
}
