//! The trainer on a tiny capture: density control and prune-only fire exactly on their steps,
//! the face term only from its start step, a checkpoint resumes bit-exactly on the CPU, and
//! the face term's centre weights (spec T7's weight checks).

use crate::common::tiny_portrait;
use crate::sds::crate_seed;
use burn::tensor::{Tensor, TensorData};
use splatzoo_aagaussian::Aag;
use splatzoo_aagaussian::config::AagConfig;
use splatzoo_aagaussian::data::PortraitConfig;
use splatzoo_aagaussian::face::{FaceNorm, centre_weights, face_colour_loss};
use splatzoo_datasets::synth::rng::Rng;
use splatzoo_train::backend::Backend;
use splatzoo_train::harness::Method;
use splatzoo_train::host_f32;

fn tiny(seed: u64) -> AagConfig {
    let mut config = AagConfig {
        seed,
        gaussians: 300,
        batch: 2,
        render_size: 8,
        data: tiny_portrait(8),
        ..AagConfig::default()
    };
    config.densify.start = 2;
    config.densify.every = 2;
    config.densify.stop = 6;
    config.densify.grad_threshold = 0.0;
    // Nothing is pruned for opacity or size: the schedule is what is tested.
    config.densify.min_opacity = 0.0;
    config.densify.prune_only_min_opacity = 0.0;
    config.densify.prune_only_max_scale = 100.0;
    config.densify.prune_only_steps = vec![7];
    config.face.start = 5;
    config.face.probability = 1.0;
    config
}

/// Spec acceptance 9 (schedule): growth after steps 4 and 6 (`start < s ≤ stop`, every 2), the
/// prune-only phase after step 7, nothing elsewhere; the face term from step 5 on.
#[test]
fn density_control_and_face_term_fire_on_their_steps() {
    let device = Backend::Flex.device();
    let mut method = Aag::new(tiny(crate_seed() % 1000), &device).expect("assembles");
    let (mut density_steps, mut face_steps) = (Vec::new(), Vec::new());
    for _ in 0..9 {
        let record = method.trainer.train_step().expect("a step");
        let done = method.trainer.step;
        if record.density.is_some() {
            density_steps.push(done);
        }
        if record.face.is_some() {
            face_steps.push(done - 1);
        }
    }
    assert_eq!(density_steps, vec![4, 6, 7]);
    assert_eq!(face_steps, vec![5, 6, 7, 8]);
}

/// A run of 6 steps and a run of 3 steps, a checkpoint and 3 more steps end on the same bits.
#[test]
fn a_checkpoint_resumes_bit_exactly() {
    let device = Backend::Flex.device();
    let config = tiny(crate_seed() % 1000);
    let mut straight = Aag::new(config.clone(), &device).expect("assembles");
    for _ in 0..6 {
        straight.step().expect("a step");
    }
    let mut first = Aag::new(config.clone(), &device).expect("assembles");
    for _ in 0..3 {
        first.step().expect("a step");
    }
    let mut checkpoint = first.checkpoint();
    checkpoint.put_meta("step", 3);
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("checkpoint.safetensors");
    checkpoint.write(&path).expect("written");
    let read = splatzoo_train::checkpoint::Checkpoint::read(&path).expect("read");
    let mut resumed = Aag::resume(config, &read, &device).expect("resumes");
    for _ in 0..3 {
        resumed.step().expect("a step");
    }
    let (a, b) = (&straight.trainer.node.set, &resumed.trainer.node.set);
    assert_eq!(a.len(), b.len());
    assert_eq!(host_f32(&a.means), host_f32(&b.means));
    assert_eq!(host_f32(&a.quats), host_f32(&b.quats));
    assert_eq!(host_f32(&a.log_scales), host_f32(&b.log_scales));
    assert_eq!(host_f32(&a.opacity_logits), host_f32(&b.opacity_logits));
    assert_eq!(host_f32(&a.sh_dc), host_f32(&b.sh_dc));
    assert_eq!(straight.trainer.rng.0, resumed.trainer.rng.0);
}

