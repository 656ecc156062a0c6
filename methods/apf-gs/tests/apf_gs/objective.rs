//! Eq. 6–7 (A4, A5): the kinematic terms are live where the spec says they must be — the
//! relative bone term on joints regressed from the deformed human, the limit term quadratic
//! beyond the ranges — σ's gradient is `λ_s L_sparse − λ_k L_kine`, and the residual chain's
//! gradients agree with finite differences.

use burn::tensor::{Device, Distribution, Tensor, TensorData};
use splatzoo_apf_gs::gate::GateConfig;
use splatzoo_apf_gs::loss::{PersonTerms, TermWeights, limit_loss, relative_bone_loss};
use splatzoo_apf_gs::residual::{gate_outputs, world_residual};
use splatzoo_datasets::synth::rng::Rng;
use splatzoo_models::body::builtin_body;
use splatzoo_models::body::lbs::{BodyTensors, PoseInput, pose};
use splatzoo_models::body::priors::bone_lengths;
use splatzoo_models::rotation::axis_angle_to_matrix;
use splatzoo_rasterizer::Splats;
use splatzoo_train::host_f32;
use splatzoo_train::loss::scalar;

fn rest_joints(device: &Device) -> Tensor<2> {
    let model = &builtin_body().model;
    let j = model.joint_count();
    let body = BodyTensors::new(model, device);
    let rest = pose(
        &body,
        &PoseInput::from_axis_angle(
            Tensor::zeros([1, model.shape_count()], device),
            Tensor::zeros([1, 3 * j], device),
            Tensor::zeros([1, 3], device),
        ),
    );
    rest.joints.reshape([j, 3])
}

#[test]
fn the_bone_term_is_zero_at_rest_and_grows_when_a_limb_stretches() {
    let device = Device::flex();
    let parents = &builtin_body().model.parents;
    let joints = rest_joints(&device);
    let [j, _] = joints.dims();
    let reference = bone_lengths(joints.clone().reshape([1, j, 3]), parents).reshape([j - 1]);
    let at_rest = scalar(relative_bone_loss(
        joints.clone(),
        parents,
        reference.clone(),
    ));
    assert!(at_rest < 1e-10, "{at_rest}");
    // Stretch the left forearm: move the left wrist (20) away from the elbow (18) by 10 %.
    let host = host_f32(&joints);
    let mut stretched = host.clone();
    for a in 0..3 {
        stretched[20 * 3 + a] += 0.1 * (host[20 * 3 + a] - host[18 * 3 + a]);
    }
    let offset = Tensor::<2>::from_data(
        TensorData::new(
            stretched
                .iter()
                .zip(&host)
                .map(|(s, h)| s - h)
                .collect::<Vec<_>>(),
            [j, 3],
        ),
        &device,
    )
    .autodiff()
    .require_grad();
    let loss = relative_bone_loss(
        joints.autodiff() + offset.clone(),
        parents,
        reference.autodiff(),
    );
    let value = scalar(loss.clone().inner());
    // One bone of J − 1 off by 10 % (the wrist's children move with it only if pushed: they
    // are not, so the hand bones change too).
    assert!(value > 0.01 / (j - 1) as f64 * 0.5, "{value}");
    let grads = loss.backward();
    let g = host_f32(&offset.grad(&grads).expect("a gradient reaches the joints"));
    assert!(g[20 * 3..20 * 3 + 3].iter().any(|v| v.abs() > 1e-6));
}

#[test]
fn the_limit_term_is_zero_inside_and_quadratic_outside() {
    let device = Device::flex();
    let j = 24;
    let loss_with_knee = |degrees: f64| {
        let mut aa = vec![0.0f32; 3 * j];
        aa[3 * 4] = degrees.to_radians() as f32; // left knee flexion (+x), range 0–145°
        let r = axis_angle_to_matrix(Tensor::from_data(TensorData::new(aa, [j, 3]), &device));
        scalar(limit_loss(r.reshape([1, j, 3, 3])))
    };
    assert!(loss_with_knee(0.0) < 1e-12);
    assert!(loss_with_knee(120.0) < 1e-12);
    let five = loss_with_knee(150.0);
    let ten = loss_with_knee(155.0);
    assert!((five - 5f64.to_radians().powi(2)).abs() < 1e-4, "{five}");
    assert!((ten / five - 4.0).abs() < 0.05, "quadratic: {five} → {ten}");
}

