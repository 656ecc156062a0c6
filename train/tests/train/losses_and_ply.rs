//! Losses against f64 references and finite differences, PSNR from its definition, Adam
//! against the scalar update rule, and the INRIA `.ply` round trip (with extra properties) and
//! its errors.

use burn::tensor::{Device, Int, Tensor, TensorData};
use splatzoo_datasets::synth::rng::Rng;
use splatzoo_train::adam::{AdamConfig, AdamState};
use splatzoo_train::gaussians::GaussianSet;
use splatzoo_train::loss::{
    d_ssim, l1, masked_l1, masked_psnr, masked_ssim, photometric, psnr, scalar, ssim, window,
};
use splatzoo_train::ply::{read_ply, read_ply_columns, write_ply, write_ply_with};

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
    let map = ssim_map_reference(x, y, h, w);
    map.iter().sum::<f64>() / map.len() as f64
}

/// The per-pixel SSIM of [`ssim_reference`], `[H, W, 3]` row-major.
fn ssim_map_reference(x: &[f64], y: &[f64], h: usize, w: usize) -> Vec<f64> {
    let g = window();
    let r = (g.len() / 2) as i64;
    let (c1, c2) = (1e-4, 9e-4);
    let mut map = vec![0.0; h * w * 3];
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
                map[(i as usize * w + j as usize) * 3 + c] = (2.0 * mx * my + c1)
                    * (2.0 * cxy + c2)
                    / ((mx * mx + my * my + c1) * (vx + vy + c2));
            }
        }
    }
    map
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

/// Normals and extra properties (material maps) ride along: the Gaussians read back unchanged,
/// the extras by name; mismatched lengths and names INRIA's layout already uses are refused.
#[test]
fn ply_extras_round_trip_beside_the_gaussians() {
    let device = Device::flex();
    let dir = tempfile::tempdir().unwrap();
    let mut rng = Rng(fresh_seed());
    let n = 17;
    let positions: Vec<[f32; 3]> = (0..n)
        .map(|_| [rng.next() as f32, rng.next() as f32, rng.next() as f32])
        .collect();
    let sigmas = vec![0.05; n];
    let set = GaussianSet::from_points(&positions, &positions, &sigmas, &device);
    let normals: Vec<f32> = (0..3 * n).map(|_| rng.next() as f32 - 0.5).collect();
    let roughness: Vec<f32> = (0..n).map(|_| rng.next() as f32).collect();
    let flags: Vec<f32> = (0..n).map(|i| (i % 2) as f32).collect();
    let path = dir.path().join("m.ply");
    write_ply_with(
        &path,
        &set,
        Some(&normals),
        &[("roughness", &roughness), ("human", &flags)],
    )
    .unwrap();
    let plain = dir.path().join("p.ply");
    write_ply(&plain, &set).unwrap();
    let v2 = |t: Tensor<2>| t.into_data().try_into_vec::<f32>().unwrap();
    let (back, same) = (
        read_ply(&path, &device).unwrap(),
        read_ply(&plain, &device).unwrap(),
    );
    assert_eq!(v2(back.means), v2(same.means));
    assert_eq!(v2(back.quats), v2(same.quats));
    let columns = read_ply_columns(&path, &["roughness", "human", "nx", "ny", "nz"]).unwrap();
    assert_eq!(columns[0], roughness);
    assert_eq!(columns[1], flags);
    for i in 0..n {
        for k in 0..3 {
            assert_eq!(columns[2 + k][i], normals[3 * i + k]);
        }
    }
    let e = read_ply_columns(&plain, &["roughness"])
        .unwrap_err()
        .to_string();
    assert!(e.contains("roughness") && e.contains("missing"), "{e}");
    let short = write_ply_with(&path, &set, None, &[("roughness", &roughness[1..])]);
    assert!(short.unwrap_err().to_string().contains("16 values for 17"));
    let taken = write_ply_with(&path, &set, None, &[("opacity", &roughness)]);
    assert!(taken.unwrap_err().to_string().contains("`opacity`"));
    let bad_normals = write_ply_with(&path, &set, Some(&normals[3..]), &[]);
    assert!(
        bad_normals
            .unwrap_err()
            .to_string()
            .contains("normal values")
    );
}

