//! Losses against f64 references and finite differences, PSNR from its definition, Adam
//! against the scalar update rule, and the INRIA `.ply` round trip and its errors.

use burn::tensor::{Device, Int, Tensor, TensorData};
use splatzoo_datasets::synth::rng::Rng;
use splatzoo_train::adam::{AdamConfig, AdamState};
use splatzoo_train::gaussians::GaussianSet;
use splatzoo_train::loss::{photometric, psnr, scalar, ssim, window};
use splatzoo_train::ply::{read_ply, write_ply};

fn image(rng: &mut Rng, h: usize, w: usize) -> Vec<f64> {
    (0..h * w * 3).map(|_| rng.next()).collect()
}

fn tensor(v: &[f64], h: usize, w: usize, device: &Device) -> Tensor<3> {
    let f: Vec<f32> = v.iter().map(|&x| x as f32).collect();
    Tensor::from_data(TensorData::new(f, [h, w, 3]), device)
}

/// SSIM in f64 straight from its definition: Gaussian-weighted local statistics with zero
/// padding, averaged over pixels and channels.
fn ssim_reference(x: &[f64], y: &[f64], h: usize, w: usize) -> f64 {
    let g = window();
    let r = (g.len() / 2) as i64;
    let (c1, c2) = (1e-4, 9e-4);
    let mut total = 0.0;
    for c in 0..3 {
        for i in 0..h as i64 {
            for j in 0..w as i64 {
                let (mut mx, mut my, mut xx, mut yy, mut xy) = (0.0, 0.0, 0.0, 0.0, 0.0);
                for di in -r..=r {
                    for dj in -r..=r {
                        let (a, b) = (i + di, j + dj);
                        if a < 0 || b < 0 || a >= h as i64 || b >= w as i64 {
                            continue;
                        }
                        let wgt = g[(di + r) as usize] * g[(dj + r) as usize];
                        let k = (a as usize * w + b as usize) * 3 + c;
                        mx += wgt * x[k];
                        my += wgt * y[k];
                        xx += wgt * x[k] * x[k];
                        yy += wgt * y[k] * y[k];
                        xy += wgt * x[k] * y[k];
                    }
                }
                let (vx, vy, cxy) = (xx - mx * mx, yy - my * my, xy - mx * my);
                total += (2.0 * mx * my + c1) * (2.0 * cxy + c2)
                    / ((mx * mx + my * my + c1) * (vx + vy + c2));
            }
        }
    }
    total / (3 * h * w) as f64
}

#[test]
fn ssim_matches_the_f64_definition_and_is_one_on_equal_images() {
    let device = Device::flex();
    let mut rng = Rng(1);
    for (h, w) in [(13, 17), (32, 24), (4, 5)] {
        let x = image(&mut rng, h, w);
        let mut y = x.clone();
        for v in y.iter_mut() {
            *v = (*v + 0.2 * (rng.next() - 0.5)).clamp(0.0, 1.0);
        }
        let fast = scalar(ssim(tensor(&x, h, w, &device), tensor(&y, h, w, &device)));
        let reference = ssim_reference(&x, &y, h, w);
        assert!(
            (fast - reference).abs() < 1e-4,
            "{h}×{w}: {fast} vs {reference}"
        );
        let same = scalar(ssim(tensor(&x, h, w, &device), tensor(&x, h, w, &device)));
        assert!((same - 1.0).abs() < 1e-5, "{same}");
    }
    // Degenerate: constant images (zero variance) still give finite values.
    let flat = vec![0.5; 8 * 8 * 3];
    let zero = vec![0.0; 8 * 8 * 3];
    let v = scalar(ssim(
        tensor(&flat, 8, 8, &device),
        tensor(&zero, 8, 8, &device),
    ));
    assert!(v.is_finite() && (v - ssim_reference(&flat, &zero, 8, 8)).abs() < 1e-4);
}

#[test]
fn the_photometric_loss_gradient_matches_finite_differences() {
    let device = Device::flex().autodiff();
    let mut rng = Rng(2);
    let (h, w) = (12, 10);
    let x = image(&mut rng, h, w);
    let y = image(&mut rng, h, w);
    let leaf = tensor(&x, h, w, &device).require_grad();
    let loss = photometric(leaf.clone(), tensor(&y, h, w, &device), 0.2);
    let grads = loss.backward();
    let g: Vec<f32> = leaf
        .grad(&grads)
        .unwrap()
        .into_data()
        .try_into_vec::<f32>()
        .unwrap();
    let plain = Device::flex();
    let eval = |v: &[f64]| {
        scalar(photometric(
            tensor(v, h, w, &plain),
            tensor(&y, h, w, &plain),
            0.2,
        ))
    };
    for _ in 0..12 {
        let k = (rng.next() * (h * w * 3) as f64) as usize;
        let step = 1e-3;
        let (mut up, mut down) = (x.clone(), x.clone());
        up[k] += step;
        down[k] -= step;
        let fd = (eval(&up) - eval(&down)) / (2.0 * step);
        assert!(
            (fd - g[k] as f64).abs() < 2e-4 + 0.05 * fd.abs(),
            "element {k}: {fd} vs {}",
            g[k]
        );
    }
}