/// The paper's weights (`λ_sparse` 1e-3, `λ_kine` 0.1, `λ_bone` = `λ_limit` = 1), no σ prior.
fn paper_weights() -> TermWeights {
    TermWeights {
        sparse: 1e-3,
        kine: 0.1,
        bone: 1.0,
        limit: 1.0,
        sigma_reads_limit: true,
        sigma_prior: 0.0,
        sigma_start: 0.8,
    }
}

/// One person-frame's Eq. 6 total at σ = `s` with constant `(L_sparse, L_bone, L_limit)`:
/// its value and `∂/∂σ`.
fn total_and_sigma_slope(w: &TermWeights, s: f64, (ls, lb, ll): (f64, f64, f64)) -> (f64, f64) {
    let device = Device::flex();
    let constant = |v: f64| Tensor::<1>::from_floats([v as f32], &device).autodiff();
    let sigma = Tensor::<2>::full([1, 1], s, &device)
        .autodiff()
        .require_grad();
    let terms = PersonTerms {
        sigma: sigma.clone(),
        sparsity: constant(ls),
        bone: constant(lb),
        limit: constant(ll),
    };
    let total = terms.total(w);
    let value = scalar(total.clone().inner());
    let grads = total.backward();
    let slope = f64::from(host_f32(&sigma.grad(&grads).expect("σ has a gradient"))[0]);
    (value, slope)
}

#[test]
fn sigma_gradient_is_the_difference_of_the_two_regularisers() {
    let seed = crate::fresh_seed();
    let mut rng = Rng(seed);
    let (ls, lb, ll) = (
        rng.range(0.0, 2.0),
        rng.range(0.0, 2.0),
        rng.range(0.0, 2.0),
    );
    let w = paper_weights();
    let (_, g) = total_and_sigma_slope(&w, rng.range(0.05, 0.95), (ls, lb, ll));
    let expected = w.sparse * ls - w.kine * (w.bone * lb + w.limit * ll);
    assert!(
        (g - expected).abs() < 1e-6,
        "seed {seed}: {g} vs {expected}"
    );
}

/// `loss.sigma_reads_limit = false`: the loss is the same number, and σ's gradient loses
/// exactly the limit term's `−λ_k λ_l L_limit` (the bone term's pull stays).
#[test]
fn detaching_sigma_in_the_limit_product_leaves_the_bone_pull_alone() {
    let seed = crate::fresh_seed();
    let mut rng = Rng(seed);
    let terms = (
        rng.range(0.0, 2.0),
        rng.range(0.0, 2.0),
        rng.range(0.1, 2.0),
    );
    let (ls, lb, ll) = terms;
    let s0 = rng.range(0.05, 0.95);
    let run = |reads: bool| {
        let w = TermWeights {
            limit: 0.5,
            sigma_reads_limit: reads,
            ..paper_weights()
        };
        total_and_sigma_slope(&w, s0, terms)
    };
    let (paper, paper_grad) = run(true);
    let (detached, detached_grad) = run(false);
    assert!(
        (paper - detached).abs() < 1e-6,
        "seed {seed}: {paper} vs {detached}"
    );
    let expected = 1e-3 * ls - 0.1 * lb;
    assert!(
        (detached_grad - expected).abs() < 1e-6,
        "seed {seed}: {detached_grad} vs {expected}"
    );
    assert!(
        (paper_grad - detached_grad + 0.1 * 0.5 * ll).abs() < 1e-6,
        "seed {seed}: the paper's gradient {paper_grad} is the detached one less λ_k λ_l L_limit"
    );
}

/// `loss.sigma_prior`: `λ_σ (σ − σ₀)²` adds `2 λ_σ (σ − σ₀)` to σ's slope, so Eq. 6's
/// linear objective gets an interior minimum `σ* = σ₀ − (λ_s L_sparse − λ_k L_kine) / 2λ_σ`,
/// where σ's gradient vanishes.
#[test]
fn the_sigma_prior_gives_eq_6_an_interior_minimum() {
    let seed = crate::fresh_seed();
    let mut rng = Rng(seed);
    let terms = (
        rng.range(0.0, 2.0),
        rng.range(0.0, 0.2),
        rng.range(0.0, 0.2),
    );
    let (ls, lb, ll) = terms;
    let w = TermWeights {
        sigma_prior: rng.range(0.5, 2.0),
        ..paper_weights()
    };
    let slope_at = |s: f64| total_and_sigma_slope(&w, s, terms).1;
    let linear = w.sparse * ls - w.kine * (w.bone * lb + w.limit * ll);
    let s = rng.range(0.05, 0.95);
    let want = linear + 2.0 * w.sigma_prior * (s - w.sigma_start);
    let got = slope_at(s);
    assert!((got - want).abs() < 1e-5, "seed {seed}: {got} vs {want}");
    let minimum = w.sigma_start - linear / (2.0 * w.sigma_prior);
    let at_minimum = slope_at(minimum);
    assert!(
        at_minimum.abs() < 1e-5,
        "seed {seed}: slope {at_minimum} at σ* = {minimum}"
    );
}

