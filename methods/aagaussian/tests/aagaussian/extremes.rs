//! Spec acceptance 12, the extremes: guidance at ω = 0, one item, t at both ends of the
//! schedule (zero terminal SNR included) stays finite; a model's NaN is zeroed and counted;
//! the line-of-sight term with no Gaussian in the face is zero without a gradient; a face view
//! with nothing in it gives a finite face loss.

use crate::sds::crate_seed;
use burn::tensor::{Tensor, TensorData};
use splatzoo_aagaussian::AagError;
use splatzoo_aagaussian::face::{FaceNorm, LineOfSight, centre_weights, face_colour_loss};
use splatzoo_aagaussian::oracle::{Components, FixedTargets, MixtureOracle};
use splatzoo_aagaussian::schedule::{NoiseSchedule, TimestepRange};
use splatzoo_aagaussian::score::{Conditioning, LatentBatch, Prediction, ScoreModel, ViewClass};
use splatzoo_aagaussian::sds::{Guidance, SdsConfig, SdsView};
use splatzoo_datasets::synth::rng::Rng;
use splatzoo_rasterizer::Camera;
use splatzoo_train::backend::Backend;
use splatzoo_train::host_f32;

fn view() -> SdsView {
    SdsView {
        camera: Camera::look_at([0.0, 0.0, 2.0], [0.0; 3], [0.0, 1.0, 0.0], 50.0, 4, 4),
        view: ViewClass::Front,
    }
}

fn batch(rng: &mut Rng) -> LatentBatch {
    LatentBatch {
        shape: [1, 3, 4, 4],
        data: (0..48).map(|_| rng.range(-1.0, 1.0) as f32).collect(),
    }
}

#[test]
fn guidance_stays_finite_at_the_extremes() {
    let mut rng = Rng(crate_seed());
    let targets: Vec<Vec<Vec<f32>>> = (0..2).map(|_| vec![batch(&mut rng).data]).collect();
    for (schedule, prediction) in [
        (NoiseSchedule::sd2(), Prediction::Epsilon),
        (NoiseSchedule::sd2().zero_snr(), Prediction::V),
        (NoiseSchedule::sd2().zero_snr(), Prediction::Epsilon),
    ] {
        let model = MixtureOracle {
            schedule: schedule.clone(),
            prediction,
            data_noise: 0.1,
            components: Components::labels(0, 1, 2),
            branches: 1,
            targets: Box::new(FixedTargets {
                images: targets.clone(),
            }),
        };
        for guidance in [Guidance::Cfg, Guidance::Anpg, Guidance::HumanGaussian] {
            for (t_min, t_max) in [(0, 0), (999, 999)] {
                let config = SdsConfig {
                    guidance,
                    scale: 0.0,
                    timesteps: TimestepRange {
                        t_min,
                        t_max,
                        t_max_annealed: t_max,
                        ..TimestepRange::default()
                    },
                    ..SdsConfig::default()
                };
                let out = config
                    .guidance(&model, &[batch(&mut rng)], &[view()], 0, &mut rng)
                    .expect("guidance");
                assert!(
                    out.grads[0].data.iter().all(|g| g.is_finite()),
                    "{guidance:?} {prediction:?} t {t_min}: {:?}",
                    out.grads[0].data
                );
            }
        }
    }
}

/// A model that answers NaN everywhere.
struct Broken(NoiseSchedule);

impl ScoreModel for Broken {
    fn schedule(&self) -> &NoiseSchedule {
        &self.0
    }
    fn prediction(&self) -> Prediction {
        Prediction::Epsilon
    }
    fn branches(&self) -> usize {
        1
    }
    fn predict(
        &self,
        noisy: &[LatentBatch],
        _t: &[usize],
        _cond: &Conditioning,
    ) -> Result<Vec<LatentBatch>, AagError> {
        Ok(noisy
            .iter()
            .map(|b| LatentBatch {
                shape: b.shape,
                data: vec![f32::NAN; b.data.len()],
            })
            .collect())
    }
}

