//! The priors taken from the acting video (Fig. 5's ablations, the ExAvatar-like baseline):
//! the scene views keep the person out of the loss and out of the points, their floor masks and
//! points agree with the floor, the avatar's views see the camera-space body prior where the
//! person is, and a run with both swapped reaches stage D with finite losses.

use crate::data::tiny_capture;
use crate::trainer::into_stage_d;
use crate::{Rng, fresh_seed, values};
use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_models::body::builtin_body;
use splatzoo_prior_4d::Prior4d;
use splatzoo_prior_4d::scene_stage::without_person;
use splatzoo_prior_4d::sources::PriorSource;
use splatzoo_train::avatar::{project, track_joints};
use splatzoo_train::harness::Method;
use splatzoo_train::loss::photometric;

#[test]
fn scene_views_from_the_acting_video_leave_the_person_out() {
    let mut capture = tiny_capture();
    let scale = capture.truth.as_ref().unwrap().scale;
    let acting_points = capture.acting_points.len();
    assert!(acting_points > 100, "{acting_points} acting points");
    capture.scene_from_acting();
    assert_eq!(capture.scene_scan.len(), capture.acting.len());
    assert_eq!(capture.scene_points.len(), acting_points);
    let mut floor_heights = Vec::new();
    for (t, (view, frame)) in capture.scene_scan.iter().zip(&capture.acting).enumerate() {
        assert_eq!(view.camera.world_to_camera, frame.camera.world_to_camera);
        let person = values(view.person.clone().expect("a person mask"));
        assert!(person.iter().any(|&m| m > 0.5), "frame {t}: nobody masked");
        // No depth target and no floor on the person.
        let mono = values(view.mono_inverse_depth.clone());
        for (p, &m) in person.iter().enumerate() {
            if m > 0.5 {
                assert_eq!(mono[p], 0.0, "frame {t} pixel {p}: depth on the person");
            }
        }
        assert!(
            view.ground.area() > 100,
            "frame {t}: {} floor pixels",
            view.ground.area()
        );
        // The video's own points that land on its floor pixels lie on the floor (y = 0).
        let points: Vec<[f32; 3]> = capture
            .scene_points
            .positions
            .iter()
            .step_by(7)
            .copied()
            .collect();
        for (k, (u, v, z)) in project(&view.camera, &points).into_iter().enumerate() {
            let (w, h) = (view.ground.width as f32, view.ground.height as f32);
            if z > 0.0
                && (0.0..w).contains(&u)
                && (0.0..h).contains(&v)
                && view.ground.get(u as usize, v as usize)
            {
                floor_heights.push(f64::from(points[k][1]).abs() / scale);
            }
        }
    }
    floor_heights.sort_by(f64::total_cmp);
    assert!(
        floor_heights.len() > 50,
        "{} floor hits",
        floor_heights.len()
    );
    let median = floor_heights[floor_heights.len() / 2];
    assert!(median < 0.05, "floor points' median height {median} m");
}

/// Each frame in its own camera frame: the camera-space prior's pelvis projects inside the
/// person's mask box (a few pixels of slack for the prior's noise).
#[test]
fn avatar_views_from_the_acting_video_see_the_prior_on_the_person() {
    let mut capture = tiny_capture();
    capture.avatar_from_acting();
    assert_eq!(capture.human_scan.len(), capture.acting.len());
    assert_eq!(capture.scan_prior, capture.acting_prior);
    let model = &builtin_body().model;
    let joints = values(track_joints(model, &capture.scan_prior, &Device::flex()));
    let joint_count = joints.len() / (3 * capture.scan_prior.frames());
    for (t, view) in capture.human_scan.iter().enumerate() {
        let pelvis = &joints[3 * t * joint_count..3 * t * joint_count + 3];
        let [(u, v, z)] = project(&view.camera, &[[pelvis[0], pelvis[1], pelvis[2]]])[..] else {
            unreachable!("one point in, one out")
        };
        assert!(z > 0.0, "frame {t}: the pelvis is behind the camera");
        let mask = values(view.mask.clone());
        let w = view.camera.width as usize;
        let (mut lo, mut hi) = ([f32::MAX; 2], [f32::MIN; 2]);
        for (p, _) in mask.iter().enumerate().filter(|(_, m)| **m > 0.5) {
            let (x, y) = ((p % w) as f32, (p / w) as f32);
            lo = [lo[0].min(x), lo[1].min(y)];
            hi = [hi[0].max(x), hi[1].max(y)];
        }
        let slack = 4.0;
        assert!(
            u > lo[0] - slack && u < hi[0] + slack && v > lo[1] - slack && v < hi[1] + slack,
            "frame {t}: pelvis at ({u:.1}, {v:.1}), person in {lo:?}–{hi:?}"
        );
    }
}

