//! A user's own portrait (`data.photo`): a PNG and its OpenPose JSON written from a synthetic
//! identity (`synthetic_photo`: photographed by the CPU mesh renderer in a pose that is not the
//! canonical one, its body, face and hand keypoints projected from the true mesh with pixel
//! noise) and read back as a user's would be: the body fitted without a floor, the face crop cut
//! from the photo, no truth. The trainer refuses to run without a guidance model and steps with
//! one; the animation runs without an identity to score against; bad files are named.

use crate::common::tiny_portrait;
use crate::face_crop::masked_psnr;
use crate::onnx::{prompts, write_model};
use crate::sds::crate_seed;
use splatzoo_aagaussian::Aag;
use splatzoo_aagaussian::animate::{AnimationConfig, animate, builtin_motion};
use splatzoo_aagaussian::config::AagConfig;
use splatzoo_aagaussian::data::{PortraitCapture, PortraitConfig};
use splatzoo_aagaussian::synthetic_photo::write_synthetic_photo;
use splatzoo_aagaussian::tiny_unet::TinyDenoiser;
use splatzoo_datasets::openpose::write_keypoints;
use splatzoo_datasets::synth::rng::Rng;
use splatzoo_datasets::synth::scene::posed_once;
use splatzoo_train::backend::Backend;
use std::path::{Path, PathBuf};

/// Side of the photo.
const PHOTO: u32 = 512;
/// Side of the face crop.
const FACE: u32 = 64;

/// The reference capture: the prompted identity's true shape, the face crop rendered from the
/// face camera.
fn reference() -> PortraitCapture {
    PortraitCapture::build(&tiny_portrait(FACE), &Backend::Flex.device()).expect("a capture")
}

/// The reference's prompted identity as a user's photo, its keypoints with `noise_px` of noise.
fn write_photo(capture: &PortraitCapture, dir: &Path, noise_px: f64) -> PathBuf {
    write_synthetic_photo(
        capture,
        dir,
        PHOTO,
        noise_px,
        crate_seed() ^ 0x9407,
        &Backend::Flex.device(),
    )
    .expect("written")
}

fn photo_config(photo: PathBuf) -> PortraitConfig {
    PortraitConfig {
        photo: Some(photo),
        body_fit: true,
        ..tiny_portrait(FACE)
    }
}

/// The photo becomes the body prior and the face crop: the fit reprojects within 3 px, its rest
/// height lies within 10 % of the truth's (a single photo fixes proportions, not size), and the
/// crop cut from the photo agrees with the face camera's render of the identity on its true
/// shape better than that render does with itself moved 2 px.
#[test]
fn a_users_photo_gives_the_body_prior_and_the_face_crop() {
    let device = Backend::Flex.device();
    let reference = reference();
    let dir = tempfile::tempdir().expect("temp dir");
    let photo = write_photo(&reference, dir.path(), 1.0);
    let capture = PortraitCapture::build(&photo_config(photo), &device).expect("from the photo");
    assert!(capture.truth.is_none());
    let fit = capture.body_fit.as_ref().expect("fitted");
    assert_eq!((fit.mpjpe_m, fit.height_error), (None, None));
    let bank = &reference.truth.as_ref().expect("synthetic").bank;
    let truth_betas = &bank.identities[reference.config.prompt].identity.betas;
    let true_height = {
        let rest = posed_once(truth_betas, &[0.0; 72], &device);
        let ys = rest.vertices.iter().map(|v| f64::from(v[1]));
        ys.clone().fold(f64::NEG_INFINITY, f64::max) - ys.fold(f64::INFINITY, f64::min)
    };
    let height_error = fit.rest_height_m / true_height - 1.0;
    let (residual, points) = capture.face_alignment.expect("cut from the photo");
    let mask: Vec<bool> = capture
        .face_mask
        .iter()
        .zip(&reference.face_mask)
        .map(|(a, b)| *a && *b)
        .collect();
    let psnr = masked_psnr(&reference.face_crop, &capture.face_crop, &mask);
    let moved = splatzoo_aagaussian::face_align::warp_crop(
        &reference.face_crop,
        FACE as usize,
        FACE as usize,
        &splatzoo_aagaussian::face_align::Similarity2 {
            scale: 1.0,
            angle: 0.0,
            translation: [2.0, 0.0],
        },
        FACE as usize,
        &vec![true; (FACE * FACE) as usize],
    );
    let two_pixels = masked_psnr(&reference.face_crop, &moved, &mask);
    eprintln!(
        "photo: reprojection {:.2} px, rest height {:.3} m against {true_height:.3} m \
         ({:+.1} %); crop from {points} face points, residual {residual:.2} px, face PSNR to the \
         render {psnr:.2} dB (the render moved 2 px: {two_pixels:.2} dB)",
        fit.reprojection_rms_px,
        fit.rest_height_m,
        100.0 * height_error
    );
    assert!(fit.reprojection_rms_px < 3.0, "{fit:?}");
    assert!(height_error.abs() < 0.10, "{height_error}");
    assert_eq!(points, 5);
    assert!(residual < 3.0, "{residual} px");
    assert!(psnr > two_pixels, "{psnr} dB against {two_pixels} dB");
}