/// U5's weights sum to 1 and peak at the centre; a colour error's gradient at a pixel is its
/// weight (over 3 channels), so a corner error pulls less than a centre error by their ratio.
#[test]
fn face_weights_sum_to_one_and_scale_the_gradient() {
    let size = 16;
    let weights = centre_weights(size, 0.25);
    let total: f64 = weights.iter().map(|w| f64::from(*w)).sum();
    assert!((total - 1.0).abs() < 1e-5);
    let centre = (size / 2) * size + size / 2;
    let top = weights.iter().fold(0.0f32, |m, w| m.max(*w));
    assert!(weights[centre] >= top * (1.0 - 1e-6));
    assert!(weights[0] < weights[centre]);

    let device = Backend::Flex.device().autodiff();
    let mut rng = Rng(crate_seed() ^ 5);
    let crop: Vec<f32> = (0..size * size * 3).map(|_| rng.next() as f32).collect();
    let image: Vec<f32> = crop.iter().map(|c| c + 0.1).collect();
    let image =
        Tensor::<3>::from_data(TensorData::new(image, [size, size, 3]), &device).require_grad();
    let crop = Tensor::<3>::from_data(TensorData::new(crop, [size, size, 3]), &device);
    let loss = face_colour_loss(image.clone(), crop, &weights, FaceNorm::L1);
    let grad = host_f32(&image.grad(&loss.backward()).expect("a leaf"));
    for p in [0, centre, size * size - 1] {
        for c in 0..3 {
            let want = weights[p] / 3.0;
            assert!(
                (grad[3 * p + c] - want).abs() < 1e-6 * (1.0 + want),
                "pixel {p}"
            );
        }
    }
}

/// The body prior comes from the portrait's keypoints: the fit reprojects within the noise,
/// lands near the true shape, and the avatar's canonical body is the fitted one.
#[test]
fn the_body_prior_is_fitted_from_the_portrait() {
    let config = PortraitConfig {
        body_fit: true,
        ..tiny_portrait(8)
    };
    let device = Backend::Flex.device();
    let capture =
        splatzoo_aagaussian::data::PortraitCapture::build(&config, &device).expect("a capture");
    let fit = capture.body_fit.as_ref().expect("fitted");
    assert!(fit.reprojection_rms_px < 4.0, "{fit:?}");
    assert!(fit.height_error.expect("graded").abs() < 0.07, "{fit:?}");
    assert!(fit.mpjpe_m.expect("graded") < 0.2, "{fit:?}");
    let bank = &capture.truth.as_ref().expect("synthetic").bank;
    let truth = &bank.identities[config.prompt].identity.betas;
    assert_ne!(&capture.body_betas, truth);
    assert_eq!(capture.body_betas, fit.betas);
    let keypoints = fit.keypoints.as_ref().expect("kept");
    assert_eq!(keypoints.body.len(), 25);
    assert_eq!(keypoints.body.iter().filter(|k| k[2] > 0.0).count(), 23);
}

/// Everything pruned is a clear error naming the knobs, not a panic.
#[test]
fn an_avatar_pruned_to_nothing_is_an_error() {
    let device = Backend::Flex.device();
    let mut config = tiny(crate_seed() % 1000);
    config.densify.min_opacity = 2.0; // every opacity is below it
    let mut method = Aag::new(config, &device).expect("assembles");
    let mut outcome = Ok(());
    for _ in 0..6 {
        if let Err(e) = method.trainer.train_step() {
            outcome = Err(e.to_string());
            break;
        }
    }
    let message = outcome.expect_err("pruned to nothing after step 4");
    assert!(message.contains("densify.min_opacity"), "{message}");
}

/// Only what the guidance needs (issue 20's rule): a two-branch model gets the depth branch
/// (its SDS term is non-zero and the module is on); a one-branch model's renders are never
/// depth-encoded (no depth term) and the decision says why.
#[test]
fn the_depth_branch_follows_the_guidance_model() {
    let device = Backend::Flex.device();
    for branches in [1, 2] {
        let mut config = tiny(crate_seed() % 1000);
        config.oracle.branches = branches;
        let mut method = Aag::new(config, &device).expect("assembles");
        let depth = method
            .modules()
            .into_iter()
            .find(|m| m.module.starts_with("depth branch"))
            .expect("the depth branch's decision");
        assert_eq!(depth.enabled, branches == 2, "{depth:?}");
        let record = method.trainer.train_step().expect("a step");
        if branches == 2 {
            assert!(record.sds_depth > 0.0, "{}", record.sds_depth);
        } else {
            assert_eq!(record.sds_depth, 0.0);
            assert!(depth.reason.contains("RGB only"), "{}", depth.reason);
        }
    }
}

/// The timestep range anneals at exactly its step: every t of steps 0–2 is drawn from
/// [20, 980] and at least one lies above the annealed maximum, every t from step 3 on is at
/// most 100.
#[test]
fn timesteps_anneal_at_their_exact_step() {
    let device = Backend::Flex.device();
    let mut config = tiny(crate_seed() % 1000 + 3);
    config.sds.timesteps.anneal_step = 3;
    config.sds.timesteps.t_max_annealed = 100;
    config.batch = 4;
    let mut method = Aag::new(config, &device).expect("assembles");
    let mut before = Vec::new();
    for step in 0..6 {
        let record = method.trainer.train_step().expect("a step");
        assert_eq!(record.t.len(), 4);
        assert!(
            record.t.iter().all(|&t| (20..=980).contains(&t)),
            "{:?}",
            record.t
        );
        if step < 3 {
            before.extend(record.t);
        } else {
            assert!(
                record.t.iter().all(|&t| t <= 100),
                "step {step}: {:?}",
                record.t
            );
        }
    }
    // 12 uniform draws on [20, 980] all at most 100: probability (81/961)^12 < 1e-12.
    assert!(before.iter().any(|&t| t > 100), "{before:?}");
}

