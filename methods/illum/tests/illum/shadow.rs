//! Eq. 8–9's scene shadows (spec §8 checks 4 and 14): ao is exactly 1 outside the human's box
//! and `sigmoid(4)` inside at first; `ao·colour` blackens, keeps and halves; the SH edit renders
//! the same colour (and naive `ao·SH` fades to grey); only in-box rows change; an empty box and
//! a Gaussian at the box centre are fine; gradients reach the decoder and the latents around
//! in-box Gaussians only; the decoder's inputs match their f64 reference.

use crate::{Rng, fresh_seed, values};
use burn::module::{Module, ModuleVisitor, Param};
use burn::tensor::{Device, Gradients, Int, Tensor, TensorData};
use splatzoo_illum::light_volume::{LightVolume, ProbeGrid};
use splatzoo_illum::shadow::{
    INITIAL_LOGIT, ShadowBox, ShadowDecoder, decoder_inputs, decoder_inputs_reference,
    scene_occlusion, sh_equivalent, sh_equivalent_reference, shadowed_colour,
};
use splatzoo_rasterizer::sh::{coeff_count, sh_colour};

fn tensor2(v: &[f64], shape: [usize; 2], device: &Device) -> Tensor<2> {
    let data: Vec<f32> = v.iter().map(|&x| x as f32).collect();
    Tensor::from_data(TensorData::new(data, shape), device)
}

fn tensor1(v: &[f64], device: &Device) -> Tensor<1> {
    let data: Vec<f32> = v.iter().map(|&x| x as f32).collect();
    Tensor::from_data(TensorData::new(data, [v.len()]), device)
}

/// A standing "human": 300 points in a 0.5 × 1.7 × 0.3 box (y up) somewhere near the origin.
fn human(rng: &mut Rng) -> Vec<[f64; 3]> {
    let base = [rng.range(-1.0, 1.0), 0.0, rng.range(-1.0, 1.0)];
    (0..300)
        .map(|_| {
            [
                base[0] + rng.range(-0.25, 0.25),
                base[1] + rng.range(0.0, 1.7),
                base[2] + rng.range(-0.15, 0.15),
            ]
        })
        .collect()
}

/// The box around a random human, its light volume (spec grid) and a fresh decoder.
fn setup(rng: &mut Rng, device: &Device) -> (ShadowBox, LightVolume, ShadowDecoder) {
    let shadow_box = ShadowBox::around(&human(rng), 1, 0.5).expect("a box");
    let (min, max) = shadow_box.bounds();
    let h = shadow_box.height;
    let grid = ProbeGrid::covering(min, max, 0.3 * h, 0.15 * h, 32).expect("a grid");
    let volume = LightVolume::new(grid, 2, 16, rng.next_u64(), device).expect("a volume");
    (shadow_box, volume, ShadowDecoder::new(16, device))
}

/// `m` scene positions, flat `[m, 3]`: even rows inside the box, odd rows outside it.
fn scene(shadow_box: &ShadowBox, m: usize, rng: &mut Rng) -> Vec<f64> {
    let (c, e) = (shadow_box.centre, shadow_box.half_extent);
    (0..m)
        .flat_map(|i| {
            let mut p = [0, 1, 2].map(|a| c[a] + rng.range(-0.99, 0.99) * e[a]);
            if i % 2 == 1 {
                let a = (rng.next_u64() % 3) as usize;
                let side = if rng.next_u64().is_multiple_of(2) {
                    1.0
                } else {
                    -1.0
                };
                p[a] = c[a] + side * e[a] * rng.range(1.01, 3.0);
            }
            p
        })
        .collect()
}

