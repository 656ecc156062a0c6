//! Eq. 11 and Eq. 12's smoothness terms (spec §8 check 9; Eq. 13's probe term is tested with
//! the light volume): zero on constant fields, hand-computed values on a 4×4 map and on three
//! Gaussians, a cheaper material step where the image has an edge, and Burn equal to the f64
//! references on random inputs, 1-pixel-wide images included.

use crate::{Rng, fresh_seed, values};
use burn::tensor::{Device, Int, Tensor, TensorData};
use splatzoo_illum::smoothness::{
    materials_smoothness, materials_smoothness_reference, shadow_smoothness,
    shadow_smoothness_reference,
};

fn tensor<const D: usize>(v: &[f64], shape: [usize; D], device: &Device) -> Tensor<D> {
    let data: Vec<f32> = v.iter().map(|&x| x as f32).collect();
    Tensor::from_data(TensorData::new(data, shape), device)
}

fn neighbour_tensor(v: &[usize], [m, k]: [usize; 2], device: &Device) -> Tensor<2, Int> {
    let data: Vec<i64> = v.iter().map(|&j| j as i64).collect();
    Tensor::from_data(TensorData::new(data, [m, k]), device)
}

/// Eq. 11 on `[h, w, c]` maps, an `[h, w, 3]` image and an `[h, w]` mask, as f64.
fn materials(maps: &[f64], image: &[f64], mask: &[f64], shape: [usize; 3]) -> f64 {
    let device = Device::flex();
    let [h, w, _] = shape;
    let loss = materials_smoothness(
        tensor(maps, shape, &device),
        tensor(image, [h, w, 3], &device),
        tensor(mask, [h, w], &device),
    );
    f64::from(values(loss)[0])
}

/// A one-channel 4×4 map whose two right columns are 1 and the rest 0.
fn step_map() -> Vec<f64> {
    (0..16)
        .map(|i| if i % 4 >= 2 { 1.0 } else { 0.0 })
        .collect()
}

/// A 4×4 image, grey except that columns ≥ `column` are brighter by (1, 0.5, 0): a mean
/// |∂C| of 0.5 between columns `column − 1` and `column`.
fn edge_image(column: usize) -> Vec<f64> {
    (0..16)
        .flat_map(|i| {
            if i % 4 >= column {
                [1.2, 0.7, 0.2]
            } else {
                [0.2; 3]
            }
        })
        .collect()
}

#[test]
fn materials_smoothness_is_zero_on_constant_maps() {
    let seed = fresh_seed();
    let mut rng = Rng(seed);
    let (h, w, c) = (5, 6, 2);
    let constant: Vec<f64> = (0..c).map(|_| rng.range(0.0, 1.0)).collect();
    let maps: Vec<f64> = (0..h * w).flat_map(|_| constant.clone()).collect();
    let image: Vec<f64> = (0..h * w * 3).map(|_| rng.range(0.0, 1.0)).collect();
    let loss = materials(&maps, &image, &[1.0; 30], [h, w, c]);
    assert_eq!(loss, 0.0, "seed {seed}");
}

/// By hand: the step costs 4 unit x-differences out of 4·3 (1/3) under a flat image. With the
/// bottom row masked out, 3 x-steps of 12 remain, and the masked row adds 2 unit y-steps out
/// of 3·4: 1/4 + 1/6 = 5/12.
#[test]
fn materials_smoothness_matches_a_hand_computed_4x4_map() {
    let (flat, full) = ([0.5; 48], [1.0; 16]);
    let loss = materials(&step_map(), &flat, &full, [4, 4, 1]);
    assert!((loss - 1.0 / 3.0).abs() < 1e-6, "{loss}");
    let mask: Vec<f64> = (0..16).map(|i| if i < 12 { 1.0 } else { 0.0 }).collect();
    let loss = materials(&step_map(), &flat, &mask, [4, 4, 1]);
    assert!((loss - 5.0 / 12.0).abs() < 1e-6, "{loss}");
}

/// The same material step costs `e^{−0.5}` as much where the image has an edge at it, and an
/// image edge elsewhere changes nothing.
#[test]
fn an_image_edge_lowers_the_cost_of_a_material_step() {
    let full = [1.0; 16];
    let flat = materials(&step_map(), &[0.5; 48], &full, [4, 4, 1]);
    let at_edge = materials(&step_map(), &edge_image(2), &full, [4, 4, 1]);
    let elsewhere = materials(&step_map(), &edge_image(1), &full, [4, 4, 1]);
    assert!(at_edge < flat);
    assert!((at_edge - (-0.5f64).exp() / 3.0).abs() < 1e-6, "{at_edge}");
    assert!((elsewhere - flat).abs() < 1e-6, "{elsewhere} vs {flat}");
}