#[test]
fn a_model_nan_is_zeroed_and_counted() {
    let mut rng = Rng(crate_seed() ^ 3);
    let out = SdsConfig::default()
        .guidance(
            &Broken(NoiseSchedule::sd2()),
            &[batch(&mut rng)],
            &[view()],
            0,
            &mut rng,
        )
        .expect("guidance");
    assert_eq!(out.nonfinite, 48);
    assert!(out.grads[0].data.iter().all(|g| *g == 0.0));
}

#[test]
fn an_empty_face_view_is_finite_and_pulls_nothing() {
    let device = Backend::Flex.device().autodiff();
    let size = 8;
    let camera = Camera::look_at([0.0, 0.0, 1.0], [0.0; 3], [0.0, 1.0, 0.0], 40.0, 8, 8);
    let los = LineOfSight {
        camera,
        mask: vec![true; size * size],
        depth: vec![1.0; size * size],
        margin: 0.02,
        distance: 0.5,
    };
    // Every centre behind the camera: none is in the face.
    let means = Tensor::<2>::from_data(
        TensorData::new(vec![0.0f32, 0.0, 5.0, 0.1, 0.0, 4.0], [2, 3]),
        &device,
    )
    .require_grad();
    let opacity =
        Tensor::<1>::from_data(TensorData::new(vec![3.0f32, 3.0], [2]), &device).require_grad();
    let loss = los.loss(means.clone(), opacity.clone()).expect("finite");
    assert_eq!(host_f32(&loss), vec![0.0]);
    // Inside a step it is one term among tracked ones; it adds nothing to their gradient.
    let step = loss + means.clone().sum().mul_scalar(0.0) + opacity.clone().sum().mul_scalar(0.0);
    let grads = step.backward();
    let g = host_f32(&means.grad(&grads).expect("tracked"));
    assert!(g.iter().all(|v| *v == 0.0), "{g:?}");

    // A black render against a crop: finite.
    let image = Tensor::<3>::zeros([size, size, 3], &device);
    let crop = Tensor::<3>::ones([size, size, 3], &device);
    let value = host_f32(&face_colour_loss(
        image,
        crop,
        &centre_weights(size, 0.25),
        FaceNorm::L1,
    ));
    assert!((value[0] - 1.0).abs() < 1e-5, "{value:?}");
}

/// A whole training step under extreme inputs, through the engine's shared check: a 1×1 SDS
/// render, one view per step, a single initial Gaussian, scene extents of 1e-3 and 1e3: each
/// a finite step with finite state, or a refusal naming the knob.
#[test]
fn a_whole_step_at_the_extremes_is_finite_or_refused_by_name() {
    use splatzoo_aagaussian::Aag;
    use splatzoo_aagaussian::config::AagConfig;
    use splatzoo_train::harness::extremes::{StepOutcome, one_step};
    let tiny = || {
        let mut c = AagConfig {
            gaussians: 300,
            batch: 2,
            render_size: 8,
            data: crate::common::tiny_portrait(8),
            ..AagConfig::default()
        };
        c.face.start = 0;
        c
    };
    let device = Backend::Flex.device();
    type Change = fn(&mut AagConfig);
    let cases: [(&str, Change); 5] = [
        ("1×1 render", |c| c.render_size = 1),
        ("one view a step", |c| c.batch = 1),
        ("one Gaussian", |c| c.gaussians = 1),
        ("extent 1e-3", |c| c.extent = 1e-3),
        ("extent 1e3", |c| c.extent = 1e3),
    ];
    for (what, change) in cases {
        let mut config = tiny();
        change(&mut config);
        match one_step::<Aag>(config, &device) {
            Ok(StepOutcome::Finite { loss }) => assert!(loss.is_finite()),
            Ok(StepOutcome::Refused(message)) => {
                assert!(!message.is_empty(), "{what}: an empty refusal")
            }
            Err(failure) => panic!("{what}: {failure}"),
        }
    }
    let mut none = tiny();
    none.gaussians = 0;
    match one_step::<Aag>(none, &device) {
        Ok(StepOutcome::Refused(message)) => assert!(message.contains("gaussians"), "{message}"),
        other => panic!("no Gaussians: {other:?}"),
    }
}