/// A seed from the clock, printed so that a failure can be replayed.
pub fn fresh_seed() -> u64 {
    let seed = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_nanos() as u64;
    println!("seed {seed}");
    seed
}

/// D-SSIM and the masked L1, SSIM and PSNR against their definitions in f64 on random images
/// and random binary masks: a masked mean divides by `max(Σ mask, 1) · C` (so an empty mask gives
/// 0 and no NaN, and the PSNR its 200 dB cap), and an all-one mask gives the unmasked values.
#[test]
fn d_ssim_and_the_masked_losses_follow_their_f64_definitions() {
    let device = Device::flex();
    let seed = fresh_seed();
    let mut rng = Rng(seed);
    let (h, w) = (9, 11);
    let x = image(&mut rng, h, w);
    let y: Vec<f64> = x
        .iter()
        .map(|v| (v + 0.4 * (rng.next() - 0.5)).clamp(0.0, 1.0))
        .collect();
    let (tx, ty) = (tensor(&x, h, w, &device), tensor(&y, h, w, &device));

    // D-SSIM = (1 − SSIM) / 2.
    let want = (1.0 - ssim_reference(&x, &y, h, w)) / 2.0;
    let got = scalar(d_ssim(tx.clone(), ty.clone()));
    assert!(
        (got - want).abs() < 5e-5,
        "D-SSIM {got} vs {want} (seed {seed})"
    );
    assert!(want > 0.005, "the images differ: {want}");
    let same = scalar(d_ssim(tx.clone(), tx.clone()));
    assert!(same.abs() < 1e-5, "D-SSIM of an image with itself: {same}");

    let mask_tensor = |m: &[f64]| {
        Tensor::<2>::from_data(
            TensorData::new(m.iter().map(|&v| v as f32).collect::<Vec<f32>>(), [h, w]),
            &device,
        )
    };
    let ssim_map = ssim_map_reference(&x, &y, h, w);
    let abs: Vec<f64> = x.iter().zip(&y).map(|(a, b)| (a - b).abs()).collect();
    let mut masks: Vec<(String, Vec<f64>)> = vec![
        ("all zero".into(), vec![0.0; h * w]),
        ("all one".into(), vec![1.0; h * w]),
    ];
    for density in [0.1, 0.5, 0.9] {
        let m = (0..h * w)
            .map(|_| if rng.next() < density { 1.0 } else { 0.0 })
            .collect();
        masks.push((format!("density {density}"), m));
    }
    let mut single = vec![0.0; h * w];
    single[rng.below(h * w)] = 1.0;
    masks.push(("one pixel".into(), single));
    for (name, m) in &masks {
        let count: f64 = m.iter().sum();
        let masked_mean = |values: &[f64]| {
            values
                .iter()
                .enumerate()
                .map(|(k, v)| v * m[k / 3])
                .sum::<f64>()
                / (count.max(1.0) * 3.0)
        };
        let sse: f64 = abs.iter().enumerate().map(|(k, d)| d * d * m[k / 3]).sum();
        let psnr_want = -10.0 * (sse / (3.0 * count).max(1.0)).max(1e-20).log10();
        let l1_got = scalar(masked_l1(tx.clone(), ty.clone(), mask_tensor(m)));
        let ssim_got = scalar(masked_ssim(tx.clone(), ty.clone(), mask_tensor(m)));
        let psnr_got = masked_psnr(tx.clone(), ty.clone(), mask_tensor(m));
        for (what, got, want, tolerance) in [
            ("masked L1", l1_got, masked_mean(&abs), 2e-6),
            ("masked SSIM", ssim_got, masked_mean(&ssim_map), 1e-4),
            ("masked PSNR", psnr_got, psnr_want, 1e-4),
        ] {
            assert!(
                got.is_finite() && (got - want).abs() < tolerance,
                "{name}: {what} {got} vs {want} (seed {seed})"
            );
        }
        if count == 0.0 {
            assert_eq!(l1_got, 0.0, "an empty mask's L1");
            assert_eq!(ssim_got, 0.0, "an empty mask's SSIM");
            assert!(
                (psnr_got - 200.0).abs() < 1e-9,
                "an empty mask's PSNR: {psnr_got}"
            );
        }
    }

    // An all-one mask: the unmasked values.
    let ones = mask_tensor(&vec![1.0; h * w]);
    let pairs = [
        (
            "L1",
            scalar(masked_l1(tx.clone(), ty.clone(), ones.clone())),
            scalar(l1(tx.clone(), ty.clone())),
            1e-6,
        ),
        (
            "SSIM",
            scalar(masked_ssim(tx.clone(), ty.clone(), ones.clone())),
            scalar(ssim(tx.clone(), ty.clone())),
            1e-6,
        ),
        (
            "PSNR",
            masked_psnr(tx.clone(), ty.clone(), ones),
            psnr(tx.clone(), ty.clone()),
            1e-4,
        ),
    ];
    for (what, masked, plain, tolerance) in pairs {
        assert!(
            (masked - plain).abs() < tolerance,
            "{what}: masked by ones {masked} vs unmasked {plain}"
        );
    }
}

