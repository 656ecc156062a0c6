//! What 2-D keypoints mark on a body: joints, vertices or points on triangles; OpenPose's
//! layouts (BODY_25, the 21-point hands, the 70-point face) on SMPL-layout bodies; SMPLify's
//! torso subset.
//!
//! Body points are joints or landmarks; a hand's wrist and finger joints are joints found by
//! their SMPL-H / SMPL-X names (`left_index1`…; a 24-joint body has none, so only its wrist and
//! the fingertips its landmarks mark count) and its fingertips landmarks; the face's brows,
//! nose, eyes and mouth are SMPL-X's barycentric face landmarks where the model file has them
//! (else its nose tip and mouth are named landmarks), its chin and pupils named landmarks. The face contour apart from
//! the chin (SMPL-X's dynamic landmarks, which follow the head's turn) stays unused.

use crate::body::BodyModel;

/// What a keypoint marks on the body.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum KeypointTarget {
    Joint(usize),
    Vertex(usize),
    /// A point on a triangle: its three vertices and barycentric weights (SMPL-X's face
    /// landmarks).
    Surface {
        vertices: [usize; 3],
        weights: [f32; 3],
    },
}

impl KeypointTarget {
    /// Where the target is on a body whose joints and vertices `joint` and `vertex` give.
    pub fn locate(
        self,
        joint: impl Fn(usize) -> [f64; 3],
        vertex: impl Fn(usize) -> [f64; 3],
    ) -> [f64; 3] {
        match self {
            KeypointTarget::Joint(j) => joint(j),
            KeypointTarget::Vertex(v) => vertex(v),
            KeypointTarget::Surface { vertices, weights } => {
                let mut p = [0.0; 3];
                for (&v, &w) in vertices.iter().zip(&weights) {
                    let q = vertex(v);
                    for k in 0..3 {
                        p[k] += f64::from(w) * q[k];
                    }
                }
                p
            }
        }
    }
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
/// `landmark` names (`nose_tip`, `left_eye`, `right_ear`, `left_toe`, `left_small_toe`,
/// `left_heel`, …; a landmark the body lacks, as the built-in body's small toes, leaves its
/// point unused).
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
        vertex("left_small_toe"),
        vertex("left_heel"),
        vertex("right_toe"),
        vertex("right_small_toe"),
        vertex("right_heel"),
    ]
}

/// A hand.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Hand {
    Left,
    Right,
}

impl Hand {
    /// The joint-name and landmark prefix (`left`, `right`).
    pub fn side(self) -> &'static str {
        match self {
            Hand::Left => "left",
            Hand::Right => "right",
        }
    }
}

/// OpenPose's fingers in its hand layout's order, four points each after the wrist (point 0):
/// three joints from the base (the thumb's carpometacarpal joint first) and the tip.
const HAND_FINGERS: [&str; 5] = ["thumb", "index", "middle", "ring", "pinky"];

/// What each point of OpenPose's 21-point `hand` marks on a body with joints `joint_names`:
/// the wrist joint, the finger joints `{side}_{finger}{1,2,3}` where the model has them, and
/// the fingertips by the landmarks `{side}_{finger}_tip` (the middle finger's is
/// `{side}_fingertip`, the one every table has).
pub fn hand21_targets(
    hand: Hand,
    joint_names: &[String],
    landmark: impl Fn(&str) -> Option<u32>,
) -> [Option<KeypointTarget>; 21] {
    let side = hand.side();
    let joint = |name: String| {
        joint_names
            .iter()
            .position(|n| *n == name)
            .map(KeypointTarget::Joint)
    };
    let mut targets = [None; 21];
    targets[0] = joint(format!("{side}_wrist"));
    for (f, finger) in HAND_FINGERS.iter().enumerate() {
        for k in 0..3 {
            targets[1 + 4 * f + k] = joint(format!("{side}_{finger}{}", k + 1));
        }
        let tip = match *finger {
            "middle" => format!("{side}_fingertip"),
            _ => format!("{side}_{finger}_tip"),
        };
        targets[4 + 4 * f] = landmark(&tip).map(|v| KeypointTarget::Vertex(v as usize));
    }
    targets
}

