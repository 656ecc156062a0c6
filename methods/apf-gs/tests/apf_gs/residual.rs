//! Eq. 4's `⊕` and `⊗ T_h` against scalar formulas (A3), the bound on `δμ`, and the networks'
//! initial state (A2: Δ ≡ 0, σ ≈ 0.8).

use burn::tensor::{Device, Distribution, Tensor, TensorData};
use splatzoo_apf_gs::networks::{Guidance, NetworkConfig, ResidualField};
use splatzoo_apf_gs::residual::{Produced, gate_outputs, world_residual};
use splatzoo_datasets::synth::rng::Rng;
use splatzoo_models::rotation_scalar::{axis_angle_matrix, quaternion_matrix};
use splatzoo_rasterizer::Splats;
use splatzoo_train::host_f32;

type M3 = [[f64; 3]; 3];

fn mul(a: &M3, b: &M3) -> M3 {
    std::array::from_fn(|r| std::array::from_fn(|c| (0..3).map(|k| a[r][k] * b[k][c]).sum()))
}

fn transpose(a: &M3) -> M3 {
    std::array::from_fn(|r| std::array::from_fn(|c| a[c][r]))
}

fn hamilton(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
    [
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    ]
}

fn unit(q: [f64; 4]) -> [f64; 4] {
    let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
    q.map(|v| v / n)
}

fn tensor2(v: Vec<f32>, shape: [usize; 2], device: &Device) -> Tensor<2> {
    Tensor::from_data(TensorData::new(v, shape), device)
}

#[test]
fn the_residual_is_added_in_the_body_frame_then_carried_by_the_root() {
    let seed = crate::fresh_seed();
    let mut rng = Rng(seed);
    let device = Device::flex();
    let g = 7;
    let root: M3 = axis_angle_matrix([rng.normal(), rng.normal(), rng.normal()]);
    let posed_q: Vec<[f64; 4]> = (0..g)
        .map(|_| unit([rng.normal(), rng.normal(), rng.normal(), rng.normal()]))
        .collect();
    let offsets: Vec<f64> = (0..3 * g).map(|_| 0.05 * rng.normal()).collect();
    let dq: Vec<f64> = (0..4 * g).map(|_| 0.2 * rng.normal()).collect();
    let ds: Vec<f64> = (0..3 * g).map(|_| 0.1 * rng.normal()).collect();
    let f32s = |v: &[f64]| v.iter().map(|&x| x as f32).collect::<Vec<_>>();
    let posed = Splats {
        means: Tensor::zeros([g, 3], &device),
        quats: tensor2(f32s(&posed_q.concat()), [g, 4], &device),
        log_scales: Tensor::zeros([g, 3], &device),
        opacity_logits: Tensor::zeros([g], &device),
        colors: Tensor::zeros([g, 1, 3], &device),
    };
    let produced = Produced {
        offsets: tensor2(f32s(&offsets), [g, 3], &device),
        rotations: tensor2(f32s(&dq), [g, 4], &device),
        log_scales: tensor2(f32s(&ds), [g, 3], &device),
        sigma: None,
        ungated: Tensor::zeros([g, 10], &device),
    };
    let root_t = tensor2(f32s(&root.concat()), [3, 3], &device);
    let residual = world_residual(&posed, &produced, root_t);
    let means = host_f32(&residual.means.expect("means"));
    let quats = host_f32(&residual.quats.expect("quats"));
    let scales = host_f32(&residual.log_scales.expect("scales"));
    for i in 0..g {
        let d = &offsets[3 * i..3 * i + 3];
        for r in 0..3 {
            let expected: f64 = (0..3).map(|c| root[r][c] * d[c]).sum();
            assert!(
                (f64::from(means[3 * i + r]) - expected).abs() < 1e-5,
                "seed {seed}"
            );
            assert!((f64::from(scales[3 * i + r]) - ds[3 * i + r]).abs() < 1e-6);
        }
        let body = unit([1.0 + dq[4 * i], dq[4 * i + 1], dq[4 * i + 2], dq[4 * i + 3]]);
        let rv: [f64; 3] = std::array::from_fn(|r| (0..3).map(|c| root[r][c] * body[1 + c]).sum());
        let world = [body[0], rv[0], rv[1], rv[2]];
        // Conjugating by the root is the rotation R · Rot(body) · Rᵀ.
        let conjugated = mul(&mul(&root, &quaternion_matrix(body)), &transpose(&root));
        let from_world = quaternion_matrix(world);
        for r in 0..3 {
            for c in 0..3 {
                assert!((conjugated[r][c] - from_world[r][c]).abs() < 1e-9);
            }
        }
        let expected = hamilton(world, posed_q[i]);
        for k in 0..4 {
            let got = f64::from(quats[4 * i + k]) + posed_q[i][k];
            assert!(
                (got - expected[k]).abs() < 1e-5,
                "seed {seed}: row {i}, component {k}"
            );
        }
    }
}

