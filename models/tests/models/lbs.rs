//! Skinning against an f64 scalar implementation of SMPL's Eqs. 2–4 on a random small model;
//! rest pose reproduces the template; ±π joint angles and ±5 shape coefficients stay finite;
//! validation errors name the key and the expected shape.
#![allow(clippy::needless_range_loop)] // the f64 reference mirrors the equations index by index

use crate::common::{rodrigues, values};
use burn::tensor::{Device, Tensor, TensorData};
use rand::{Rng, SeedableRng, rngs::StdRng};
use splatzoo_models::body::{BodyKind, BodyModel, BodyTensors, PoseInput, lbs};
use std::f64::consts::PI;

const V: usize = 40;
const J: usize = 6;
const S: usize = 4;
const E: usize = 2;

fn random_model(seed: u64) -> BodyModel {
    let mut rng = StdRng::seed_from_u64(seed);
    let mut uniform = |lo: f32, hi: f32, n: usize| -> Vec<f32> {
        (0..n).map(|_| rng.random_range(lo..hi)).collect()
    };
    let template = uniform(-1.0, 1.0, V * 3);
    let mut regressor = uniform(0.0, 1.0, J * V);
    for row in regressor.chunks_mut(V) {
        let s: f32 = row.iter().sum();
        row.iter_mut().for_each(|x| *x /= s);
    }
    let mut weights = uniform(0.0, 1.0, V * J);
    for row in weights.chunks_mut(J) {
        let s: f32 = row.iter().sum();
        row.iter_mut().for_each(|x| *x /= s);
    }
    BodyModel {
        kind: BodyKind::Builtin,
        template,
        faces: (0..V as u32 - 2).flat_map(|i| [i, i + 1, i + 2]).collect(),
        joint_regressor: regressor,
        parents: vec![None, Some(0), Some(1), Some(1), Some(3), Some(4)],
        skin_weights: weights,
        shape_dirs: uniform(-0.1, 0.1, V * 3 * S),
        pose_dirs: Some(uniform(-0.05, 0.05, V * 3 * 9 * (J - 1))),
        expression_dirs: Some(uniform(-0.05, 0.05, V * 3 * E)),
        joint_names: (0..J).map(|j| format!("j{j}")).collect(),
        face_landmarks: None,
    }
}

type M3 = [[f64; 3]; 3];

fn mul(a: &M3, b: &M3) -> M3 {
    let mut o = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            o[i][j] = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    o
}

fn apply(a: &M3, v: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|i| a[i][0] * v[0] + a[i][1] * v[1] + a[i][2] * v[2])
}

/// SMPL Eqs. 2–4 in f64, one frame: returns (vertices, joints).
fn reference(
    m: &BodyModel,
    betas: &[f64],
    expr: &[f64],
    pose: &[f64],
    trans: [f64; 3],
) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
    let f = |x: f32| x as f64;
    let mut shaped: Vec<[f64; 3]> = (0..V)
        .map(|v| [0, 1, 2].map(|c| f(m.template[3 * v + c])))
        .collect();
    for v in 0..V {
        for c in 0..3 {
            for (s, b) in betas.iter().enumerate() {
                shaped[v][c] += b * f(m.shape_dirs[(v * 3 + c) * S + s]);
            }
            for (e, x) in expr.iter().enumerate() {
                shaped[v][c] += x * f(m.expression_dirs.as_ref().unwrap()[(v * 3 + c) * E + e]);
            }
        }
    }
    let rest_joints: Vec<[f64; 3]> = (0..J)
        .map(|j| {
            [0, 1, 2].map(|c| {
                (0..V)
                    .map(|v| f(m.joint_regressor[j * V + v]) * shaped[v][c])
                    .sum()
            })
        })
        .collect();
    let rots: Vec<M3> = (0..J)
        .map(|j| rodrigues([pose[3 * j], pose[3 * j + 1], pose[3 * j + 2]]))
        .collect();
    let mut feature = Vec::new();
    for r in &rots[1..] {
        for (i, row) in r.iter().enumerate() {
            for (k, x) in row.iter().enumerate() {
                feature.push(x - if i == k { 1.0 } else { 0.0 });
            }
        }
    }
    let mut posed_rest = shaped.clone();
    let p = m.pose_dirs.as_ref().unwrap();
    for v in 0..V {
        for c in 0..3 {
            for (k, x) in feature.iter().enumerate() {
                posed_rest[v][c] += x * f(p[(v * 3 + c) * feature.len() + k]);
            }
        }
    }
    let mut g_rot: Vec<M3> = Vec::new();
    let mut g_pos: Vec<[f64; 3]> = Vec::new();
    for j in 0..J {
        match m.parents[j] {
            None => {
                g_rot.push(rots[j]);
                g_pos.push(rest_joints[j]);
            }
            Some(par) => {
                let off = [0, 1, 2].map(|c| rest_joints[j][c] - rest_joints[par][c]);
                let t = apply(&g_rot[par], off);
                g_pos.push([0, 1, 2].map(|c| t[c] + g_pos[par][c]));
                g_rot.push(mul(&g_rot[par], &rots[j]));
            }
        }
    }
    let verts = (0..V)
        .map(|v| {
            let mut out = trans;
            for j in 0..J {
                let w = f(m.skin_weights[v * J + j]);
                let local = [0, 1, 2].map(|c| posed_rest[v][c] - rest_joints[j][c]);
                let moved = apply(&g_rot[j], local);
                for c in 0..3 {
                    out[c] += w * (moved[c] + g_pos[j][c]);
                }
            }
            out
        })
        .collect();
    let joints = g_pos
        .iter()
        .map(|p| [0, 1, 2].map(|c| p[c] + trans[c]))
        .collect();
    (verts, joints)
}

