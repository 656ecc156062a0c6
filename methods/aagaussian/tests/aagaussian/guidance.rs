//! Spec T3 and T5: where each guidance form's SDS gradient vanishes when pixels are optimised
//! directly under point-mass targets (classic CFG lands on `y_u + ω (y_c − y_u)`,
//! HumanGaussian's form on `y_c + ω (y_c − y_u)`, plain SDS on `y_c`: SDS with guidance is not
//! an L2 fit), and the surrogate's gradient `2 λ g / B` through Burn's autodiff.

use crate::sds::crate_seed;
use burn::tensor::{Tensor, TensorData};
use splatzoo_aagaussian::fixed_points;
use splatzoo_aagaussian::oracle::{Components, FixedTargets, MixtureOracle};
use splatzoo_aagaussian::schedule::NoiseSchedule;
use splatzoo_aagaussian::score::{LatentBatch, Prediction, ViewClass};
use splatzoo_aagaussian::sds::{Guidance, SdsConfig, SdsView, Weighting, surrogate};
use splatzoo_datasets::synth::rng::Rng;
use splatzoo_rasterizer::Camera;
use splatzoo_train::backend::Backend;
use splatzoo_train::host_f32;

const PIXELS: usize = 3 * 4 * 4;

fn fixed_point(guidance: Guidance, omega: f64, y_c: &[f32], y_u: &[f32], seed: u64) -> Vec<f32> {
    fixed_points::fixed_point(guidance, omega, 200, y_c, y_u, seed).expect("guidance")
}

#[test]
fn guidance_forms_have_their_closed_form_fixed_points() {
    let seed = crate_seed();
    let mut rng = Rng(seed);
    let y_c: Vec<f32> = (0..PIXELS).map(|_| rng.range(-0.5, 0.5) as f32).collect();
    let y_u: Vec<f32> = (0..PIXELS).map(|_| rng.range(-0.5, 0.5) as f32).collect();
    let omega = 3.0;
    // The closed forms, written out here (the library's `closed_form` is what the run reports).
    type Expected = Box<dyn Fn(f32, f32) -> f32>;
    let cases: [(Guidance, Expected); 3] = [
        (Guidance::Plain, Box::new(|c, _| c)),
        (
            Guidance::Cfg,
            Box::new(move |c, u| u + omega as f32 * (c - u)),
        ),
        (
            Guidance::HumanGaussian,
            Box::new(move |c, u| c + omega as f32 * (c - u)),
        ),
    ];
    for (guidance, expected) in cases {
        let x = fixed_point(guidance, omega, &y_c, &y_u, seed ^ 11);
        for j in 0..PIXELS {
            let want = expected(y_c[j], y_u[j]);
            assert_eq!(
                fixed_points::closed_form(guidance, omega, y_c[j], y_u[j]),
                Some(want)
            );
            assert!(
                (x[j] - want).abs() < 1e-3,
                "{guidance:?} pixel {j}: {} vs {want}",
                x[j]
            );
        }
    }
    // The run's report: CFG's landing point matches its closed form and lies beyond y_c.
    let report = fixed_points::check(&[Guidance::Plain, Guidance::Cfg], omega, 200, seed ^ 17)
        .expect("checked");
    assert!(
        report[0].closed_form_error.expect("closed form") < 1e-3,
        "{report:?}"
    );
    assert!(report[0].beyond_target < 1e-3, "{report:?}");
    assert!(
        report[1].closed_form_error.expect("closed form") < 1e-3,
        "{report:?}"
    );
    assert!(report[1].beyond_target > 0.1, "{report:?}");
    // Classic CFG lands beyond the target, where an L2 fit would stop at y_c.
    let cfg = fixed_point(Guidance::Cfg, omega, &y_c, &y_u, seed ^ 13);
    let off: f32 = cfg.iter().zip(&y_c).map(|(x, c)| (x - c).abs()).sum();
    assert!(off > 0.1 * PIXELS as f32 * 0.1, "CFG stayed on y_c ({off})");
}