#[test]
fn a_zero_residual_changes_nothing() {
    let device = Device::flex();
    let g = 5;
    let posed = Splats {
        means: Tensor::random([g, 3], Distribution::Normal(0.0, 1.0), &device),
        quats: Tensor::<1>::from_floats([1.0, 0.0, 0.0, 0.0], &device)
            .reshape([1, 4])
            .expand([g, 4]),
        log_scales: Tensor::zeros([g, 3], &device),
        opacity_logits: Tensor::zeros([g], &device),
        colors: Tensor::zeros([g, 1, 3], &device),
    };
    let produced = gate_outputs(
        Tensor::zeros([g, 10], &device),
        Tensor::ones([1, 1], &device),
        0.25,
    );
    let root = Tensor::<2>::from_floats(
        [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]],
        &device,
    );
    let r = world_residual(&posed, &produced, root);
    for v in [r.means, r.quats, r.log_scales] {
        assert!(host_f32(&v.expect("set")).iter().all(|&x| x.abs() < 1e-7));
    }
}

#[test]
fn offsets_stay_within_the_bound_and_scale_with_the_amplitude() {
    let device = Device::flex();
    let raw = Tensor::<2>::from_floats(
        [[1e6, -1e6, 0.01, 1.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.5]],
        &device,
    );
    let full = gate_outputs(raw.clone(), Tensor::ones([1, 1], &device), 0.25);
    let offsets = host_f32(&full.offsets);
    assert!((offsets[0] - 0.25).abs() < 1e-6 && (offsets[1] + 0.25).abs() < 1e-6);
    let tenth = gate_outputs(raw, Tensor::full([1, 1], 0.1, &device), 0.25);
    let small = host_f32(&tenth.offsets);
    // Small offsets scale linearly with the amplitude (tanh is the identity near 0).
    assert!((small[2] - 0.1 * offsets[2]).abs() < 1e-6);
    assert!((host_f32(&tenth.rotations)[0] - 0.1).abs() < 1e-6);
}

#[test]
fn the_field_starts_at_zero_and_sigma_starts_at_its_prior() {
    let device = Device::flex();
    let config = NetworkConfig::default();
    let field = ResidualField::new(&config, 10, &device);
    let input = Tensor::random(
        [64, config.residual_inputs()],
        Distribution::Normal(0.0, 1.0),
        &device,
    );
    assert!(host_f32(&field.forward(input)).iter().all(|&v| v == 0.0));
    let guidance = Guidance::new(&config, &device);
    let input = Tensor::random(
        [64, config.guidance_inputs()],
        Distribution::Normal(0.0, 1.0),
        &device,
    );
    let (condition, logit) = guidance.forward(input);
    assert_eq!(condition.dims(), [64, config.condition]);
    for l in host_f32(&logit) {
        let sigma = 1.0 / (1.0 + (-f64::from(l)).exp());
        assert!((sigma - 0.8).abs() < 0.01, "σ₀ = {sigma}");
    }
}