/// `loss.sparsity_of`: on the blend `a(σ) = 1 − 0.9σ`, the gated sparsity's σ-weighted term
/// `σ S(a(σ) F)` falls with σ near 1 (it cannot pull σ down where the residual is large), and
/// the field's `σ S(F)` rises at every σ with slope `S(F)`, checked against a scalar reference.
#[test]
fn field_sparsity_pulls_sigma_down_at_every_sigma_where_the_gated_one_turns() {
    let seed = crate::fresh_seed();
    let mut rng = Rng(seed);
    let device = Device::flex();
    let g = 5;
    let max_offset = 0.25;
    let raw: Vec<f64> = (0..10 * g).map(|_| 0.02 * rng.normal()).collect();
    let gate = GateConfig::default();
    let slope = |field: bool, s: f64| {
        let sigma = Tensor::<2>::full([1, 1], s, &device)
            .autodiff()
            .require_grad();
        let f = Tensor::<2>::from_data(
            TensorData::new(raw.iter().map(|&v| v as f32).collect::<Vec<_>>(), [g, 10]),
            &device,
        )
        .autodiff();
        let produced = gate_outputs(f, gate.amplitude(sigma.clone()), max_offset);
        let rows = if field {
            produced.field_sparsity_rows(max_offset)
        } else {
            produced.sparsity_rows()
        };
        let grads = (sigma.clone().reshape([1]) * rows.mean()).backward();
        f64::from(host_f32(&sigma.grad(&grads).expect("σ has a gradient"))[0])
    };
    let reference: f64 = (0..g)
        .map(|i| {
            let r = &raw[10 * i..10 * i + 10];
            let offsets: f64 = r[..3]
                .iter()
                .map(|&v| ((v / max_offset).tanh() * max_offset).abs())
                .sum();
            offsets / 0.01 + r[3..].iter().map(|v| v.abs()).sum::<f64>()
        })
        .sum::<f64>()
        / g as f64;
    for s in [0.1, 0.5, 0.9] {
        let got = slope(true, s);
        assert!(
            (got - reference).abs() < 1e-4 * reference.max(1.0),
            "seed {seed}, σ = {s}: the field's slope {got} vs S(F) = {reference}"
        );
    }
    assert!(
        slope(false, 0.2) > 0.0,
        "seed {seed}: gated slope at σ = 0.2"
    );
    assert!(
        slope(false, 0.9) < 0.0,
        "seed {seed}: the gated term turns past σ ≈ 0.56, so at 0.9 it falls"
    );
}

/// The per-Gaussian gate's Eq. 6: `d/dσ_i = (λ_s s_i − λ_k L_kine) / G` for each of `G`
/// Gaussians' σ and sparsity rows, on fresh random values; at equal σ_i it is the
/// person-frame total with `L_sparse = mean_i s_i`.
#[test]
fn per_gaussian_sigma_gradients_are_their_rows_against_the_kinematics() {
    let seed = crate::fresh_seed();
    let mut rng = Rng(seed);
    let device = Device::flex();
    let g = 7;
    let sigmas: Vec<f32> = (0..g).map(|_| rng.range(0.05, 0.95) as f32).collect();
    let rows: Vec<f32> = (0..g).map(|_| rng.range(0.0, 2.0) as f32).collect();
    let (lb, ll) = (rng.range(0.0, 2.0), rng.range(0.0, 2.0));
    let w = paper_weights();
    let constant = |v: f64| Tensor::<1>::from_floats([v as f32], &device).autodiff();
    let sigma = Tensor::<2>::from_data(TensorData::new(sigmas.clone(), [g, 1]), &device)
        .autodiff()
        .require_grad();
    let terms = PersonTerms {
        sigma: sigma.clone(),
        sparsity: Tensor::<1>::from_data(TensorData::new(rows.clone(), [g]), &device).autodiff(),
        bone: constant(lb),
        limit: constant(ll),
    };
    let grads = terms.total(&w).backward();
    let got = host_f32(&sigma.grad(&grads).expect("each σ_i has a gradient"));
    let kine = w.bone * lb + w.limit * ll;
    for i in 0..g {
        let want = (w.sparse * f64::from(rows[i]) - w.kine * kine) / g as f64;
        assert!(
            (f64::from(got[i]) - want).abs() < 1e-6,
            "seed {seed}, Gaussian {i}: {} vs {want}",
            got[i]
        );
    }
    // Equal σ_i: the person-frame total on the mean row.
    let equal = PersonTerms {
        sigma: Tensor::<2>::full([g, 1], sigmas[0], &device),
        sparsity: Tensor::<1>::from_data(TensorData::new(rows.clone(), [g]), &device),
        bone: Tensor::<1>::from_floats([lb as f32], &device),
        limit: Tensor::<1>::from_floats([ll as f32], &device),
    };
    let mean_row = rows.iter().map(|&r| f64::from(r)).sum::<f64>() / g as f64;
    let frame = PersonTerms {
        sigma: Tensor::<2>::full([1, 1], sigmas[0], &device),
        sparsity: Tensor::<1>::from_floats([mean_row as f32], &device),
        bone: Tensor::<1>::from_floats([lb as f32], &device),
        limit: Tensor::<1>::from_floats([ll as f32], &device),
    };
    let (a, b) = (scalar(equal.total(&w)), scalar(frame.total(&w)));
    assert!(
        (a - b).abs() < 1e-6 * b.abs().max(1.0),
        "seed {seed}: {a} vs {b}"
    );
}