#[test]
fn psnr_follows_its_definition() {
    let device = Device::flex();
    let a = Tensor::<3>::zeros([4, 4, 3], &device);
    let b = Tensor::<3>::full([4, 4, 3], 0.1, &device);
    assert!((psnr(a.clone(), b) - 20.0).abs() < 1e-4);
    assert!(
        psnr(a.clone(), a).is_finite(),
        "identical images give a finite cap"
    );
}

#[test]
fn adam_matches_the_scalar_update_rule() {
    let device = Device::flex();
    let config = AdamConfig {
        epsilon: 1e-8,
        ..AdamConfig::default()
    };
    let mut param = Tensor::<1>::from_floats([1.0, -2.0, 0.5], &device);
    let mut state = AdamState::new(&param);
    let (mut p, mut m, mut v) = ([1.0f64, -2.0, 0.5], [0.0f64; 3], [0.0f64; 3]);
    for t in 1..=5 {
        let grad = [0.3 * t as f64, -0.1, 2.0 / t as f64];
        param = state.step(
            param,
            Tensor::from_floats(grad.map(|g| g as f32), &device),
            0.01,
            &config,
        );
        for k in 0..3 {
            m[k] = 0.9 * m[k] + 0.1 * grad[k];
            v[k] = 0.999 * v[k] + 0.001 * grad[k] * grad[k];
            let mh = m[k] / (1.0 - 0.9f64.powi(t));
            let vh = v[k] / (1.0 - 0.999f64.powi(t));
            p[k] -= 0.01 * mh / (vh.sqrt() + 1e-8);
        }
    }
    let got: Vec<f32> = param.into_data().try_into_vec().unwrap();
    for k in 0..3 {
        assert!((got[k] as f64 - p[k]).abs() < 1e-5, "{got:?} vs {p:?}");
    }
    // Pruning keeps the surviving rows' moments; growing appends zeros.
    let first_before: Vec<f32> = state.first.clone().into_data().try_into_vec().unwrap();
    state.select(Tensor::<1, Int>::from_ints([0, 2], &device));
    state.grow(2);
    let first: Vec<f32> = state.first.into_data().try_into_vec().unwrap();
    assert_eq!(first, vec![first_before[0], first_before[2], 0.0, 0.0]);
}

#[test]
fn ply_round_trips_and_bad_files_are_refused() {
    let device = Device::flex();
    let dir = tempfile::tempdir().unwrap();
    let mut rng = Rng(3);
    let n = 50;
    let positions: Vec<[f32; 3]> = (0..n)
        .map(|_| [rng.next() as f32, rng.next() as f32, rng.next() as f32])
        .collect();
    let colours = positions.clone();
    let sigmas: Vec<f32> = (0..n).map(|_| 0.01 + rng.next() as f32 * 0.1).collect();
    let mut set = GaussianSet::from_points(&positions, &colours, &sigmas, &device);
    let rest: Vec<f32> = (0..n * 45).map(|_| rng.next() as f32 - 0.5).collect();
    set.sh_rest = Tensor::from_data(TensorData::new(rest.clone(), [n, 15, 3]), &device);
    let path = dir.path().join("g.ply");
    write_ply(&path, &set).unwrap();
    let back = read_ply(&path, &device).unwrap();
    let v = |t: Tensor<3>| t.into_data().try_into_vec::<f32>().unwrap();
    assert_eq!(v(back.sh_rest.clone()), rest);
    assert_eq!(v(back.sh_dc.clone()), v(set.sh_dc.clone()));
    let v2 = |t: Tensor<2>| t.into_data().try_into_vec::<f32>().unwrap();
    assert_eq!(v2(back.means), v2(set.means));
    assert_eq!(v2(back.log_scales), v2(set.log_scales.clone()));
    assert_eq!(v2(back.quats), v2(set.quats));
    // The INRIA channel-major f_rest order: f_rest_15 is coefficient 1 of green.
    let bytes = std::fs::read(&path).unwrap();
    let header_end = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .unwrap()
        + 11;
    let header = String::from_utf8_lossy(&bytes[..header_end]).to_string();
    let props: Vec<&str> = header
        .lines()
        .filter_map(|l| l.strip_prefix("property float "))
        .collect();
    assert_eq!(props.len(), 62);
    let col = props.iter().position(|p| *p == "f_rest_15").unwrap();
    let at = header_end + col * 4;
    let value = f32::from_le_bytes(bytes[at..at + 4].try_into().unwrap());
    assert_eq!(
        value, rest[1],
        "f_rest_15 must hold channel 1, coefficient 1"
    );
    // Truncated body, wrong property type, not a ply.
    std::fs::write(&path, &bytes[..bytes.len() - 7]).unwrap();
    let e = read_ply(&path, &device).unwrap_err().to_string();
    assert!(e.contains("truncated") && e.contains("g.ply"), "{e}");
    std::fs::write(
        &path,
        header.replace("property float opacity", "property uchar opacity"),
    )
    .unwrap();
    let e = read_ply(&path, &device).unwrap_err().to_string();
    assert!(e.contains("opacity"), "{e}");
    std::fs::write(&path, b"solid\n").unwrap();
    assert!(read_ply(&path, &device).is_err());
}

/// The intensity-and-gradient term against its f64 definition, and NLF-GS's total objective
/// against finite differences in the image and the offsets.
#[test]
fn nlf_objective_matches_its_definition_and_finite_differences() {
    use splatzoo_train::loss::intensity_gradient;
    use splatzoo_train::nlf_loss::{NlfLossInputs, NlfLossWeights, nlf_loss};
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