fn input(betas: &[f64], expr: &[f64], pose: &[f64], trans: [f64; 3], device: &Device) -> PoseInput {
    let t = |v: &[f64], shape: [usize; 2]| {
        Tensor::<2>::from_data(
            TensorData::new(v.iter().map(|&x| x as f32).collect::<Vec<_>>(), shape),
            device,
        )
    };
    let mut p = PoseInput::from_axis_angle(
        t(betas, [1, betas.len()]),
        t(pose, [1, pose.len()]),
        t(&trans, [1, 3]),
    );
    p.expression = Some(t(expr, [1, expr.len()]));
    p
}

#[test]
fn skinning_matches_f64_reference() {
    let device = Device::flex();
    let model = random_model(1);
    model.validate("random").unwrap();
    let body = BodyTensors::new(&model, &device);
    let mut rng = StdRng::seed_from_u64(2);
    for case in 0..4 {
        let betas: Vec<f64> = (0..S).map(|_| rng.random_range(-5.0..5.0)).collect();
        let expr: Vec<f64> = (0..E).map(|_| rng.random_range(-2.0..2.0)).collect();
        let mut pose: Vec<f64> = (0..3 * J).map(|_| rng.random_range(-1.5..1.5)).collect();
        if case == 3 {
            pose[3..6].copy_from_slice(&[PI, 0.0, 0.0]);
            pose[6..9].copy_from_slice(&[0.0, -PI, 0.0]);
        }
        let trans = [0.3, -0.2, 1.5];
        let (ref_verts, ref_joints) = reference(&model, &betas, &expr, &pose, trans);
        let posed = lbs::pose(&body, &input(&betas, &expr, &pose, trans, &device));
        let verts = values(posed.vertices);
        let joints = values(posed.joints);
        for (a, e) in verts.iter().zip(ref_verts.iter().flatten()) {
            assert!(
                (*a as f64 - e).abs() < 1e-4,
                "case {case}: vertex {a} vs {e}"
            );
        }
        for (a, e) in joints.iter().zip(ref_joints.iter().flatten()) {
            assert!(
                (*a as f64 - e).abs() < 1e-4,
                "case {case}: joint {a} vs {e}"
            );
        }
    }
}

#[test]
fn rest_pose_is_the_template() {
    let device = Device::flex();
    let model = random_model(3);
    let body = BodyTensors::new(&model, &device);
    let zeros = |n| vec![0.0; n];
    let posed = lbs::pose(
        &body,
        &input(&zeros(S), &zeros(E), &zeros(3 * J), [0.0; 3], &device),
    );
    let verts = values(posed.vertices);
    for (a, e) in verts.iter().zip(&model.template) {
        assert!((a - e).abs() < 1e-6, "{a} vs {e}");
    }
}

#[test]
fn extreme_angles_and_shapes_give_finite_vertices_and_gradients() {
    let device = Device::flex().autodiff();
    let model = random_model(4);
    let body = BodyTensors::new(&model, &device);
    for (angle, beta) in [(PI, 5.0), (-PI, -5.0), (2.0 * PI, 5.0), (0.0, -5.0)] {
        let pose: Vec<f32> = (0..3 * J)
            .map(|k| if k % 3 == 0 { angle as f32 } else { 0.0 })
            .collect();
        let pose =
            Tensor::<2>::from_data(TensorData::new(pose, [1, 3 * J]), &device).require_grad();
        let betas = Tensor::<2>::from_data(TensorData::new(vec![beta as f32; S], [1, S]), &device)
            .require_grad();
        let trans = Tensor::<2>::zeros([1, 3], &device);
        let posed = lbs::pose(
            &body,
            &PoseInput::from_axis_angle(betas.clone(), pose.clone(), trans),
        );
        let v = values(posed.vertices.clone());
        assert!(v.iter().all(|x| x.is_finite()));
        let grads = posed.vertices.powi_scalar(2).sum().backward();
        let gp = values(pose.grad(&grads).unwrap());
        let gb = values(betas.grad(&grads).unwrap());
        assert!(
            gp.iter().chain(&gb).all(|x| x.is_finite()),
            "angle {angle}: {gp:?}"
        );
    }
}

#[test]
fn validation_names_the_key_and_shape() {
    let mut model = random_model(5);
    model.skin_weights.pop();
    let err = model.validate("my_smpl.npz").unwrap_err().to_string();
    assert!(
        err.contains("my_smpl.npz") && err.contains("weights") && err.contains("[40, 6]"),
        "{err}"
    );
    let mut model = random_model(5);
    model.parents[3] = Some(4);
    let err = model.validate("m.npz").unwrap_err().to_string();
    assert!(
        err.contains("kintree_table") && err.contains("precede"),
        "{err}"
    );
    let mut model = random_model(5);
    model.template[7] = f32::NAN;
    let err = model.validate("m.npz").unwrap_err().to_string();
    assert!(
        err.contains("v_template") && err.contains("non-finite"),
        "{err}"
    );
}