#[test]
fn the_residual_chain_matches_finite_differences() {
    let seed = crate::fresh_seed();
    let mut rng = Rng(seed);
    let device = Device::flex();
    let g = 4;
    let quats: Vec<f32> = (0..4 * g).map(|_| rng.normal() as f32).collect();
    let posed = Splats {
        means: Tensor::zeros([g, 3], &device),
        quats: Tensor::<2>::from_data(TensorData::new(quats, [g, 4]), &device),
        log_scales: Tensor::zeros([g, 3], &device),
        opacity_logits: Tensor::zeros([g], &device),
        colors: Tensor::zeros([g, 1, 3], &device),
    };
    let root = axis_angle_to_matrix(Tensor::random(
        [1, 3],
        Distribution::Normal(0.0, 1.0),
        &device,
    ))
    .reshape([3, 3]);
    let weights = Tensor::<2>::random([g, 17], Distribution::Normal(0.0, 1.0), &device);
    let raw0: Vec<f32> = (0..10 * g).map(|_| (0.1 * rng.normal()) as f32).collect();
    let objective = |raw: Tensor<2>, autodiff: bool| {
        let lift = |t: Tensor<2>| if autodiff { t.autodiff() } else { t };
        let amplitude = lift(Tensor::full([1, 1], 0.7, &device));
        let produced = gate_outputs(raw, amplitude, 0.25);
        let p = Splats {
            means: lift(posed.means.clone()),
            quats: lift(posed.quats.clone()),
            log_scales: lift(posed.log_scales.clone()),
            opacity_logits: if autodiff {
                posed.opacity_logits.clone().autodiff()
            } else {
                posed.opacity_logits.clone()
            },
            colors: posed.colors.clone(),
        };
        let r = world_residual(&p, &produced, lift(root.clone()));
        let all = Tensor::cat(
            vec![
                r.means.expect("means"),
                r.quats.expect("quats"),
                r.log_scales.expect("scales"),
                produced.offsets,
                produced.rotations,
            ],
            1,
        );
        (all * lift(weights.clone())).sum()
    };
    let leaf = Tensor::<2>::from_data(TensorData::new(raw0.clone(), [g, 10]), &device)
        .autodiff()
        .require_grad();
    let grads = objective(leaf.clone(), true).backward();
    let analytic = host_f32(&leaf.grad(&grads).expect("gradient"));
    let eps = 1e-3f32;
    for k in 0..10 * g {
        let mut plus = raw0.clone();
        plus[k] += eps;
        let mut minus = raw0.clone();
        minus[k] -= eps;
        let f = |v: Vec<f32>| {
            scalar(objective(
                Tensor::from_data(TensorData::new(v, [g, 10]), &device),
                false,
            ))
        };
        let numeric = (f(plus) - f(minus)) / (2.0 * f64::from(eps));
        let a = f64::from(analytic[k]);
        assert!(
            (a - numeric).abs() <= 2e-2 * numeric.abs().max(1.0),
            "seed {seed}: input {k}: autodiff {a}, finite difference {numeric}"
        );
    }
}
