//! Skeleton priors for APF-GS's kinematic consistency loss (Eq. 7 of APF-GS:
//! `L_kine = λ_bone L_bone + λ_limit L_limit`): bone lengths, and box limits on each SMPL joint's
//! local axis-angle components.

use burn::tensor::{Tensor, TensorData, activation::relu};

/// `[B, J − 1]` lengths of the bones (joint to parent), in joint order skipping the root.
pub fn bone_lengths(joints: Tensor<3>, parents: &[Option<usize>]) -> Tensor<2> {
    let [b, j, _] = joints.dims();
    let bones: Vec<Tensor<2>> = (0..j)
        .filter_map(|k| parents[k].map(|p| (k, p)))
        .map(|(k, p)| {
            let d = joints.clone().slice([0..b, k..k + 1, 0..3])
                - joints.clone().slice([0..b, p..p + 1, 0..3]);
            d.powi_scalar(2)
                .sum_dim(2)
                .reshape([b, 1])
                .clamp_min(1e-20)
                .sqrt()
        })
        .collect();
    Tensor::cat(bones, 1)
}

/// `L_bone`: mean squared deviation of the bone lengths from `reference` (`[J − 1]`).
pub fn bone_length_loss(
    joints: Tensor<3>,
    parents: &[Option<usize>],
    reference: Tensor<1>,
) -> Tensor<1> {
    let lengths = bone_lengths(joints, parents);
    let [_, n] = lengths.dims();
    (lengths - reference.reshape([1, n])).powi_scalar(2).mean()
}

/// Per-joint `[min, max]` in degrees for the x, y, z components of SMPL's local axis-angle pose
/// (rest pose: T-pose, +y up, +z forward, the body's left on +x).
///
/// Source: the American Academy of Orthopaedic Surgeons' normative active ranges of motion
/// (Greene & Heckman, *The Clinical Measurement of Joint Motion*, 1994), mapped onto SMPL's axes
/// and widened by about 10° for soft tissue and fitting noise. Hinges are tight on their two
/// minor axes: knee flexion is +x (0–145°); elbow flexion is −y on the left arm and +y on the
/// right (0–150°). Spine segments share the trunk's range (about a third each); the pelvis row is
/// the global orientation and is unbounded.
pub const SMPL_ANGLE_LIMITS_DEG: [[[f32; 2]; 3]; 24] = [
    [[-360.0, 360.0], [-360.0, 360.0], [-360.0, 360.0]], // pelvis (global)
    [[-135.0, 40.0], [-50.0, 50.0], [-40.0, 55.0]],      // left_hip
    [[-135.0, 40.0], [-50.0, 50.0], [-55.0, 40.0]],      // right_hip
    [[-35.0, 45.0], [-25.0, 25.0], [-20.0, 20.0]],       // spine1
    [[-5.0, 145.0], [-10.0, 10.0], [-10.0, 10.0]],       // left_knee
    [[-5.0, 145.0], [-10.0, 10.0], [-10.0, 10.0]],       // right_knee
    [[-25.0, 35.0], [-25.0, 25.0], [-20.0, 20.0]],       // spine2
    [[-60.0, 30.0], [-30.0, 30.0], [-35.0, 35.0]],       // left_ankle
    [[-60.0, 30.0], [-30.0, 30.0], [-35.0, 35.0]],       // right_ankle
    [[-25.0, 35.0], [-25.0, 25.0], [-20.0, 20.0]],       // spine3
    [[-30.0, 50.0], [-15.0, 15.0], [-15.0, 15.0]],       // left_foot (toes)
    [[-30.0, 50.0], [-15.0, 15.0], [-15.0, 15.0]],       // right_foot (toes)
    [[-50.0, 60.0], [-70.0, 70.0], [-45.0, 45.0]],       // neck
    [[-20.0, 20.0], [-30.0, 30.0], [-20.0, 35.0]],       // left_collar
    [[-20.0, 20.0], [-30.0, 30.0], [-35.0, 20.0]],       // right_collar
    [[-50.0, 60.0], [-70.0, 70.0], [-45.0, 45.0]],       // head
    [[-100.0, 100.0], [-110.0, 60.0], [-100.0, 100.0]],  // left_shoulder
    [[-100.0, 100.0], [-60.0, 110.0], [-100.0, 100.0]],  // right_shoulder
    [[-90.0, 90.0], [-150.0, 5.0], [-15.0, 15.0]],       // left_elbow (forearm twist on x)
    [[-90.0, 90.0], [-5.0, 150.0], [-15.0, 15.0]],       // right_elbow
    [[-40.0, 40.0], [-30.0, 30.0], [-90.0, 90.0]],       // left_wrist
    [[-40.0, 40.0], [-30.0, 30.0], [-90.0, 90.0]],       // right_wrist
    [[-30.0, 30.0], [-30.0, 30.0], [-40.0, 40.0]],       // left_hand
    [[-30.0, 30.0], [-30.0, 30.0], [-40.0, 40.0]],       // right_hand
];

/// `L_limit`: mean over frames of the summed squared excess (radians) of each local axis-angle
/// component beyond its limit, for poses `[B, 3 J]` and limits `[J][3][min, max]` in degrees.
pub fn angle_limit_loss(pose: Tensor<2>, limits_deg: &[[[f32; 2]; 3]]) -> Tensor<1> {
    let [_, p] = pose.dims();
    assert_eq!(
        p,
        3 * limits_deg.len(),
        "pose must be [B, 3 J] for {} joints",
        limits_deg.len()
    );
    let device = pose.device();
    let bound = |side: usize| {
        let v: Vec<f32> = limits_deg
            .iter()
            .flatten()
            .map(|r| r[side].to_radians())
            .collect();
        Tensor::<2>::from_data(TensorData::new(v, [1, p]), &device)
    };
    let below = relu(bound(0) - pose.clone());
    let above = relu(pose - bound(1));
    (below.powi_scalar(2) + above.powi_scalar(2))
        .sum_dim(1)
        .mean()
}