#[test]
fn materials_smoothness_matches_the_reference() {
    let seed = fresh_seed();
    let mut rng = Rng(seed);
    for _ in 0..10 {
        let shape = [0; 3].map(|_| 1 + (rng.next_u64() % 6) as usize);
        let [h, w, c] = shape;
        let maps: Vec<f64> = (0..h * w * c).map(|_| rng.range(0.0, 1.0)).collect();
        let image: Vec<f64> = (0..h * w * 3).map(|_| rng.range(0.0, 1.0)).collect();
        let mask: Vec<f64> = (0..h * w).map(|_| rng.range(0.0, 1.0)).collect();
        let round = |v: &[f64]| v.iter().map(|&x| x as f32 as f64).collect::<Vec<_>>();
        let (maps, image, mask) = (round(&maps), round(&image), round(&mask));
        let got = materials(&maps, &image, &mask, shape);
        let want = materials_smoothness_reference(&maps, &image, &mask, shape);
        assert!(got.is_finite(), "seed {seed}: {shape:?}");
        assert!(
            (got - want).abs() < 1e-5,
            "seed {seed}: {shape:?}: {got} vs {want}"
        );
    }
}

/// Eq. 12 as f64.
fn shadows(ao: &[f64], neighbours: &[usize], k: usize, in_box: &[bool]) -> f64 {
    let device = Device::flex();
    let m = ao.len();
    let loss = shadow_smoothness(
        tensor(ao, [m], &device),
        neighbour_tensor(neighbours, [m, k], &device),
        in_box,
    );
    f64::from(values(loss)[0])
}

#[test]
fn shadow_smoothness_is_zero_on_constant_ao() {
    let seed = fresh_seed();
    let mut rng = Rng(seed);
    let (m, k) = (30, 5);
    let ao = vec![rng.range(0.0, 1.0); m];
    let neighbours: Vec<usize> = (0..m * k)
        .map(|_| (rng.next_u64() % m as u64) as usize)
        .collect();
    let in_box: Vec<bool> = (0..m).map(|_| rng.next_u64().is_multiple_of(2)).collect();
    assert_eq!(shadows(&ao, &neighbours, k, &in_box), 0.0, "seed {seed}");
}

/// Three Gaussians, ao = (0.2, 0.5, 1.0), neighbours 0 → (0, 1), 1 → (0, 2), 2 → (1, 0), only
/// Gaussian 0 in the box: the self pair (0, 0) and the outside pairs (1, 2), (2, 1) are left
/// out, so the mean is over (0, 1), (1, 0), (2, 0): (0.3 + 0.3 + 0.8)/3. With nobody in the
/// box there is no pair and the term is 0.
#[test]
fn shadow_smoothness_matches_three_hand_computed_gaussians() {
    let ao = [0.2, 0.5, 1.0];
    let neighbours = [0, 1, 0, 2, 1, 0];
    let loss = shadows(&ao, &neighbours, 2, &[true, false, false]);
    assert!((loss - 1.4 / 3.0).abs() < 1e-6, "{loss}");
    let all = shadows(&ao, &neighbours, 2, &[true; 3]);
    assert!(
        (all - (0.3 + 0.5 + 0.5 + 0.8 + 0.3) / 5.0).abs() < 1e-6,
        "{all}"
    );
    assert_eq!(shadows(&ao, &neighbours, 2, &[false; 3]), 0.0);
}

#[test]
fn shadow_smoothness_matches_the_reference() {
    let seed = fresh_seed();
    let mut rng = Rng(seed);
    for _ in 0..10 {
        let m = 5 + (rng.next_u64() % 55) as usize;
        let k = 1 + (rng.next_u64() % 8) as usize;
        let in_box: Vec<bool> = (0..m).map(|_| rng.next_u64().is_multiple_of(3)).collect();
        let ao: Vec<f64> = in_box
            .iter()
            .map(|&b| {
                if b {
                    rng.range(0.0, 1.0) as f32 as f64
                } else {
                    1.0
                }
            })
            .collect();
        let neighbours: Vec<usize> = (0..m * k)
            .map(|_| (rng.next_u64() % m as u64) as usize)
            .collect();
        let got = shadows(&ao, &neighbours, k, &in_box);
        let want = shadow_smoothness_reference(&ao, &neighbours, &in_box);
        assert!((got - want).abs() < 1e-5, "seed {seed}: {got} vs {want}");
    }
}