/// The person's pixels carry neither loss nor gradient; elsewhere the render is unchanged.
#[test]
fn masked_person_pixels_carry_no_loss_and_no_gradient() {
    let seed = fresh_seed();
    let mut rng = Rng(seed);
    let device = Device::flex().autodiff();
    let (h, w) = (9, 11);
    let random = |rng: &mut Rng, n: usize| -> Vec<f32> {
        (0..n).map(|_| rng.range(0.0, 1.0) as f32).collect()
    };
    let image = random(&mut rng, h * w * 3);
    let render = random(&mut rng, h * w * 3);
    let person: Vec<f32> = (0..h * w)
        .map(|_| f32::from(u8::from(rng.range(0.0, 1.0) < 0.3)))
        .collect();
    let tensor3 =
        |v: &[f32]| Tensor::<3>::from_data(TensorData::new(v.to_vec(), [h, w, 3]), &device);
    let mask = Tensor::<2>::from_data(TensorData::new(person.clone(), [h, w]), &device);
    let r = tensor3(&render).require_grad();
    let composed = without_person(r.clone(), tensor3(&image), mask.clone());
    let loss = photometric(composed.clone(), tensor3(&image), 0.2);
    let grads = loss.backward();
    let grad = values(r.grad(&grads).expect("the render gets a gradient"));
    let out = values(composed.inner());
    for (p, &masked) in person.iter().enumerate() {
        for c in 0..3 {
            let i = 3 * p + c;
            if masked > 0.5 {
                assert_eq!(grad[i], 0.0, "seed {seed}: gradient on the person at {p}");
                assert_eq!(out[i], image[i], "seed {seed}: pixel {p}");
            } else {
                assert_eq!(out[i], render[i], "seed {seed}: pixel {p}");
            }
        }
    }
    assert!(
        grad.iter().any(|g| *g != 0.0),
        "seed {seed}: no gradient at all"
    );
}

#[test]
fn both_priors_from_the_acting_video_reach_stage_d() {
    let mut config = into_stage_d(12);
    config.scene.source = PriorSource::Acting;
    config.avatar.source = PriorSource::Acting;
    let device = Device::flex();
    let mut method = Prior4d::new(config.clone(), &device).expect("a tiny run");
    let frames = method.capture.acting.len();
    assert_eq!(method.scene.train.len() + method.scene.test.len(), frames);
    assert_eq!(method.avatar.train.len() + method.avatar.test.len(), frames);
    let decisions = method.decisions().join("\n");
    for source in ["scene.source = \"acting\"", "avatar.source = \"acting\""] {
        assert!(decisions.contains(source), "no `{source}` in:\n{decisions}");
    }
    while method.steps() < config.iterations {
        let report = method.step().expect("a step");
        assert!(
            report.loss.is_finite(),
            "step {}: {}",
            method.steps(),
            report.loss
        );
    }
    let scores = method.final_scores(None).expect("stage D's scores");
    assert!(scores.psnr.is_finite() && scores.sigma.is_finite());
    // The person-only PSNR is scored where the evaluation camera shows her.
    let human = scores
        .human_psnr
        .expect("the evaluation camera shows the person");
    assert!(
        human.is_finite() && human != scores.psnr,
        "{human} against {}",
        scores.psnr
    );
}
