//! NLF-GS's objective (Eq. 5–7) against its definition written out in f64, and its gradient
//! against finite differences.

use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_datasets::synth::rng::Rng;
use splatzoo_nlf_gs::loss::{NlfLossInputs, NlfLossWeights, intensity_gradient, nlf_loss};
use splatzoo_train::loss::scalar;

fn image(rng: &mut Rng, h: usize, w: usize) -> Vec<f64> {
    (0..h * w * 3).map(|_| rng.next()).collect()
}

fn tensor(v: &[f64], h: usize, w: usize, device: &Device) -> Tensor<3> {
    let data: Vec<f32> = v.iter().map(|&x| x as f32).collect();
    Tensor::from_data(TensorData::new(data, [h, w, 3]), device)
}

#[test]
fn nlf_objective_matches_its_definition_and_finite_differences() {
    let device = Device::flex();
    let mut rng = Rng(12);
    let (h, w) = (9, 7);
    let a = image(&mut rng, h, w);
    let b = image(&mut rng, h, w);
    let luma = |v: &[f64]| -> Vec<f64> {
        (0..h * w)
            .map(|p| 0.2126 * v[3 * p] + 0.7152 * v[3 * p + 1] + 0.0722 * v[3 * p + 2])
            .collect()
    };
    let (ya, yb) = (luma(&a), luma(&b));
    let mean = |v: Vec<f64>| v.iter().sum::<f64>() / v.len() as f64;
    let level = mean((0..h * w).map(|p| (ya[p] - yb[p]).abs()).collect());
    let gx = mean(
        (0..h)
            .flat_map(|y| (0..w - 1).map(move |x| (y, x)))
            .map(|(y, x)| {
                ((ya[y * w + x + 1] - ya[y * w + x]) - (yb[y * w + x + 1] - yb[y * w + x])).abs()
            })
            .collect(),
    );
    let gy = mean(
        (0..h - 1)
            .flat_map(|y| (0..w).map(move |x| (y, x)))
            .map(|(y, x)| {
                ((ya[(y + 1) * w + x] - ya[y * w + x]) - (yb[(y + 1) * w + x] - yb[y * w + x]))
                    .abs()
            })
            .collect(),
    );
    let got = scalar(intensity_gradient(
        tensor(&a, h, w, &device),
        tensor(&b, h, w, &device),
    ));
    assert!(
        (got - (level + gx + gy)).abs() < 1e-5,
        "{got} vs {}",
        level + gx + gy
    );

    let n = 6;
    let offsets: Vec<f64> = (0..3 * n).map(|_| rng.next() * 0.02 - 0.01).collect();
    let weights = NlfLossWeights::default();
    let total = |img: &[f64], off: &[f64]| -> f64 {
        let loss = nlf_loss(
            NlfLossInputs {
                image: tensor(img, h, w, &device),
                target: tensor(&b, h, w, &device),
                alpha: Tensor::<2>::ones([h, w], &device) * 0.8,
                mask: Tensor::<2>::ones([h, w], &device),
                log_scales: Tensor::<2>::ones([n, 3], &device) * -4.0,
                offsets: Tensor::from_data(
                    TensorData::new(off.iter().map(|&v| v as f32).collect::<Vec<_>>(), [n, 3]),
                    &device,
                ),
                opacity_logits: Tensor::<1>::zeros([n], &device),
            },
            &weights,
        );
        scalar(loss.total)
    };
    let img_leaf = tensor(&a, h, w, &device).autodiff().require_grad();
    let off_leaf = Tensor::<2>::from_data(
        TensorData::new(
            offsets.iter().map(|&v| v as f32).collect::<Vec<_>>(),
            [n, 3],
        ),
        &device,
    )
    .autodiff()
    .require_grad();
    let loss = nlf_loss(
        NlfLossInputs {
            image: img_leaf.clone(),
            target: tensor(&b, h, w, &device).autodiff(),
            alpha: (Tensor::<2>::ones([h, w], &device) * 0.8).autodiff(),
            mask: Tensor::<2>::ones([h, w], &device).autodiff(),
            log_scales: (Tensor::<2>::ones([n, 3], &device) * -4.0).autodiff(),
            offsets: off_leaf.clone(),
            opacity_logits: Tensor::<1>::zeros([n], &device).autodiff(),
        },
        &weights,
    );
    let grads = loss.total.backward();
    let gi: Vec<f32> = img_leaf
        .grad(&grads)
        .unwrap()
        .into_data()
        .try_into_vec()
        .unwrap();
    let go: Vec<f32> = off_leaf
        .grad(&grads)
        .unwrap()
        .into_data()
        .try_into_vec()
        .unwrap();
    let eps = 1e-3;
    for &k in &[0usize, 17, 50, 100, 3 * h * w - 1] {
        let (mut p, mut m) = (a.clone(), a.clone());
        p[k] += eps;
        m[k] -= eps;
        let fd = (total(&p, &offsets) - total(&m, &offsets)) / (2.0 * eps);
        assert!(
            (gi[k] as f64 - fd).abs() < 2e-3 + 0.05 * fd.abs(),
            "image {k}: {} vs {fd}",
            gi[k]
        );
    }
    for k in [0usize, 7, 3 * n - 1] {
        let (mut p, mut m) = (offsets.clone(), offsets.clone());
        p[k] += eps;
        m[k] -= eps;
        let fd = (total(&a, &p) - total(&a, &m)) / (2.0 * eps);
        assert!(
            (go[k] as f64 - fd).abs() < 1e-5 + 0.01 * fd.abs(),
            "offset {k}: {} vs {fd}",
            go[k]
        );
    }
    // The regulariser's prior: transparent Gaussians cost more than opaque ones.
    let opaque = nlf_loss(
        NlfLossInputs {
            image: tensor(&a, h, w, &device),
            target: tensor(&a, h, w, &device),
            alpha: Tensor::<2>::ones([h, w], &device),
            mask: Tensor::<2>::ones([h, w], &device),
            log_scales: Tensor::<2>::ones([n, 3], &device) * -4.0,
            offsets: Tensor::<2>::zeros([n, 3], &device),
            opacity_logits: Tensor::<1>::ones([n], &device) * 5.0,
        },
        &weights,
    );
    assert!(scalar(opaque.opacity) < 0.01 && scalar(opaque.l1) == 0.0);
}