/// The user's LPIPS weights (`lpips_weights`, loaded by the harness) reach the held-out scores:
/// a random small AlexNet written here gives a finite, positive LPIPS, and leaves PSNR and SSIM
/// as they are without it.
#[test]
fn lpips_weights_reach_the_held_out_scores() {
    use splatzoo_train::checkpoint::Checkpoint;
    use splatzoo_train::lpips::Lpips;
    let device = Backend::Flex.device();
    let mut rng = Rng(crate_seed() ^ 31);
    let mut file = Checkpoint::default();
    // torchvision AlexNet's conv indices and kernels, with few channels.
    let mut inputs = 3;
    for (index, outputs, kernel) in [(0, 8, 11), (3, 12, 5), (6, 16, 3), (8, 10, 3), (10, 10, 3)] {
        let n = outputs * inputs * kernel * kernel;
        let scale = (2.0 / (inputs * kernel * kernel) as f64).sqrt();
        let weight: Vec<f32> = (0..n).map(|_| (scale * rng.normal()) as f32).collect();
        file.put(
            &format!("features.{index}.weight"),
            &Tensor::<4>::from_data(
                TensorData::new(weight, [outputs, inputs, kernel, kernel]),
                &device,
            ),
        );
        file.put(
            &format!("features.{index}.bias"),
            &Tensor::<1>::from_data(TensorData::new(vec![0.01f32; outputs], [outputs]), &device),
        );
        inputs = outputs;
    }
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("alex.safetensors");
    file.write(&path).expect("written");
    let lpips = Lpips::load(&path, &device).expect("loaded");
    let config = AagConfig {
        data: PortraitConfig {
            eval_size: 64,
            ..tiny_portrait(16)
        },
        ..tiny(crate_seed() % 1000 + 5)
    };
    let mut method = Aag::new(config, &device).expect("assembles");
    method.trainer.train_step().expect("a step");
    let with = method.evaluate(Some(&lpips)).expect("scored").scores;
    let without = method.evaluate(None).expect("scored").scores;
    let value = with.lpips.expect("LPIPS with weights");
    assert!(value.is_finite() && value > 0.0, "{value}");
    assert_eq!(without.lpips, None);
    assert_eq!((with.psnr, with.ssim), (without.psnr, without.ssim));
}

/// The user's CLIP (`clip`: an image encoder as ONNX and the prompt's text embedding; here the
/// engine's random stand-in) scores the held-out views: the mean of the scorer over the same
/// renders, in [0, 100]; without it there is no CLIP score and the other scores are unchanged.
#[test]
fn a_user_clip_scores_the_held_out_views() {
    use splatzoo_aagaussian::trainer::render_views;
    use splatzoo_train::clip_score::fixture::write_tiny_clip;
    let device = Backend::Flex.device();
    let dir = tempfile::tempdir().expect("temp dir");
    let text: Vec<f32> = (0..6).map(|k| 0.2 + (k as f32).cos()).collect();
    let (toml, _) = write_tiny_clip(dir.path(), 24, &text, &device).expect("written");
    let base = AagConfig {
        data: PortraitConfig {
            eval_size: 32,
            ..tiny_portrait(16)
        },
        ..tiny(crate_seed() % 1000 + 7)
    };
    let mut method = Aag::new(
        AagConfig {
            clip: Some(toml),
            ..base.clone()
        },
        &device,
    )
    .expect("assembles");
    method.trainer.train_step().expect("a step");
    let with = method.trainer.evaluate(None).expect("scored");
    let clip = method.trainer.clip.as_ref().expect("loaded");
    let renders = render_views(
        &method.trainer.node.set.splats(),
        &method.trainer.capture.eval_cameras,
    )
    .expect("rendered");
    let mean = renders
        .iter()
        .map(|r| clip.score(r.color.clone().clamp(0.0, 1.0)).expect("scored"))
        .sum::<f64>()
        / renders.len() as f64;
    let value = with.clip_score.expect("a CLIP score");
    assert!((value - mean).abs() < 1e-9, "{value} against {mean}");
    assert!((0.0..=100.0).contains(&value));
    method.trainer.clip = None;
    let without = method.trainer.evaluate(None).expect("scored");
    assert_eq!(without.clip_score, None);
    assert_eq!(with.held_out, without.held_out);
    assert!(with.held_out.is_some());

    let missing = AagConfig {
        clip: Some(dir.path().join("absent.toml")),
        ..base
    };
    let error = Aag::new(missing, &device)
        .err()
        .expect("refused")
        .to_string();
    assert!(error.contains("absent.toml"), "{error}");
}
