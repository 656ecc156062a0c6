//! Skeleton priors of APF-GS Eq. 7: bone lengths and joint-angle limits.

use crate::common::values;
use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_models::body::priors::{
    SMPL_ANGLE_LIMITS_DEG, angle_limit_loss, bone_length_loss, bone_lengths,
};
use splatzoo_models::body::skeleton::SMPL_PARENTS;

#[test]
fn bone_lengths_and_their_loss() {
    let device = Device::flex().autodiff();
    let parents = [None, Some(0), Some(1)];
    let joints = Tensor::<3>::from_data(
        TensorData::new(
            vec![0.0f32, 0.0, 0.0, 3.0, 4.0, 0.0, 3.0, 4.0, 0.0],
            [1, 3, 3],
        ),
        &device,
    )
    .require_grad();
    let lengths = values(bone_lengths(joints.clone(), &parents));
    assert!(
        (lengths[0] - 5.0).abs() < 1e-6 && lengths[1].abs() < 1e-6,
        "{lengths:?}"
    );
    let at_reference = bone_length_loss(
        joints.clone(),
        &parents,
        Tensor::from_floats([5.0, 0.0], &device),
    );
    assert!(values(at_reference)[0].abs() < 1e-10);
    // Coincident joints (a zero-length bone) still give finite gradients.
    let loss = bone_length_loss(
        joints.clone(),
        &parents,
        Tensor::from_floats([4.0, 1.0], &device),
    );
    assert!((values(loss.clone())[0] - 1.0).abs() < 1e-6); // ((5-4)² + (0-1)²) / 2
    let g = values(joints.grad(&loss.backward()).unwrap());
    assert!(g.iter().all(|v| v.is_finite()), "{g:?}");
}

#[test]
fn angle_limits_allow_rest_and_natural_bends_and_penalise_impossible_ones() {
    let device = Device::flex();
    for (j, joint) in SMPL_ANGLE_LIMITS_DEG.iter().enumerate() {
        for axis in joint {
            assert!(
                axis[0] <= 0.0 && 0.0 <= axis[1],
                "joint {j}: rest pose must be inside its limits"
            );
        }
    }
    assert_eq!(SMPL_PARENTS.len(), SMPL_ANGLE_LIMITS_DEG.len());
    let pose_with = |joint: usize, axis: usize, degrees: f32| {
        let mut p = vec![0.0f32; 72];
        p[3 * joint + axis] = degrees.to_radians();
        Tensor::<2>::from_data(TensorData::new(p, [1, 72]), &device)
    };
    let loss = |t| values(angle_limit_loss(t, &SMPL_ANGLE_LIMITS_DEG))[0];
    assert_eq!(loss(pose_with(0, 0, 0.0)), 0.0);
    assert_eq!(loss(pose_with(4, 0, 90.0)), 0.0, "left knee flexed 90°");
    assert_eq!(
        loss(pose_with(18, 1, -120.0)),
        0.0,
        "left elbow flexed 120°"
    );
    let hyper = loss(pose_with(4, 0, -35.0));
    assert!(
        (hyper - 30f32.to_radians().powi(2)).abs() < 1e-5,
        "knee bent backwards 35°: {hyper}"
    );
    assert!(
        loss(pose_with(19, 1, -60.0)) > 0.0,
        "right elbow bent backwards"
    );
}
