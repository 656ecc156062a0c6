//! Extremes (spec §8): σ → 0 and σ huge, feet far below the floor, a ground cloud with no
//! plane in it — finite values or a clear error, never a panic or a NaN; and the whole
//! pipeline into stage D under extreme captures, through the engine's shared check.

use crate::{Rng, fresh_seed, values};
use burn::tensor::{Device, Tensor};
use splatzoo_prior_4d::Prior4d;
use splatzoo_prior_4d::camera::{RigidFrame, splats_in_frame};
use splatzoo_prior_4d::config::Prior4dConfig;
use splatzoo_prior_4d::contact::{ContactConfig, contact_loss};
use splatzoo_prior_4d::locate::place;
use splatzoo_prior_4d::plane::{Plane, RansacConfig, ransac_plane};
use splatzoo_prior_4d::render::{AvatarSplats, render_layers};
use splatzoo_rasterizer::ColorMode;
use splatzoo_rasterizer::testing::{SceneSpec, random_scene};
use splatzoo_train::harness::extremes::{StepOutcome, after_steps, assert_stable};

/// The avatar placed at σ = e^s for s from −30 to +30 renders a finite image with finite
/// gradients on s, and the contact loss stays finite (feet kilometres below or at the origin).
#[test]
fn extreme_global_scales_stay_finite() {
    let seed = fresh_seed();
    let device = Device::flex().autodiff();
    let (host, settings) = random_scene(
        seed,
        &SceneSpec::new(200, 48, 36, ColorMode::Sh { degree: 0 }),
    );
    let (world, _) = host.tensors(&device);
    let acting = RigidFrame::of_camera(&settings.camera, &device);
    let camera_space = splats_in_frame(&world, &acting);
    let floor = Plane::new([0.0, 1.0, 0.0], 0.0).unwrap();
    for s in [-30.0f32, -8.0, 0.0, 8.0, 30.0] {
        let log_sigma = Tensor::<1>::from_floats([s], &device).require_grad();
        let placed = place(camera_space.clone(), log_sigma.clone(), &acting);
        let n = placed.len();
        let avatar = AvatarSplats {
            splats: placed.clone(),
            normals: Tensor::zeros([n, 3], &device),
        };
        let layers = render_layers(None, Some(&avatar), &acting, &settings, [0.2; 3]).unwrap();
        let image = values(layers.color.clone());
        assert!(
            image.iter().all(|v| v.is_finite()),
            "seed {seed}, s {s}: image"
        );
        let sigma = f64::from(s).exp();
        let contact = contact_loss(placed.means, &floor, &ContactConfig::default(), sigma);
        let loss = match contact {
            Ok(term) => {
                let v = values(term.loss.clone())[0];
                assert!(v.is_finite(), "seed {seed}, s {s}: contact {v}");
                term.loss + layers.color.mean()
            }
            // A clear error is acceptable; it must name the foot vertex.
            Err(e) => {
                assert!(e.to_string().contains("foot vertex"), "{e}");
                layers.color.mean()
            }
        };
        let grads = loss.backward();
        let g = values(log_sigma.grad(&grads).expect("s is reached"));
        assert!(g[0].is_finite(), "seed {seed}, s {s}: dL/ds = {}", g[0]);
    }
}

/// RANSAC on a cloud with no plane (every point an outlier of every other's plane) returns a
/// fit or a clear error, never a panic; a NaN anywhere is named.
#[test]
fn ransac_without_a_floor_does_not_panic() {
    let seed = fresh_seed();
    let mut rng = Rng(seed);
    let cloud: Vec<[f64; 3]> = (0..300)
        .map(|_| {
            [
                rng.range(-5.0, 5.0),
                rng.range(-5.0, 5.0),
                rng.range(-5.0, 5.0),
            ]
        })
        .collect();
    let config = RansacConfig {
        threshold: 1e-6,
        ..RansacConfig::default()
    };
    match ransac_plane(&cloud, &config) {
        Ok(fit) => assert!(fit.plane.normal.iter().all(|v| v.is_finite())),
        Err(e) => assert!(e.to_string().contains("ground points"), "{e}"),
    }
    let mut bad = cloud.clone();
    bad[17][1] = f64::NAN;
    let err = ransac_plane(&bad, &RansacConfig::default()).unwrap_err();
    assert!(err.to_string().contains("17"), "{err}");
}

/// Two scene steps, two avatar steps and the first joint step (stage C's body fit, plane and
/// σ₀ in between) of the tiny capture, with `change` applied.
fn through_stage_d(what: &str, change: impl FnOnce(&mut Prior4dConfig)) -> StepOutcome {
    let mut config = crate::trainer::into_stage_d(6);
    change(&mut config);
    assert_stable(what, after_steps::<Prior4d>(config, &Device::flex(), 5))
}

/// The whole pipeline into stage D at the extremes: a scene in units 1e-3 and 1e3 times the
/// body's (σ* at both ends), the body-model fit off by about π on every joint, one acting
/// frame, a 1×1 image, a zero-opacity avatar. Each is a finite step with finite state
/// (cameras, poses, σ, offsets, optimiser moments) or a refusal by name.
#[test]
fn the_pipeline_reaches_stage_d_at_the_extremes_or_refuses_by_name() {
    for scale in [1e-3, 1e3] {
        let outcome = through_stage_d("σ* at the ends", |c| c.data.scene_scale = scale);
        assert!(
            matches!(outcome, StepOutcome::Finite { .. }),
            "σ* = {scale}: {outcome:?}"
        );
    }
    through_stage_d("body fit off by ~π", |c| {
        c.data.noise.pose_bias = std::f64::consts::PI;
        c.data.noise.pose_noise = std::f64::consts::PI;
    });
    through_stage_d("one acting frame", |c| c.data.acting_frames = 1);
    let pixel = through_stage_d("1×1 image", |c| {
        c.data.width = 1;
        c.data.height = 1;
    });
    if let StepOutcome::Refused(message) = pixel {
        assert!(message.contains("width"), "{message}");
    }
    let clear = through_stage_d("zero opacity", |c| c.avatar.node.initial_opacity = 0.0);
    if let StepOutcome::Refused(message) = clear {
        assert!(message.contains("initial_opacity"), "{message}");
    }
}
