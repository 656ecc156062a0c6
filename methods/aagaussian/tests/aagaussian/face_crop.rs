//! U8: the face crop cut from the portrait photo. The 2-D similarity is recovered exactly from
//! clean points and refused on degenerate ones; the resampling moves an image as the
//! similarity says; and the crop cut from the synthetic portrait by its noisy face keypoints
//! matches the face camera's own render of the identity where both see the face.

use crate::common::tiny_portrait;
use crate::sds::crate_seed;
use splatzoo_aagaussian::data::{FaceCropSource, PortraitCapture, PortraitConfig};
use splatzoo_aagaussian::face_align::{Similarity2, umeyama_2d, warp_crop};
use splatzoo_datasets::synth::rng::Rng;
use splatzoo_train::backend::Backend;

#[test]
fn the_similarity_is_recovered_and_degenerate_points_refused() {
    let mut rng = Rng(crate_seed() ^ 21);
    for _ in 0..20 {
        let truth = Similarity2 {
            scale: rng.range(0.2, 5.0),
            angle: rng.range(-3.0, 3.0),
            translation: [rng.range(-50.0, 50.0), rng.range(-50.0, 50.0)],
        };
        let n = 2 + rng.below(5);
        let src: Vec<[f64; 2]> = (0..n)
            .map(|_| [rng.range(0.0, 500.0), rng.range(0.0, 500.0)])
            .collect();
        let dst: Vec<[f64; 2]> = src.iter().map(|p| truth.apply(*p)).collect();
        let found = umeyama_2d(&src, &dst).expect("distinct points");
        assert!(
            (found.scale - truth.scale).abs() < 1e-9 * truth.scale,
            "{found:?} {truth:?}"
        );
        let turn = (found.angle - truth.angle).rem_euclid(std::f64::consts::TAU);
        assert!(
            turn.min(std::f64::consts::TAU - turn) < 1e-9,
            "{found:?} {truth:?}"
        );
        for p in &src {
            let (a, b) = (found.apply(*p), truth.apply(*p));
            assert!((a[0] - b[0]).abs() < 1e-6 && (a[1] - b[1]).abs() < 1e-6);
            let back = found.inverse().apply(a);
            assert!((back[0] - p[0]).abs() < 1e-6 && (back[1] - p[1]).abs() < 1e-6);
        }
    }
    let message = umeyama_2d(&[[3.0, 4.0]], &[[1.0, 1.0]])
        .expect_err("one point")
        .to_string();
    assert!(message.contains("two distinct face points"), "{message}");
    assert!(umeyama_2d(&[[3.0, 4.0]; 3], &[[1.0, 1.0], [2.0, 2.0], [0.0, 5.0]]).is_err());
    let message = umeyama_2d(&[[0.0, 0.0], [9.0, 1.0]], &[[5.0, 5.0]; 2])
        .expect_err("onto one point")
        .to_string();
    assert!(message.contains("map to one point"), "{message}");
}

/// A pure shift by whole pixels moves every pixel by that shift; the kept mask blacks the rest.
#[test]
fn the_crop_resamples_through_the_similarity() {
    let (w, h) = (9, 7);
    let image: Vec<f32> = (0..3 * w * h).map(|k| (k % 17) as f32 / 17.0).collect();
    let shift = Similarity2 {
        scale: 1.0,
        angle: 0.0,
        translation: [-2.0, -1.0],
    };
    let size = 5;
    let mut keep = vec![true; size * size];
    keep[3] = false;
    let crop = warp_crop(&image, w, h, &shift, size, &keep);
    for c in 0..3 {
        for row in 0..size {
            for col in 0..size {
                let got = crop[c * size * size + row * size + col];
                let want = if row * size + col == 3 {
                    0.0
                } else {
                    image[c * w * h + (row + 1) * w + col + 2]
                };
                assert!(
                    (got - want).abs() < 1e-6,
                    "({c}, {row}, {col}): {got} vs {want}"
                );
            }
        }
    }
}

/// PSNR of `b` to `a` (`[3, S, S]`) over `mask`.
pub fn masked_psnr(a: &[f32], b: &[f32], mask: &[bool]) -> f64 {
    let plane = mask.len();
    let (mut squared, mut count) = (0.0f64, 0usize);
    for (p, _) in mask.iter().enumerate().filter(|(_, on)| **on) {
        for c in 0..3 {
            squared += f64::from(a[c * plane + p] - b[c * plane + p]).powi(2);
            count += 1;
        }
    }
    -10.0 * (squared / count as f64).log10()
}

/// Halving the image: each crop pixel's centre lands where four image pixels meet, so it is
/// their mean (pixel centres at +0.5 on both sides; without them it would be one pixel).
#[test]
fn a_halved_crop_averages_four_pixels() {
    let (w, h) = (8, 6);
    let image: Vec<f32> = (0..3 * w * h)
        .map(|k| ((k * 7) % 23) as f32 / 23.0)
        .collect();
    let half = Similarity2 {
        scale: 0.5,
        angle: 0.0,
        translation: [0.0, 0.0],
    };
    let size = 3;
    let crop = warp_crop(&image, w, h, &half, size, &vec![true; size * size]);
    for c in 0..3 {
        for row in 0..size {
            for col in 0..size {
                let px = |x: usize, y: usize| image[c * w * h + y * w + x];
                let (x, y) = (2 * col, 2 * row);
                let want = 0.25 * (px(x, y) + px(x + 1, y) + px(x, y + 1) + px(x + 1, y + 1));
                let got = crop[c * size * size + row * size + col];
                assert!(
                    (got - want).abs() < 1e-6,
                    "({c}, {row}, {col}): {got} vs {want}"
                );
            }
        }
    }
}

/// The portrait-cut crop against the face camera's render over the face mask: the face points
/// meet within 3 crop pixels, and the crop agrees with the render better than the render does
/// with itself moved 2 pixels (the photo is 6× farther away, so its perspective and resolution
/// differ; measured: 1.41 px, 19.87 dB, against 20.52 / 18.91 dB for the render moved 1 / 2 px).
#[test]
fn the_portrait_crop_matches_the_face_cameras_render() {
    let device = Backend::Flex.device();
    let config = |face_crop| PortraitConfig {
        face_crop,
        ..tiny_portrait(64)
    };
    let rendered =
        PortraitCapture::build(&config(FaceCropSource::Render), &device).expect("render");
    let cut = PortraitCapture::build(&config(FaceCropSource::Portrait), &device).expect("portrait");
    assert_eq!(rendered.face_alignment, None);
    let (residual, points) = cut.face_alignment.expect("aligned");
    assert_eq!(points, 5);
    let mask = &rendered.face_mask;
    let psnr = masked_psnr(&rendered.face_crop, &cut.face_crop, mask);
    let moved = warp_crop(
        &rendered.face_crop,
        64,
        64,
        &Similarity2 {
            scale: 1.0,
            angle: 0.0,
            translation: [2.0, 0.0],
        },
        64,
        &vec![true; 64 * 64],
    );
    let two_pixels = masked_psnr(&rendered.face_crop, &moved, mask);
    eprintln!(
        "portrait crop: residual {residual:.2} px, face PSNR to the render {psnr:.2} dB \
         (the render moved 2 px: {two_pixels:.2} dB)"
    );
    assert!(residual < 3.0, "residual {residual} px");
    assert!(
        psnr > two_pixels,
        "{psnr} dB, the render moved 2 px {two_pixels} dB"
    );
    assert_ne!(
        rendered.face_crop, cut.face_crop,
        "it is not the render itself"
    );
}