/// The first of OpenPose's face points SMPL-X's 51 static landmarks mark (17–67 in order).
pub const FACE_EMBEDDING_START: usize = 17;

/// What each point of OpenPose's 70-point face (the 68-point iBUG layout and the two pupils)
/// marks on `model`: points 17–67 (brows, nose, eyes, mouth) on its face landmarks where it
/// has SMPL-X's 51 ([`BodyModel::face_landmarks`]); else, and for the chin and the pupils, the
/// landmarks `landmark` names — the chin (8), the nose tip (30), the mouth (62, the upper inner
/// lip's middle, where a closed mouth's slit is), the pupils (68 right, 69 left). The rest of
/// the contour (0–16 but the chin: SMPL-X's dynamic landmarks) stays unused.
pub fn face70_targets(
    model: &BodyModel,
    landmark: impl Fn(&str) -> Option<u32>,
) -> [Option<KeypointTarget>; 70] {
    let mut targets = [None; 70];
    for (point, name) in [
        (8, "chin"),
        (30, "nose_tip"),
        (62, "mouth"),
        (68, "right_eye"),
        (69, "left_eye"),
    ] {
        targets[point] = landmark(name).map(|v| KeypointTarget::Vertex(v as usize));
    }
    if let Some(landmarks) = &model.face_landmarks
        && landmarks.len() == 51
    {
        for (k, l) in landmarks.iter().enumerate() {
            let f = 3 * l.face as usize;
            // A validated model's faces hold every landmark's triangle; an unvalidated one
            // loses the landmarks it does not.
            if let Some(&[a, b, c]) = model.faces.get(f..f + 3) {
                targets[FACE_EMBEDDING_START + k] = Some(KeypointTarget::Surface {
                    vertices: [a as usize, b as usize, c as usize],
                    weights: l.weights,
                });
            }
        }
    }
    targets
}

/// What a whole OpenPose person (body, face, both hands) marks on one body.
#[derive(Debug, Clone, PartialEq)]
pub struct PersonTargets {
    pub body: [Option<KeypointTarget>; 25],
    pub face: [Option<KeypointTarget>; 70],
    pub left_hand: [Option<KeypointTarget>; 21],
    pub right_hand: [Option<KeypointTarget>; 21],
}

impl PersonTargets {
    /// The targets on `model`, whose surface landmarks `landmark` names.
    pub fn new(model: &BodyModel, landmark: impl Fn(&str) -> Option<u32>) -> Self {
        Self {
            body: body25_targets(&landmark),
            face: face70_targets(model, &landmark),
            left_hand: hand21_targets(Hand::Left, &model.joint_names, &landmark),
            right_hand: hand21_targets(Hand::Right, &model.joint_names, &landmark),
        }
    }

    /// One person's keypoints as observations: `body` (BODY_25), `face` (70) and the hands
    /// (21 each), each part empty where the detector gave none.
    pub fn observations(
        &self,
        body: &[[f32; 3]],
        face: &[[f32; 3]],
        left_hand: &[[f32; 3]],
        right_hand: &[[f32; 3]],
    ) -> Vec<Observation> {
        [
            keypoint_observations(body, &self.body),
            keypoint_observations(face, &self.face),
            keypoint_observations(left_hand, &self.left_hand),
            keypoint_observations(right_hand, &self.right_hand),
        ]
        .concat()
    }
}

/// One frame's keypoints of one layout (`[x, y, confidence]` in pixels, in the layout's order; a
/// missed point is `[0, 0, 0]`) as observations of a body whose points `targets` names
/// ([`body25_targets`], [`hand21_targets`], [`face70_targets`]): the points without a target
/// are dropped, and so are all of them where the detector gave none (`keypoints` empty).
pub fn keypoint_observations(
    keypoints: &[[f32; 3]],
    targets: &[Option<KeypointTarget>],
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