/// ao ≡ 1 exactly outside the box and `sigmoid(4) ≈ 0.982` inside at initialisation, so
/// shadowed colours change on in-box rows only.
#[test]
fn ao_is_one_outside_the_box_and_sigmoid_four_inside() {
    let seed = fresh_seed();
    let mut rng = Rng(seed);
    let device = Device::flex();
    let (shadow_box, volume, decoder) = setup(&mut rng, &device);
    let m = 200;
    let positions = tensor2(&scene(&shadow_box, m, &mut rng), [m, 3], &device);
    let inside = shadow_box.inside(&positions);
    assert!((0..m).all(|i| inside[i] == (i % 2 == 0)), "seed {seed}");
    let ao = scene_occlusion(&decoder, &volume, &shadow_box, positions);
    let colours: Vec<f64> = (0..m * 3).map(|_| rng.range(0.0, 1.0)).collect();
    let colour = tensor2(&colours, [m, 3], &device);
    let shadowed = values(shadowed_colour(colour.clone(), ao.clone()));
    let (ao, colour) = (values(ao), values(colour));
    let initial = 1.0 / (1.0 + (-INITIAL_LOGIT).exp());
    for i in 0..m {
        let row = i * 3..i * 3 + 3;
        if inside[i] {
            assert!(
                (f64::from(ao[i]) - initial).abs() < 1e-3,
                "seed {seed}: {}",
                ao[i]
            );
            assert_ne!(shadowed[row.clone()], colour[row], "seed {seed}");
        } else {
            assert_eq!(ao[i], 1.0, "seed {seed}: row {i}");
            assert_eq!(shadowed[row.clone()], colour[row], "seed {seed}");
        }
    }
}

/// `ao = 0` gives black, 1 the identity, 0.5 half the colour; any ao scales its row.
#[test]
fn shadowed_colour_blackens_keeps_and_halves() {
    const M: usize = 40;
    let seed = fresh_seed();
    let mut rng = Rng(seed);
    let device = Device::flex();
    let colours: Vec<f64> = (0..M * 3).map(|_| rng.range(0.0, 1.5)).collect();
    let colour = tensor2(&colours, [M, 3], &device);
    let with = |ao: &[f64]| values(shadowed_colour(colour.clone(), tensor1(ao, &device)));
    let plain = values(colour.clone());
    assert!(with(&[0.0; M]).iter().all(|&v| v == 0.0));
    assert_eq!(with(&[1.0; M]), plain);
    let halves: Vec<f32> = plain.iter().map(|v| v * 0.5).collect();
    assert_eq!(with(&[0.5; M]), halves);
    let ao: Vec<f64> = (0..M).map(|_| rng.range(0.0, 1.0)).collect();
    for (i, v) in with(&ao).iter().enumerate() {
        let want = ao[i / 3] * f64::from(plain[i]);
        assert!((f64::from(*v) - want).abs() < 1e-6, "seed {seed}");
    }
}

/// The SH edit renders `ao · max(SH(d) + 0.5, 0)` in every direction (clamped colours
/// included), matches its f64 reference, and differs from naive `ao·SH`, which fades a full
/// shadow to grey 0.5.
#[test]
fn the_sh_edit_renders_the_shadowed_colour() {
    let seed = fresh_seed();
    let mut rng = Rng(seed);
    let device = Device::flex();
    let (m, degree) = (60, 3);
    let k = coeff_count(degree);
    let coefficients: Vec<f64> = (0..m * k * 3).map(|_| 0.6 * rng.gauss()).collect();
    let sh = tensor2(&coefficients, [m, k * 3], &device).reshape([m, k, 3]);
    let directions: Vec<f64> = (0..m * 3).map(|_| rng.gauss()).collect();
    let directions = tensor2(&directions, [m, 3], &device);
    let mut ao: Vec<f64> = (0..m).map(|_| rng.range(0.0, 1.0)).collect();
    (ao[0], ao[1]) = (0.0, 1.0);
    let ao_t = tensor1(&ao, &device);
    let colour = sh_colour(sh.clone(), directions.clone(), degree);
    let want = values(shadowed_colour(colour, ao_t.clone()));
    let edited = sh_equivalent(sh.clone(), ao_t);
    let got = values(sh_colour(edited.clone(), directions.clone(), degree));
    for (g, w) in got.iter().zip(&want) {
        assert!((g - w).abs() < 1e-5, "seed {seed}: {g} vs {w}");
    }
    let edited = values(edited);
    for i in 0..m {
        let row = &coefficients[i * k * 3..(i + 1) * k * 3];
        let row: Vec<f64> = row.iter().map(|&v| v as f32 as f64).collect();
        for (j, r) in sh_equivalent_reference(&row, 3, ao[i]).iter().enumerate() {
            let g = f64::from(edited[i * k * 3 + j]);
            assert!((g - r).abs() < 1e-5 * (1.0 + r.abs()), "seed {seed}");
        }
    }
    // Naive Eq. 9 at ao = 0: every coefficient zero, colour 0.5 grey, not black.
    let naive = values(sh_colour(sh * 0.0, directions, degree));
    assert!(naive.iter().all(|&v| v == 0.5));
}