/// The masked L1's gradient: `sign(x − y) · mask / (max(Σ mask, 1) · C)`, analytically and by
/// central differences away from the kinks (exact there: the loss is linear in each element).
#[test]
fn the_masked_l1_gradient_matches_finite_differences() {
    let device = Device::flex().autodiff();
    let plain = Device::flex();
    let seed = fresh_seed();
    let mut rng = Rng(seed);
    let (h, w) = (7, 6);
    let x = image(&mut rng, h, w);
    let y = image(&mut rng, h, w);
    let mask: Vec<f64> = (0..h * w)
        .map(|_| if rng.next() < 0.5 { 1.0 } else { 0.0 })
        .collect();
    let mask_f32: Vec<f32> = mask.iter().map(|&v| v as f32).collect();
    let count = mask.iter().sum::<f64>().max(1.0);
    let leaf = tensor(&x, h, w, &device).require_grad();
    let loss = masked_l1(
        leaf.clone(),
        tensor(&y, h, w, &device),
        Tensor::<2>::from_data(TensorData::new(mask_f32.clone(), [h, w]), &device),
    );
    let grads = loss.backward();
    let g: Vec<f32> = leaf
        .grad(&grads)
        .unwrap()
        .into_data()
        .try_into_vec::<f32>()
        .unwrap();
    assert_eq!(g.len(), h * w * 3);
    for k in 0..h * w * 3 {
        let analytic = (x[k] - y[k]).signum() * mask[k / 3] / (3.0 * count);
        assert!(
            (g[k] as f64 - analytic).abs() < 1e-7 + 1e-5 * analytic.abs(),
            "element {k}: {} vs {analytic} (seed {seed})",
            g[k]
        );
    }
    let eval = |v: &[f64]| {
        scalar(masked_l1(
            tensor(v, h, w, &plain),
            tensor(&y, h, w, &plain),
            Tensor::<2>::from_data(TensorData::new(mask_f32.clone(), [h, w]), &plain),
        ))
    };
    let mut checked = [0usize; 2];
    for _ in 0..40 {
        let k = rng.below(h * w * 3);
        if (x[k] - y[k]).abs() < 0.05 {
            continue;
        }
        let step = 0.02;
        let (mut up, mut down) = (x.clone(), x.clone());
        up[k] += step;
        down[k] -= step;
        let fd = (eval(&up) - eval(&down)) / (2.0 * step);
        assert!(
            (fd - g[k] as f64).abs() < 1e-5 + 1e-3 * fd.abs(),
            "element {k}: {fd} vs {} (seed {seed})",
            g[k]
        );
        checked[mask[k / 3] as usize] += 1;
    }
    assert!(
        checked[0] > 0 && checked[1] > 0,
        "{checked:?} masked-out / masked-in elements checked (seed {seed})"
    );
}
