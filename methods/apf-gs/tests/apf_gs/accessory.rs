//! Eq. 8 (A8): `T_acc = T_parent · ΔT_attach` as 4×4 matrices, and an accessory moving rigidly
//! with its parent joint when `D_ψ` is off.

use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_apf_gs::accessory::{AccessoryNode, AttachRates, attached};
use splatzoo_datasets::synth::rng::Rng;
use splatzoo_models::rotation_scalar::axis_angle_matrix;
use splatzoo_rasterizer::Camera;
use splatzoo_train::densify::{DensifyConfig, Strategy};
use splatzoo_train::gaussians::GaussianSet;
use splatzoo_train::host_f32;
use splatzoo_train::optimizer::LearningRates;
use splatzoo_train::scene::{FrameContext, FrameQuery, NodeOutput, SceneNode};

type M4 = [[f64; 4]; 4];

fn homogeneous(r: [[f64; 3]; 3], t: [f64; 3]) -> M4 {
    let mut m = [[0.0; 4]; 4];
    for i in 0..3 {
        m[i][..3].copy_from_slice(&r[i]);
        m[i][3] = t[i];
    }
    m[3][3] = 1.0;
    m
}

fn mul(a: &M4, b: &M4) -> M4 {
    std::array::from_fn(|r| std::array::from_fn(|c| (0..4).map(|k| a[r][k] * b[k][c]).sum()))
}

#[test]
fn the_accessory_transform_is_the_parent_times_the_attachment() {
    let seed = crate::fresh_seed();
    let mut rng = Rng(seed);
    let device = Device::flex();
    let parent_r = axis_angle_matrix([rng.normal(), rng.normal(), rng.normal()]);
    let parent_t = [rng.normal(), rng.normal(), rng.normal()];
    let attach_r = [0.3 * rng.normal(), 0.3 * rng.normal(), 0.3 * rng.normal()];
    let attach_t = [0.2 * rng.normal(), 0.2 * rng.normal(), 0.2 * rng.normal()];
    let t2 = |v: Vec<f64>, shape: [usize; 2]| {
        Tensor::<2>::from_data(
            TensorData::new(v.into_iter().map(|x| x as f32).collect::<Vec<_>>(), shape),
            &device,
        )
    };
    let (rotation, translation) = attached(
        t2(parent_r.concat(), [3, 3]),
        t2(parent_t.to_vec(), [1, 3]),
        t2(attach_r.to_vec(), [1, 3]),
        t2(attach_t.to_vec(), [1, 3]),
    );
    let expected = mul(
        &homogeneous(parent_r, parent_t),
        &homogeneous(axis_angle_matrix(attach_r), attach_t),
    );
    let r = host_f32(&rotation);
    let t = host_f32(&translation);
    for i in 0..3 {
        for j in 0..3 {
            assert!(
                (f64::from(r[3 * i + j]) - expected[i][j]).abs() < 1e-5,
                "seed {seed}"
            );
        }
        assert!(
            (f64::from(t[i]) - expected[i][3]).abs() < 1e-5,
            "seed {seed}"
        );
    }
}

/// A 24-joint parent output whose joint `k` has the given transform (others identity).
fn parent(k: usize, r: [[f64; 3]; 3], p: [f64; 3], device: &Device) -> NodeOutput {
    let mut values = Vec::new();
    for j in 0..24 {
        let m = if j == k {
            homogeneous(r, p)
        } else {
            homogeneous(
                [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
                [0.0; 3],
            )
        };
        values.extend(m.iter().flatten().map(|&v| v as f32));
    }
    NodeOutput {
        splats: GaussianSet::from_points(&[[0.0; 3]], &[[0.5; 3]], &[0.01], device).splats(),
        joints: Some(Tensor::from_data(
            TensorData::new(values, [24, 4, 4]),
            device,
        )),
        bounds: None,
    }
}

#[test]
fn without_deformation_the_accessory_moves_rigidly_with_its_joint() {
    let seed = crate::fresh_seed();
    let mut rng = Rng(seed);
    let device = Device::flex();
    let points: Vec<[f32; 3]> = (0..20)
        .map(|_| std::array::from_fn(|_| rng.range(-0.2, 0.2) as f32))
        .collect();
    let set = GaussianSet::from_points(&points, &vec![[0.5; 3]; 20], &[0.01; 20], &device);
    let node = AccessoryNode::new(
        "bag",
        "human_0",
        20,
        set,
        LearningRates::default(),
        AttachRates::default(),
        &DensifyConfig {
            strategy: Strategy::None,
            ..DensifyConfig::default()
        },
        1,
    );
    let camera = Camera::look_at([0.0, 0.0, -3.0], [0.0; 3], [0.0, 1.0, 0.0], 60.0, 64, 48);
    for _ in 0..3 {
        let r = axis_angle_matrix([rng.normal(), rng.normal(), rng.normal()]);
        let p = [rng.normal(), rng.normal(), rng.normal()];
        let outputs = vec![("human_0".to_owned(), parent(20, r, p, &device))];
        let query = FrameQuery {
            camera: &camera,
            frame: 0,
            time: 0.0,
        };
        let out = node.render(&query, &FrameContext { outputs: &outputs });
        let means = host_f32(&out.splats.means);
        for (i, q) in points.iter().enumerate() {
            for row in 0..3 {
                let expected: f64 =
                    p[row] + (0..3).map(|c| r[row][c] * f64::from(q[c])).sum::<f64>();
                assert!(
                    (f64::from(means[3 * i + row]) - expected).abs() < 1e-5,
                    "seed {seed}"
                );
            }
        }
    }
}