/// A box that holds no scene Gaussian gives all ones, without evaluating anything.
#[test]
fn an_empty_box_gives_all_ones() {
    let seed = fresh_seed();
    let mut rng = Rng(seed);
    let device = Device::flex();
    let (shadow_box, volume, decoder) = setup(&mut rng, &device);
    let m = 50;
    let far: Vec<f64> = (0..m * 3).map(|_| rng.range(20.0, 40.0)).collect();
    let ao = scene_occlusion(
        &decoder,
        &volume,
        &shadow_box,
        tensor2(&far, [m, 3], &device),
    );
    assert_eq!(values(ao), vec![1.0; m], "seed {seed}");
}

/// Counts parameters whose gradient is present, finite and not all zero.
struct Reached<'a> {
    grads: &'a Gradients,
    with: usize,
    without: usize,
}

impl ModuleVisitor for Reached<'_> {
    fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
        let g = param.val().grad(self.grads).map(values).unwrap_or_default();
        if g.iter().all(|v| v.is_finite()) && g.iter().any(|&v| v != 0.0) {
            self.with += 1;
        } else {
            self.without += 1;
        }
    }
}

/// A loss on ao reaches every decoder parameter and the latents of exactly the probes around
/// in-box Gaussians (not the SH); a Gaussian at the box centre keeps values and gradients
/// finite.
#[test]
fn gradients_reach_the_decoder_and_the_in_box_latents_only() {
    let seed = fresh_seed();
    let mut rng = Rng(seed);
    let device = Device::flex().autodiff();
    let (shadow_box, volume, decoder) = setup(&mut rng, &device);
    let m = 80;
    let mut flat = scene(&shadow_box, m, &mut rng);
    flat[..3].copy_from_slice(&shadow_box.centre.map(|v| v as f32 as f64));
    let positions = tensor2(&flat, [m, 3], &device);
    let inside = shadow_box.inside(&positions);
    let ao = scene_occlusion(&decoder, &volume, &shadow_box, positions.clone());
    assert!(
        values(ao.clone())
            .iter()
            .all(|v| v.is_finite() && *v > 0.0 && *v <= 1.0)
    );
    let upstream: Vec<f64> = (0..m).map(|_| rng.range(0.5, 1.5)).collect();
    let grads = (ao * tensor1(&upstream, &device)).sum().backward();
    let mut reached = Reached {
        grads: &grads,
        with: 0,
        without: 0,
    };
    decoder.visit(&mut reached);
    assert_eq!((reached.with, reached.without), (8, 0), "seed {seed}");
    // The probes at the corners of in-box Gaussians' cells.
    let rows: Vec<i64> = (0..m).filter(|&i| inside[i]).map(|i| i as i64).collect();
    let count = rows.len();
    let rows = Tensor::<1, Int>::from_data(TensorData::new(rows, [count]), &device);
    let (corners, _) = volume.grid().corner_weights(positions.select(0, rows));
    let corners: Vec<i64> = corners.into_data().convert::<i64>().try_into_vec().unwrap();
    let g = values(
        volume
            .latent
            .val()
            .grad(&grads)
            .expect("latents are reached"),
    );
    let dz = volume.latent_dim();
    for probe in 0..volume.grid().count() {
        let row = &g[probe * dz..(probe + 1) * dz];
        assert!(row.iter().all(|v| v.is_finite()), "seed {seed}");
        if !corners.contains(&(probe as i64)) {
            assert!(row.iter().all(|&v| v == 0.0), "seed {seed}: probe {probe}");
        }
    }
    assert!(g.iter().any(|&v| v != 0.0), "seed {seed}");
    let sh = volume.sh.val().grad(&grads).map(values).unwrap_or_default();
    assert!(
        sh.iter().all(|&v| v == 0.0),
        "seed {seed}: the SH got a gradient"
    );
}