/// Without a guidance model a photo is refused (the oracle knows only the synthetic
/// identities); with one the trainer steps, the scores have no held-out part, and the avatar
/// animates with nothing to score it against.
#[test]
fn a_photo_trains_with_a_guidance_model_and_has_no_held_out_truth() {
    let device = Backend::Flex.device();
    let reference = reference();
    let dir = tempfile::tempdir().expect("temp dir");
    let photo = write_photo(&reference, dir.path(), 1.0);
    let base = AagConfig {
        gaussians: 400,
        batch: 2,
        render_size: 8,
        data: photo_config(photo),
        ..AagConfig::default()
    };
    let message = Aag::assemble(base.clone(), &device)
        .err()
        .expect("no guidance model")
        .to_string();
    assert!(
        message.contains("data.photo") && message.contains("guidance model"),
        "{message}"
    );
    let mut rng = Rng(crate_seed() ^ 0x9408);
    let toml = write_model(
        &TinyDenoiser::new(4, crate::onnx::CHANNELS, &device),
        &prompts(&mut rng),
        dir.path(),
    );
    let mut method = Aag::assemble(
        AagConfig {
            guidance_model: Some(toml),
            ..base
        },
        &device,
    )
    .expect("assembles");
    for _ in 0..2 {
        let record = method.trainer.train_step().expect("a step");
        assert!(record.loss.is_finite(), "{record:?}");
    }
    let scores = method.trainer.evaluate(None).expect("scored");
    assert!(scores.held_out.is_none());
    assert!(scores.face_psnr.is_finite() && scores.face_ssim.is_finite());
    let json = serde_json::to_value(&scores).expect("plain data");
    assert!(json.get("psnr").is_none() && json.get("face_psnr").is_some());
    let motion = builtin_motion(3, 6.0);
    let animation = animate(
        &method.trainer.node.set,
        &method.trainer.capture,
        &motion,
        &AnimationConfig {
            size: 16,
            azimuths: vec![0.0],
            ..AnimationConfig::default()
        },
        None,
    )
    .expect("animated");
    assert_eq!(animation.frames, 3);
    assert!(animation.identity.is_none());
}

/// A missing keypoint file, a keypoint file without face points, a file that is not an image
/// and keypoints without a photo are each refused, naming the file or key.
#[test]
fn bad_photo_inputs_are_named() {
    let device = Backend::Flex.device();
    let reference = reference();
    let dir = tempfile::tempdir().expect("temp dir");
    let photo = write_photo(&reference, dir.path(), 0.0);
    let keypoints = dir.path().join("portrait_keypoints.json");
    let error = |config: &PortraitConfig| {
        PortraitCapture::build(config, &device)
            .expect_err("refused")
            .to_string()
    };

    let elsewhere = dir.path().join("elsewhere.json");
    let message = error(&PortraitConfig {
        photo_keypoints: Some(elsewhere),
        ..photo_config(photo.clone())
    });
    assert!(
        message.contains("data.photo_keypoints") && message.contains("elsewhere.json"),
        "{message}"
    );

    let faceless = dir.path().join("faceless.json");
    let mut person = splatzoo_datasets::openpose::read_main_person(&keypoints)
        .expect("read")
        .expect("a person");
    person.face.clear();
    write_keypoints(&faceless, &person).expect("written");
    let message = error(&PortraitConfig {
        photo_keypoints: Some(faceless),
        ..photo_config(photo.clone())
    });
    assert!(
        message.contains("faceless.json") && message.contains("face_keypoints_2d"),
        "{message}"
    );

    let broken = dir.path().join("broken.png");
    std::fs::write(&broken, b"not a picture").expect("written");
    let message = error(&PortraitConfig {
        photo_keypoints: Some(keypoints.clone()),
        ..photo_config(broken)
    });
    assert!(
        message.contains("broken.png") && message.contains("cannot read"),
        "{message}"
    );

    let message = error(&PortraitConfig {
        photo_keypoints: Some(keypoints),
        ..tiny_portrait(FACE)
    });
    assert!(message.contains("photo_keypoints"), "{message}");
}
