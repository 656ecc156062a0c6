//! The probe scores against the analytic light: zero on the light itself at any gain, a
//! missing band weighed by the cosine lobe in the irradiance error, and each band's cosine
//! telling a band that points the wrong way from one that is missing.

use burn::module::Param;
use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_illum::eval::TruthScores;
use splatzoo_illum::method::Illum;
use splatzoo_illum::probe_scores::ProbeBand;
use splatzoo_illum::trainer::IllumTrainer;
use splatzoo_train::harness::Method;

/// Sets every probe to `gain ×` the analytic SH of the training light, band `l` further scaled
/// by `band_scale[l]`: the whole coefficient in the probe's own part, the shared environment 0.
fn set_probes(trainer: &mut IllumTrainer, gain: f64, band_scale: [f64; 3]) {
    let truth = trainer
        .capture
        .truth
        .clone()
        .expect("the synthetic capture's truth");
    let grid = *trainer.volume.grid();
    let [p, k, _] = trainer.volume.sh.val().dims();
    assert_eq!(k, 9, "the default probes are SH degree 2");
    let mut values = vec![0.0f32; p * k * 3];
    for i in 0..p {
        let sh = truth.probe_truth(grid.position(i));
        for (j, coefficient) in sh.iter().enumerate() {
            let band = (j as f64).sqrt() as usize;
            for c in 0..3 {
                values[(i * k + j) * 3 + c] = (gain * band_scale[band] * coefficient[c]) as f32;
            }
        }
    }
    let device = trainer.volume.sh.val().device();
    trainer.volume.sh = Param::from_tensor(Tensor::from_data(
        TensorData::new(values, [p, k, 3]),
        &device,
    ));
    trainer.volume.environment = Param::from_tensor(Tensor::zeros([k, 3], &device));
}

#[test]
fn vanish_on_the_scaled_light_and_weigh_a_missing_band_by_the_cosine_lobe() {
    let device = Device::flex();
    let mut method = Illum::new(super::trainer::tiny(), &device).unwrap();
    let trainer = &mut method.trainer;
    let truth = trainer.capture.truth.clone().unwrap();

    set_probes(trainer, 2.5, [1.0; 3]);
    let gain = trainer.probe_gain().unwrap();
    for g in gain {
        assert!((g - 2.5).abs() < 1e-5, "gain {gain:?}");
    }
    let mut scores = TruthScores::default();
    trainer.probe_scores(&truth, gain, &mut scores);
    let bands = scores.probe_bands_seen.clone().unwrap();
    assert_eq!(bands.len(), 3, "{bands:?}");
    for (name, error) in [
        ("whole grid", scores.probe_relative_error.unwrap()),
        ("seen", scores.probe_relative_error_seen.unwrap()),
        ("irradiance", scores.probe_irradiance_error_seen.unwrap()),
    ]
    .into_iter()
    .chain(bands.iter().map(|b| ("band", b.relative_error)))
    {
        assert!(error < 1e-5, "{name}: {error} in {scores:?}");
    }
    for band in &bands {
        assert!(band.truth_rms > 0.0, "the light has no band {band:?}");
        let ratio = band.learned_rms / band.truth_rms;
        assert!((ratio - 1.0).abs() < 1e-5, "{band:?}");
        assert!((band.cosine - 1.0).abs() < 1e-6, "{band:?}");
    }

    // Band 2 gone: its error is whole, the others stay exact, and the irradiance error is
    // band 2's share after the lobe's 1, 2/3, 1/4.
    set_probes(trainer, 2.5, [1.0, 1.0, 0.0]);
    let seen = trainer.seen_probes();
    let (bands, irradiance) = trainer.probe_band_scores(&truth, [2.5; 3], &seen);
    assert!(bands[0].relative_error < 1e-5 && bands[1].relative_error < 1e-5);
    assert!((bands[2].relative_error - 1.0).abs() < 1e-9, "{bands:?}");
    assert_eq!(bands[2].learned_rms, 0.0);
    assert_eq!(bands[2].cosine, 0.0);
    let energy = |b: &ProbeBand| b.truth_rms.powi(2) * (2 * b.band + 1) as f64;
    let expected = 0.25 * energy(&bands[2]).sqrt()
        / (energy(&bands[0]) + energy(&bands[1]) * 4.0 / 9.0 + energy(&bands[2]) / 16.0).sqrt();
    assert!(
        (irradiance - expected).abs() < 1e-6 * expected,
        "{irradiance} against {expected}"
    );

    // Band 1 turned the other way and three times too strong: its cosine is −1 whatever its
    // size, band 2 keeps 1, and the error counts both the sign and the size.
    set_probes(trainer, 2.5, [1.0, -3.0, 1.0]);
    let (bands, _) = trainer.probe_band_scores(&truth, [2.5; 3], &seen);
    assert!((bands[1].cosine + 1.0).abs() < 1e-6, "{bands:?}");
    assert!((bands[2].cosine - 1.0).abs() < 1e-6, "{bands:?}");
    assert!((bands[1].relative_error - 4.0).abs() < 1e-5, "{bands:?}");
}
