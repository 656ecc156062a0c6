//! The schedule and the SDS driver against closed forms (spec T4, T1 without the rasterizer,
//! T5, U2).

use splatzoo_aagaussian::oracle::{Components, FixedTargets, MixtureOracle};
use splatzoo_aagaussian::schedule::NoiseSchedule;
use splatzoo_aagaussian::score::{LatentBatch, Prediction, ViewClass};
use splatzoo_aagaussian::sds::{Guidance, SdsConfig, SdsView, Weighting, clip_pixel_norm};
use splatzoo_datasets::synth::rng::Rng;
use splatzoo_rasterizer::Camera;

#[test]
fn schedule_constants_match_sd2_and_zero_snr() {
    let sd2 = NoiseSchedule::sd2();
    assert!((sd2.alpha_bar(0) - 0.99915).abs() < 1e-9);
    assert!((sd2.alpha_bar(999) - 0.004_660_1).abs() < 1e-6);
    let zero = sd2.zero_snr();
    assert_eq!(zero.alpha_bar(999), 0.0);
    assert!((zero.alpha_bar(499) - 0.242_359).abs() < 1e-5);
    assert!((zero.alpha_bar(0) - 0.99915).abs() < 1e-9);
}

fn oracle(target: Vec<f32>, prediction: Prediction, schedule: NoiseSchedule) -> MixtureOracle {
    MixtureOracle {
        schedule,
        prediction,
        data_noise: 0.0,
        components: Components::labels(0, 0, 1),
        branches: 1,
        targets: Box::new(FixedTargets {
            images: vec![vec![target]],
        }),
    }
}

fn view() -> SdsView {
    SdsView {
        camera: Camera::look_at([0.0, 0.0, 2.0], [0.0; 3], [0.0, 1.0, 0.0], 50.0, 4, 4),
        view: ViewClass::Front,
    }
}

fn plain() -> SdsConfig {
    SdsConfig {
        guidance: Guidance::Plain,
        clip_norm: 0.0,
        clamp_start: 0.0,
        ..SdsConfig::default()
    }
}

/// Under one point mass, `g = w_t α_t (x − y) / σ_t` exactly: the noise cancels.
#[test]
fn point_mass_sds_is_a_weighted_l2_without_noise() {
    let mut rng = Rng(crate_seed());
    let x: Vec<f32> = (0..48).map(|_| rng.range(-1.0, 1.0) as f32).collect();
    let y: Vec<f32> = (0..48).map(|_| rng.range(-1.0, 1.0) as f32).collect();
    let model = oracle(y.clone(), Prediction::Epsilon, NoiseSchedule::sd2());
    let z = LatentBatch {
        shape: [1, 3, 4, 4],
        data: x.clone(),
    };
    let config = plain();
    for step in 0..20 {
        let out = config
            .guidance(&model, std::slice::from_ref(&z), &[view()], step, &mut rng)
            .expect("guidance");
        let t = out.t[0];
        let s = NoiseSchedule::sd2();
        let (a, sg) = (s.alpha(t), s.sigma(t));
        let w = 1.0 - s.alpha_bar(t);
        for j in 0..48 {
            let expected = w * a * f64::from(x[j] - y[j]) / sg;
            let got = f64::from(out.grads[0].data[j]);
            assert!(
                (got - expected).abs() < 1e-4 * (1.0 + expected.abs()),
                "t {t}: {got} vs {expected}"
            );
        }
    }
}

/// A v-predicting oracle on the zero-SNR schedule gives the ε oracle's gradient (U2).
#[test]
fn v_and_epsilon_prediction_agree() {
    let mut rng = Rng(crate_seed() ^ 5);
    let x: Vec<f32> = (0..48).map(|_| rng.range(-1.0, 1.0) as f32).collect();
    let y: Vec<f32> = (0..48).map(|_| rng.range(-1.0, 1.0) as f32).collect();
    let z = LatentBatch {
        shape: [1, 3, 4, 4],
        data: x,
    };
    let schedule = NoiseSchedule::sd2().zero_snr();
    let config = SdsConfig {
        weighting: Weighting::Uniform,
        ..plain()
    };
    let seed = crate_seed();
    let eps = oracle(y.clone(), Prediction::Epsilon, schedule.clone());
    let v = oracle(y, Prediction::V, schedule);
    let a = config
        .guidance(&eps, std::slice::from_ref(&z), &[view()], 0, &mut Rng(seed))
        .expect("ε");
    let b = config
        .guidance(&v, &[z], &[view()], 0, &mut Rng(seed))
        .expect("v");
    assert_eq!(a.t, b.t);
    for (p, q) in a.grads[0].data.iter().zip(&b.grads[0].data) {
        assert!((p - q).abs() < 1e-3 * (1.0 + p.abs()), "{p} vs {q}");
    }
}

#[test]
fn clipping_bounds_each_pixel_over_channels() {
    let mut rng = Rng(crate_seed() ^ 9);
    let mut g = LatentBatch {
        shape: [2, 3, 5, 5],
        data: (0..150).map(|_| (rng.normal() * 3.0) as f32).collect(),
    };
    let before = g.clone();
    clip_pixel_norm(&mut g, 1.0, false);
    for b in 0..2 {
        for p in 0..25 {
            let norm = |x: &LatentBatch| {
                (0..3)
                    .map(|c| f64::from(x.data[b * 75 + c * 25 + p]).powi(2))
                    .sum::<f64>()
                    .sqrt()
            };
            assert!(norm(&g) <= 1.0 + 1e-5);
            if norm(&before) <= 1.0 {
                assert_eq!(norm(&g), norm(&before));
            }
        }
    }
}

pub fn crate_seed() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .expect("the clock is past 1970")
        .as_nanos() as u64
}