/// `d/dz λ ‖z − sg(z − g)‖² / B = 2 λ g / B` exactly, and the value is `λ ‖g‖² / B`.
#[test]
fn surrogate_gradient_is_two_lambda_g_over_b() {
    let device = Backend::Flex.device().autodiff();
    let mut rng = Rng(crate_seed() ^ 17);
    let shape = [3, 2, 5, 4];
    let n: usize = shape.iter().product();
    let z_host: Vec<f32> = (0..n).map(|_| rng.normal() as f32).collect();
    let g = LatentBatch {
        shape,
        data: (0..n).map(|_| rng.normal() as f32).collect(),
    };
    let lambda = 0.5;
    let z = Tensor::<4>::from_data(TensorData::new(z_host, shape.to_vec()), &device).require_grad();
    let loss = surrogate(z.clone(), &g, lambda).expect("same shape");
    let value = splatzoo_train::loss::scalar(loss.clone());
    let norm2: f64 = g.data.iter().map(|v| f64::from(*v).powi(2)).sum();
    assert!((value - lambda * norm2 / 3.0).abs() < 1e-4 * (1.0 + value));
    let grads = loss.backward();
    let dz = host_f32(&z.grad(&grads).expect("z is a leaf"));
    for (d, gj) in dz.iter().zip(&g.data) {
        let want = 2.0 * lambda as f32 * gj / 3.0;
        assert!(
            (d - want).abs() < 1e-5 * (1.0 + want.abs()),
            "{d} vs {want}"
        );
    }
    let wrong = LatentBatch {
        shape: [1, 2, 5, 4],
        data: vec![0.0; 40],
    };
    let err = surrogate(z, &wrong, lambda).expect_err("shape mismatch");
    assert!(err.to_string().contains("[3, 2, 5, 4]"), "{err}");
}

/// Standardised residuals `(g − E[g]) / sd[g]` of plain SDS under one blurred identity
/// (S2 with K = 1, s = 0.1): `E[g] = w σ α (x − y) / D` and `sd[g] = w α² s² / D` with
/// `D = α² s² + σ²`, over every draw and element.
fn residual_moments(weighting: Weighting, draws: usize, seed: u64) -> (f64, f64) {
    let mut rng = Rng(seed);
    let x: Vec<f32> = (0..PIXELS).map(|_| rng.range(-1.0, 1.0) as f32).collect();
    let y: Vec<f32> = (0..PIXELS).map(|_| rng.range(-1.0, 1.0) as f32).collect();
    let s = 0.1;
    let schedule = NoiseSchedule::sd2();
    let model = MixtureOracle {
        schedule: schedule.clone(),
        prediction: Prediction::Epsilon,
        data_noise: s,
        components: Components::labels(0, 0, 1),
        branches: 1,
        targets: Box::new(FixedTargets {
            images: vec![vec![y.clone()]],
        }),
    };
    let config = SdsConfig {
        guidance: Guidance::Plain,
        weighting,
        clip_norm: 0.0,
        clamp_start: 0.0,
        ..SdsConfig::default()
    };
    let view = SdsView {
        camera: Camera::look_at([0.0, 0.0, 2.0], [0.0; 3], [0.0, 1.0, 0.0], 50.0, 4, 4),
        view: ViewClass::Front,
    };
    let z = LatentBatch {
        shape: [1, 3, 4, 4],
        data: x.clone(),
    };
    let (mut sum, mut sum2, mut count) = (0.0, 0.0, 0.0);
    for _ in 0..draws {
        let out = config
            .guidance(&model, std::slice::from_ref(&z), &[view], 0, &mut rng)
            .expect("guidance");
        let t = out.t[0];
        let (a, sg) = (schedule.alpha(t), schedule.sigma(t));
        let d = a * a * s * s + sg * sg;
        let w = 1.0 - schedule.alpha_bar(t);
        for j in 0..PIXELS {
            let mean = w * sg * a * f64::from(x[j] - y[j]) / d;
            let sd = w * a * a * s * s / d;
            let r = (f64::from(out.grads[0].data[j]) - mean) / sd;
            sum += r;
            sum2 += r * r;
            count += 1.0;
        }
    }
    let mean = sum / count;
    (mean, sum2 / count - mean * mean)
}

/// Spec T2: the Monte-Carlo mean of the SDS gradient under S2 with one identity is its closed
/// form (within 4 standard errors) and its spread is the noise term's; uniform weighting
/// does not fit the `1 − ᾱ_t` formula.
#[test]
fn mixture_sds_matches_its_closed_form_mean_and_variance() {
    let draws = 4096;
    let (mean, variance) = residual_moments(Weighting::Sds, draws, crate_seed());
    let samples = (draws * PIXELS) as f64;
    assert!(mean.abs() < 4.0 / samples.sqrt(), "mean residual {mean}");
    // The variance estimate of ~2·10⁵ unit normals is 1 within a few hundredths.
    assert!(
        (variance - 1.0).abs() < 0.05,
        "residual variance {variance}"
    );
    let (_, uniform) = residual_moments(Weighting::Uniform, 256, crate_seed() ^ 1);
    assert!(
        (uniform - 1.0).abs() > 0.5,
        "uniform weighting fit: {uniform}"
    );
}