/// The decoder's input rows equal the f64 reference, at the box centre (r = 0) too.
#[test]
fn decoder_inputs_match_the_reference() {
    let seed = fresh_seed();
    let mut rng = Rng(seed);
    let device = Device::flex();
    let mut shadow_box = ShadowBox::around(&human(&mut rng), 1, 0.5).expect("a box");
    // A centre exact in f32, so the point placed on it is at distance 0 in both.
    shadow_box.centre = shadow_box.centre.map(|v| v as f32 as f64);
    let (r, dz) = (30, 16);
    let mut points = scene(&shadow_box, r, &mut rng);
    points[..3].copy_from_slice(&shadow_box.centre);
    let latent: Vec<f64> = (0..r * dz).map(|_| rng.gauss() as f32 as f64).collect();
    let rows = decoder_inputs(
        &shadow_box,
        tensor2(&points, [r, 3], &device),
        tensor2(&latent, [r, dz], &device),
    );
    let width = ShadowDecoder::input_width(dz);
    assert_eq!(rows.dims(), [r, width]);
    let rows = values(rows);
    for i in 0..r {
        let point = [0, 1, 2].map(|a| points[3 * i + a] as f32 as f64);
        let want = decoder_inputs_reference(&shadow_box, point, &latent[i * dz..(i + 1) * dz]);
        for (j, w) in want.iter().enumerate() {
            let g = f64::from(rows[i * width + j]);
            assert!(
                (g - w).abs() < 2e-4,
                "seed {seed}: row {i} col {j}: {g} vs {w}"
            );
        }
    }
}

/// The box is the human's AABB padded by a fraction of its height along the chosen up axis;
/// bad input is named.
#[test]
fn the_box_pads_the_human_by_a_fraction_of_its_height() {
    let points = [[0.0, 0.0, 0.0], [1.0, 2.0, 0.5], [0.2, 1.0, 0.1]];
    let b = ShadowBox::around(&points, 1, 0.5).unwrap();
    assert_eq!(b.height, 2.0);
    assert_eq!(b.centre, [0.5, 1.0, 0.25]);
    assert_eq!(b.half_extent, [1.5, 2.0, 1.25]);
    let (min, max) = b.bounds();
    assert!(b.contains(min) && b.contains(max) && b.contains(b.centre));
    assert!(!b.contains([max[0] + 1e-9, 1.0, 0.0]));
    assert_eq!(ShadowBox::around(&points, 2, 0.5).unwrap().height, 0.5);
    let error =
        |r: Result<ShadowBox, splatzoo_illum::IllumError>| r.expect_err("bad input").to_string();
    assert!(error(ShadowBox::around(&[], 1, 0.5)).contains("no human points"));
    assert!(error(ShadowBox::around(&[[f64::NAN, 0.0, 0.0]], 1, 0.5)).contains("not finite"));
    assert!(error(ShadowBox::around(&points, 3, 0.5)).contains("up axis"));
    assert!(error(ShadowBox::around(&points, 1, -0.1)).contains("padding"));
    let flat = [[0.0, 1.0, 0.0], [1.0, 1.0, 1.0]];
    assert!(error(ShadowBox::around(&flat, 1, 0.5)).contains("no extent"));
}
