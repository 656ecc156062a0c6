//! Rotation conversions against f64 scalar formulas, round trips, and finite gradients at the
//! singular angles 0, π and 2π.
#![allow(clippy::needless_range_loop)] // the f64 reference mirrors the equations index by index

use crate::common::{rodrigues, values};
use burn::tensor::{Device, Tensor, TensorData};
use rand::{Rng, SeedableRng, rngs::StdRng};
use splatzoo_models::rotation::*;
use std::f64::consts::PI;

/// Random axis-angles plus the singular and near-singular cases.
fn axis_angles(seed: u64) -> Vec<[f64; 3]> {
    let mut rng = StdRng::seed_from_u64(seed);
    let mut out = Vec::new();
    for angle in [
        0.0,
        1e-7,
        1e-3,
        PI / 2.0,
        PI - 1e-6,
        PI,
        2.0 * PI - 1e-3,
        2.0 * PI,
        3.0 * PI,
    ] {
        let axis: [f64; 3] = [
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        ];
        let n = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
        out.push(axis.map(|a| a / n * angle));
    }
    for _ in 0..40 {
        out.push([0; 3].map(|_: i32| rng.random_range(-3.0..3.0)));
    }
    out
}

fn to_tensor(aa: &[[f64; 3]], device: &Device) -> Tensor<2> {
    let flat: Vec<f32> = aa.iter().flatten().map(|&v| v as f32).collect();
    Tensor::from_data(TensorData::new(flat, [aa.len(), 3]), device)
}

fn assert_close(actual: &[f32], expected: &[f64], tol: f64, what: &str) {
    for (i, (a, e)) in actual.iter().zip(expected).enumerate() {
        assert!((*a as f64 - e).abs() <= tol, "{what}[{i}]: {a} vs {e}");
    }
}

#[test]
fn axis_angle_to_matrix_matches_rodrigues() {
    let device = Device::flex();
    let aa = axis_angles(1);
    let got = values(axis_angle_to_matrix(to_tensor(&aa, &device)));
    let expected: Vec<f64> = aa
        .iter()
        .flat_map(|w| rodrigues(*w).into_iter().flatten())
        .collect();
    assert_close(&got, &expected, 2e-6, "R");
}

#[test]
fn round_trips_reproduce_the_rotation() {
    let device = Device::flex();
    let aa = axis_angles(2);
    let r = axis_angle_to_matrix(to_tensor(&aa, &device));
    let expected = values(r.clone());
    let via_quat = values(quaternion_to_matrix(matrix_to_quaternion(r.clone())));
    let via_aa = values(axis_angle_to_matrix(matrix_to_axis_angle(r.clone())));
    let via_6d = values(rotation_6d_to_matrix(matrix_to_rotation_6d(r.clone())));
    let via_q_aa = values(axis_angle_to_matrix(quaternion_to_axis_angle(
        axis_angle_to_quaternion(to_tensor(&aa, &device)),
    )));
    let expected64: Vec<f64> = expected.iter().map(|&v| v as f64).collect();
    assert_close(&via_quat, &expected64, 1e-5, "matrix→quaternion→matrix");
    assert_close(&via_aa, &expected64, 1e-5, "matrix→axis-angle→matrix");
    assert_close(&via_6d, &expected64, 1e-5, "matrix→6D→matrix");
    assert_close(
        &via_q_aa,
        &expected64,
        1e-5,
        "axis-angle→quaternion→axis-angle→matrix",
    );
    // Recovered angles lie in [0, π].
    let angles = values(matrix_to_axis_angle(r).powi_scalar(2).sum_dim(1).sqrt());
    assert!(
        angles
            .iter()
            .all(|&a| (0.0..=PI as f32 + 1e-5).contains(&a)),
        "{angles:?}"
    );
}

#[test]
fn six_d_of_any_vectors_is_a_rotation() {
    let device = Device::flex();
    let mut rng = StdRng::seed_from_u64(3);
    let raw: Vec<f32> = (0..6 * 50).map(|_| rng.random_range(-2.0..2.0)).collect();
    let r = rotation_6d_to_matrix(Tensor::from_data(TensorData::new(raw, [50, 6]), &device));
    let rrt = values(r.clone().matmul(r.clone().swap_dims(1, 2)));
    let eye: Vec<f64> = (0..50)
        .flat_map(|_| [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0])
        .collect();
    assert_close(&rrt, &eye, 1e-5, "R Rᵀ");
    // det = +1: third row = first × second by construction; check one determinant sign.
    let m = values(r);
    for k in 0..50 {
        let a = &m[9 * k..9 * k + 9];
        let det = a[0] * (a[4] * a[8] - a[5] * a[7]) - a[1] * (a[3] * a[8] - a[5] * a[6])
            + a[2] * (a[3] * a[7] - a[4] * a[6]);
        assert!((det - 1.0).abs() < 1e-5, "det {det}");
    }
}

#[test]
fn gradients_are_finite_at_singular_angles() {
    let device = Device::flex().autodiff();
    let aa = axis_angles(4);
    let mut rng = StdRng::seed_from_u64(5);
    let weights: Vec<f32> = (0..aa.len() * 9)
        .map(|_| rng.random_range(-1.0..1.0))
        .collect();
    let w = Tensor::<3>::from_data(TensorData::new(weights, [aa.len(), 3, 3]), &device);

    let x = to_tensor(&aa, &device).require_grad();
    let r = axis_angle_to_matrix(x.clone());
    let round = axis_angle_to_matrix(matrix_to_axis_angle(r.clone()));
    let q = axis_angle_to_quaternion(x.clone());
    let via_q = quaternion_to_matrix(q.clone()) + axis_angle_to_matrix(quaternion_to_axis_angle(q));
    let six = rotation_6d_to_matrix(matrix_to_rotation_6d(r.clone()));
    let loss = ((r + round + via_q + six) * w).sum();
    let g = values(x.grad(&loss.backward()).expect("gradient"));
    assert!(
        g.iter().all(|v| v.is_finite()),
        "non-finite gradient: {g:?}"
    );
}