/// Each weight enters the total as Eq. 5–7 say: the returned terms match their definitions
/// (in f64, or the term functions), the total is `λ_rec (λ_l1 L1 + λ_ssim (1 − SSIM) +
/// λ_perc L_perc) + λ_sil L_sil + λ_reg (λ_scale L_scale + λ_Δx L_Δx + λ_α L_α)` for random
/// non-default weights, and moving one weight by δ moves the total by δ times its term (times
/// its parent weight for the nested ones).
#[test]
fn each_loss_weight_scales_its_own_term() {
    use splatzoo_train::loss::{l1, silhouette, ssim};
    let device = Device::flex();
    let seed = crate::fresh_seed();
    println!("seed {seed}");
    let mut rng = Rng(seed);
    let (h, w, n) = (8, 6, 5);
    let a = image(&mut rng, h, w);
    let b = image(&mut rng, h, w);
    let alpha: Vec<f64> = (0..h * w).map(|_| rng.next()).collect();
    let mask: Vec<f64> = (0..h * w)
        .map(|_| if rng.next() < 0.5 { 1.0 } else { 0.0 })
        .collect();
    let log_scales: Vec<f64> = (0..3 * n).map(|_| rng.range(-3.0, -1.0)).collect();
    let offsets: Vec<f64> = (0..3 * n).map(|_| rng.range(-0.5, 0.5)).collect();
    let logits: Vec<f64> = (0..n).map(|_| 2.0 * rng.normal()).collect();
    let f32s = |v: &[f64]| v.iter().map(|&x| x as f32).collect::<Vec<f32>>();
    let plane = |v: &[f64]| Tensor::<2>::from_data(TensorData::new(f32s(v), [h, w]), &device);
    let rows = |v: &[f64]| Tensor::<2>::from_data(TensorData::new(f32s(v), [n, 3]), &device);
    let inputs = || NlfLossInputs {
        image: tensor(&a, h, w, &device),
        target: tensor(&b, h, w, &device),
        alpha: plane(&alpha),
        mask: plane(&mask),
        log_scales: rows(&log_scales),
        offsets: rows(&offsets),
        opacity_logits: Tensor::<1>::from_data(TensorData::new(f32s(&logits), [n]), &device),
    };
    let mut weights = NlfLossWeights::default();
    for v in [
        &mut weights.reconstruction,
        &mut weights.l1,
        &mut weights.ssim,
        &mut weights.perceptual,
        &mut weights.silhouette,
        &mut weights.regularisation,
        &mut weights.scale,
        &mut weights.offset,
        &mut weights.opacity,
    ] {
        *v = rng.range(0.2, 2.0);
    }
    let loss = nlf_loss(inputs(), &weights);
    let terms = [
        scalar(loss.l1),
        scalar(loss.ssim),
        scalar(loss.perceptual),
        scalar(loss.silhouette),
        scalar(loss.scale),
        scalar(loss.offset),
        scalar(loss.opacity),
    ];
    let [l1_t, ssim_t, perc_t, sil_t, scale_t, offset_t, opacity_t] = terms;
    let total = scalar(loss.total);

    // The terms: their definitions.
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let diff: Vec<f64> = a.iter().zip(&b).map(|(x, y)| (x - y).abs()).collect();
    let sil: Vec<f64> = alpha
        .iter()
        .zip(&mask)
        .map(|(x, y)| (x - y).abs())
        .collect();
    let scales: Vec<f64> = log_scales.iter().map(|v| v.exp()).collect();
    let squared: Vec<f64> = offsets
        .chunks(3)
        .map(|o| o.iter().map(|v| v * v).sum::<f64>())
        .collect();
    let transparency: Vec<f64> = logits
        .iter()
        .map(|&x| 1.0 - 1.0 / (1.0 + (-x).exp()))
        .collect();
    let one_minus_ssim = 1.0 - scalar(ssim(tensor(&a, h, w, &device), tensor(&b, h, w, &device)));
    let perceptual = scalar(intensity_gradient(
        tensor(&a, h, w, &device),
        tensor(&b, h, w, &device),
    ));
    let l1_fn = scalar(l1(tensor(&a, h, w, &device), tensor(&b, h, w, &device)));
    let sil_fn = scalar(silhouette(plane(&alpha), plane(&mask)));
    for (what, got, want) in [
        ("L1", l1_t, mean(&diff)),
        ("L1 (term function)", l1_t, l1_fn),
        ("1 − SSIM", ssim_t, one_minus_ssim),
        ("L_perc", perc_t, perceptual),
        ("L_sil", sil_t, mean(&sil)),
        ("L_sil (term function)", sil_t, sil_fn),
        ("L_scale", scale_t, mean(&scales)),
        ("L_Δx", offset_t, mean(&squared)),
        ("L_α", opacity_t, mean(&transparency)),
    ] {
        assert!(
            (got - want).abs() < 1e-6 * (1.0 + want.abs()),
            "{what}: {got} vs {want} (seed {seed})"
        );
    }

    // The total: Eq. 5–7.
    let reconstruction = weights.l1 * l1_t + weights.ssim * ssim_t + weights.perceptual * perc_t;
    let regularisation =
        weights.scale * scale_t + weights.offset * offset_t + weights.opacity * opacity_t;
    let combined = weights.reconstruction * reconstruction
        + weights.silhouette * sil_t
        + weights.regularisation * regularisation;
    assert!(
        (total - combined).abs() < 2e-6 * (1.0 + combined.abs()),
        "total {total} vs {combined} (seed {seed})"
    );

    // One weight at a time, moved by δ: the total moves by δ × its term (× its parent).
    let expected_slope = [
        ("reconstruction", reconstruction),
        ("l1", weights.reconstruction * l1_t),
        ("ssim", weights.reconstruction * ssim_t),
        ("perceptual", weights.reconstruction * perc_t),
        ("silhouette", sil_t),
        ("regularisation", regularisation),
        ("scale", weights.regularisation * scale_t),
        ("offset", weights.regularisation * offset_t),
        ("opacity", weights.regularisation * opacity_t),
    ];
    for (k, (name, slope)) in expected_slope.into_iter().enumerate() {
        let delta = rng.range(0.5, 1.0);
        let mut moved = weights;
        match k {
            0 => moved.reconstruction += delta,
            1 => moved.l1 += delta,
            2 => moved.ssim += delta,
            3 => moved.perceptual += delta,
            4 => moved.silhouette += delta,
            5 => moved.regularisation += delta,
            6 => moved.scale += delta,
            7 => moved.offset += delta,
            _ => moved.opacity += delta,
        }
        let change = scalar(nlf_loss(inputs(), &moved).total) - total;
        let want = delta * slope;
        let tolerance = 4e-6 * (1.0 + total.abs());
        assert!(
            want.abs() > 10.0 * tolerance,
            "{name}: the change {want} is too small to test (seed {seed})"
        );
        assert!(
            (change - want).abs() < tolerance,
            "{name} + {delta}: total moved by {change}, expected {want} (seed {seed})"
        );
    }
}
