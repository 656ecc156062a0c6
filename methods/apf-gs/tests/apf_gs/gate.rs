//! The gate's amplitude `a(σ)` and σ's source (Eq. 4's modulation; A3, A9).

use burn::tensor::{Device, Tensor};
use splatzoo_apf_gs::gate::{GateConfig, GateForm, GateMode};
use splatzoo_datasets::synth::rng::Rng;
use splatzoo_train::host_f32;

#[test]
fn amplitude_is_full_at_zero_and_kappa_at_one_for_the_blend() {
    let gate = GateConfig::default();
    assert_eq!(gate.form, GateForm::Blend);
    assert!((gate.amplitude_of(0.0) - 1.0).abs() < 1e-12);
    assert!((gate.amplitude_of(1.0) - gate.kappa).abs() < 1e-12);
    let literal = GateConfig {
        form: GateForm::Sigma,
        ..GateConfig::default()
    };
    assert_eq!(
        (literal.amplitude_of(0.0), literal.amplitude_of(1.0)),
        (0.0, 1.0)
    );
    let other = GateConfig {
        form: GateForm::OneMinus,
        ..GateConfig::default()
    };
    assert_eq!(
        (other.amplitude_of(0.0), other.amplitude_of(1.0)),
        (1.0, 0.0)
    );
}

#[test]
fn tensor_amplitude_matches_the_scalar_formula() {
    let seed = crate::fresh_seed();
    let mut rng = Rng(seed);
    let device = Device::flex();
    for form in [GateForm::Blend, GateForm::Sigma, GateForm::OneMinus] {
        let gate = GateConfig {
            form,
            kappa: rng.range(0.0, 1.0),
            ..GateConfig::default()
        };
        let sigmas: Vec<f32> = (0..16).map(|_| rng.range(0.0, 1.0) as f32).collect();
        let t = Tensor::<1>::from_floats(sigmas.as_slice(), &device).reshape([16, 1]);
        let a = host_f32(&gate.amplitude(t));
        for (s, a) in sigmas.iter().zip(a) {
            let expected = gate.amplitude_of(f64::from(*s));
            assert!(
                (f64::from(a) - expected).abs() < 1e-6,
                "seed {seed}: {form:?} σ {s}"
            );
        }
    }
}

#[test]
fn fixed_sigma_ignores_the_logits_and_saturated_logits_stay_finite() {
    let device = Device::flex();
    let logits = Tensor::<1>::from_floats([-60.0, 0.0, 60.0], &device).reshape([3, 1]);
    let fixed = GateConfig {
        mode: GateMode::Fixed,
        value: 0.3,
        ..GateConfig::default()
    };
    assert_eq!(host_f32(&fixed.sigma(logits.clone())), vec![0.3f32; 3]);
    let learned = GateConfig::default();
    let sigma = host_f32(&learned.sigma(logits));
    assert!(
        sigma
            .iter()
            .all(|s| s.is_finite() && (0.0..=1.0).contains(s))
    );
    assert!(sigma[0] < 1e-6 && sigma[2] > 1.0 - 1e-6);
}
