//! Illum's smoothness terms (§3.4, Eq. 11–12; Eq. 14 weighs them with Eq. 13's probe term,
//! which lives on the grid as [`crate::light_volume::LightVolume::probe_smoothness`]).
//!
//! - Eq. 11, [`materials_smoothness`]: `‖∇R‖·exp(−‖∇C_gt‖)` on rendered material maps, read
//!   as R3DG's `first_order_edge_aware_loss` (the spec's choice): forward differences along x
//!   and y, `|∂R|` per channel weighted by `exp(−|∂C|)` with `|∂C|` averaged over RGB; each
//!   direction's mean over its differences and channels, the two means summed. `R` is masked
//!   (multiplied) by the human alpha first, so only the person's materials are smoothed. Maps
//!   are `[H, W, C]`, the rasterizer's layout (`Render::color`, `Render::alpha` `[H, W]`).
//! - Eq. 12, [`shadow_smoothness`]: `|ao_i − ao_k|` over each scene Gaussian's `K` nearest
//!   neighbours, averaged (not summed, so its weight does not depend on the scene's size) over
//!   the pairs `(i, k)` with `k ≠ i` and at least one end in the shadow box. Pairs with both
//!   ends outside would cost 0 anyway (`ao ≡ 1` there); leaving them out keeps the mean from
//!   being diluted by the whole scene.
//!
//! Both have scalar f64 references beside them for the tests.

use burn::tensor::{Int, Tensor, TensorData};

/// Eq. 11: material maps `[H, W, C]`, the ground-truth image `[H, W, 3]` and the human alpha
/// mask `[H, W]` → the edge-aware smoothness `[1]`. A direction with fewer than two pixels
/// adds nothing (a 1×1 image costs 0).
pub fn materials_smoothness(maps: Tensor<3>, image: Tensor<3>, mask: Tensor<2>) -> Tensor<1> {
    let [h, w, _] = maps.dims();
    assert_eq!(
        image.dims(),
        [h, w, 3],
        "materials_smoothness: the image must be [{h}, {w}, 3]"
    );
    assert_eq!(
        mask.dims(),
        [h, w],
        "materials_smoothness: the mask must be [{h}, {w}]"
    );
    let device = maps.device();
    let masked = maps * mask.reshape([h, w, 1]);
    [(0, h), (1, w)]
        .into_iter()
        .filter(|&(_, size)| size >= 2)
        .map(|(axis, _)| {
            let dr = forward_difference(masked.clone(), axis).abs();
            let dc = forward_difference(image.clone(), axis).abs().mean_dim(2);
            (dr * dc.neg().exp()).mean()
        })
        .fold(Tensor::<1>::zeros([1], &device), |sum, term| sum + term)
}

/// `t[i + 1] − t[i]` along `axis` (0 = y, 1 = x) of `[H, W, C]`.
fn forward_difference(t: Tensor<3>, axis: usize) -> Tensor<3> {
    let size = t.dims()[axis];
    t.clone().slice_dim(axis, 1..size) - t.slice_dim(axis, 0..size - 1)
}

/// [`materials_smoothness`] in f64 on row-major `maps` `[H, W, C]`, `image` `[H, W, 3]` and
/// `mask` `[H, W]`.
pub fn materials_smoothness_reference(
    maps: &[f64],
    image: &[f64],
    mask: &[f64],
    [h, w, c]: [usize; 3],
) -> f64 {
    let r = |y: usize, x: usize, k: usize| maps[(y * w + x) * c + k] * mask[y * w + x];
    let colour_step = |(y0, x0): (usize, usize), (y1, x1): (usize, usize)| {
        (0..3)
            .map(|k| (image[(y1 * w + x1) * 3 + k] - image[(y0 * w + x0) * 3 + k]).abs())
            .sum::<f64>()
            / 3.0
    };
    let mut total = 0.0;
    // x differences.
    if w >= 2 {
        let mut sum = 0.0;
        for y in 0..h {
            for x in 0..w - 1 {
                let weight = (-colour_step((y, x), (y, x + 1))).exp();
                for k in 0..c {
                    sum += (r(y, x + 1, k) - r(y, x, k)).abs() * weight;
                }
            }
        }
        total += sum / (h * (w - 1) * c) as f64;
    }
    // y differences.
    if h >= 2 {
        let mut sum = 0.0;
        for y in 0..h - 1 {
            for x in 0..w {
                let weight = (-colour_step((y, x), (y + 1, x))).exp();
                for k in 0..c {
                    sum += (r(y + 1, x, k) - r(y, x, k)).abs() * weight;
                }
            }
        }
        total += sum / ((h - 1) * w * c) as f64;
    }
    total
}

/// Eq. 12: `ao` `[M]` of every scene Gaussian, its `K` nearest neighbours `[M, K]` (fixed scene
/// indices) and which Gaussians are in the shadow box (`[M]`, e.g. [`crate::shadow::ShadowBox::inside`])
/// → the mean of `|ao_i − ao_k|` over the pairs `(i, k)` with `k ≠ i` and `i` or `k` in the box
/// (`[1]`; 0 when there is no such pair). Gradients reach `ao` through both ends of a pair.
pub fn shadow_smoothness(ao: Tensor<1>, neighbours: Tensor<2, Int>, in_box: &[bool]) -> Tensor<1> {
    let [m, k] = neighbours.dims();
    assert_eq!(ao.dims(), [m], "shadow_smoothness: ao must be [{m}]");
    assert_eq!(
        in_box.len(),
        m,
        "shadow_smoothness: in_box must hold {m} flags"
    );
    let device = ao.device();
    let flat = neighbours.clone().reshape([m * k]);
    let inside: Vec<f32> = in_box.iter().map(|&b| if b { 1.0 } else { 0.0 }).collect();
    let inside = Tensor::<1>::from_data(TensorData::new(inside, [m]), &device);
    let either = inside
        .clone()
        .reshape([m, 1])
        .expand([m, k])
        .max_pair(inside.select(0, flat.clone()).reshape([m, k]));
    let own = Tensor::<1, Int>::arange(0..m as i64, &device)
        .reshape([m, 1])
        .expand([m, k]);
    let pairs = either * neighbours.not_equal(own).float();
    let ao_k = ao.clone().select(0, flat).reshape([m, k]);
    let differences = (ao.reshape([m, 1]).expand([m, k]) - ao_k).abs();
    (differences * pairs.clone()).sum() / pairs.sum().clamp_min(1.0)
}

/// [`shadow_smoothness`] in f64 on row-major neighbours `[M, K]`.
pub fn shadow_smoothness_reference(ao: &[f64], neighbours: &[usize], in_box: &[bool]) -> f64 {
    let m = ao.len();
    let k = neighbours.len() / m;
    let (mut sum, mut pairs) = (0.0, 0usize);
    for i in 0..m {
        for &j in &neighbours[i * k..(i + 1) * k] {
            if j != i && (in_box[i] || in_box[j]) {
                sum += (ao[i] - ao[j]).abs();
                pairs += 1;
            }
        }
    }
    if pairs == 0 { 0.0 } else { sum / pairs as f64 }
}
