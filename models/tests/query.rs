//! NLF-GS's query and fusion (Eq. 2–4) against scalar formulas: projection, the pixel-centre
//! convention of the sampling, each fusion variant's weights, the weighted mean, gradients by
//! finite differences; and the decoder's bounds at extreme inputs.

use burn::tensor::{Device, Tensor, TensorData};
use rand::{Rng, SeedableRng, rngs::StdRng};
use splatzoo_models::networks::decoder::Decoder;
use splatzoo_models::networks::query::{
    Fusion, Projection, Views, fuse, project, sample, sample_and_fuse, sample_by_grid, weights,
};

fn host<const D: usize>(t: Tensor<D>) -> Vec<f32> {
    t.into_data()
        .convert::<f32>()
        .try_into_vec::<f32>()
        .unwrap()
}

/// Two cameras 3 m from the origin: view 0 on −z looking +z, view 1 on +x looking −x.
fn views(device: &Device) -> (Views, Tensor<2>) {
    let w2c = [
        [
            1.0f32, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 3.0,
        ],
        // Camera at (3, 0, 0) looking −x: rows right = (0, 0, −1)... chosen so x_cam = R x + t.
        [0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, -1.0, 0.0, 0.0, 3.0],
    ];
    let views = Views {
        intrinsics: Tensor::from_data(
            TensorData::new(
                vec![40.0f32, 42.0, 16.0, 12.0, 50.0, 50.0, 16.5, 11.5],
                [2, 4],
            ),
            device,
        ),
        world_to_camera: Tensor::from_data(TensorData::new(w2c.concat(), [2, 3, 4]), device),
        size: [32, 24],
    };
    let centres = Tensor::from_data(
        TensorData::new(vec![0.0f32, 0.0, -3.0, 3.0, 0.0, 0.0], [2, 3]),
        device,
    );
    (views, centres)
}

#[test]
fn projection_and_sampling_follow_eq_2_and_3_with_pixel_centres_at_half() {
    let device = Device::flex();
    let (views, _) = views(&device);
    let pts = [[0.1f32, -0.2, 0.3], [-0.4, 0.25, -0.1], [0.0, 0.0, -4.0]];
    let points = Tensor::<2>::from_data(TensorData::new(pts.concat(), [3, 3]), &device);
    let proj = project(points, &views);
    let pixels = host(proj.pixels.clone());
    let k = [[40.0, 42.0, 16.0, 12.0], [50.0, 50.0, 16.5, 11.5]];
    let r: [[[f32; 3]; 3]; 2] = [
        [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        [[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]],
    ];
    let t = [[0.0, 0.0, 3.0], [0.0, 0.0, 3.0]];
    for v in 0..2 {
        for (i, p) in pts.iter().enumerate().take(2) {
            let c: Vec<f32> = (0..3)
                .map(|a| (0..3).map(|b| r[v][a][b] * p[b]).sum::<f32>() + t[v][a])
                .collect();
            let u = k[v][0] * c[0] / c[2] + k[v][2];
            let y = k[v][1] * c[1] / c[2] + k[v][3];
            let at = (v * 3 + i) * 2;
            assert!(
                (pixels[at] - u).abs() < 1e-4 && (pixels[at + 1] - y).abs() < 1e-4,
                "view {v} point {i}"
            );
        }
    }
    let inside = proj
        .inside
        .clone()
        .into_data()
        .try_to_vec::<bool>()
        .unwrap();
    assert_eq!(
        &inside[..3],
        &[true, true, false],
        "the third point is behind view 0"
    );
    // A stride-4 feature map holding each feature pixel's image-space centre: sampling returns
    // the projected pixel itself.
    let (fw, fh) = (8, 6);
    let mut values = Vec::new();
    for channel in 0..2 {
        for y in 0..fh {
            for x in 0..fw {
                values.push(4.0 * ((if channel == 0 { x } else { y }) as f32 + 0.5));
            }
        }
    }
    let map = Tensor::<4>::from_data(TensorData::new(values, [1, 2, fh, fw]), &device)
        .expand([2, 2, fh, fw]);
    let stacked = sample(map.clone(), &proj, views.size);
    // Fusing view by view equals sampling all views, then fusing.
    let w = Tensor::<2>::from_data(
        TensorData::new(vec![0.3f32, 1.0, 0.0, 0.7, 0.5, 1.0], [2, 3]),
        &device,
    );
    let streamed = host(sample_and_fuse(map, &proj, w.clone(), views.size));
    let reference = host(fuse(stacked.clone(), w));
    assert!(
        streamed
            .iter()
            .zip(&reference)
            .all(|(a, b)| (a - b).abs() < 1e-5),
        "{streamed:?} vs {reference:?}"
    );
    let sampled = host(stacked);
    for v in 0..2 {
        for i in 0..2 {
            let at = (v * 3 + i) * 2;
            let (u, y) = (pixels[at], pixels[at + 1]);
            if (2.0..30.0).contains(&u) && (2.0..22.0).contains(&y) {
                assert!(
                    (sampled[at] - u).abs() < 1e-3 && (sampled[at + 1] - y).abs() < 1e-3,
                    "{u} {y} → {} {}",
                    sampled[at],
                    sampled[at + 1]
                );
            }
        }
    }
}

#[test]
fn fusion_weights_follow_eq_4_in_each_variant() {
    let device = Device::flex();
    let (views, centres) = views(&device);
    // Point 0 at the origin facing view 0 (normal −z); point 1 facing view 1 (normal +x).
    let points = Tensor::<2>::from_data(
        TensorData::new(vec![0.0f32, 0.0, 0.0, 0.1, 0.05, 0.0], [2, 3]),
        &device,
    );
    let normals = Tensor::<2>::from_data(
        TensorData::new(vec![0.0f32, 0.0, -1.0, 1.0, 0.0, 0.0], [2, 3]),
        &device,
    );
    let proj = project(points.clone(), &views);
    let w = |variant, depth: Option<Tensor<3>>| {
        host(weights(
            variant,
            points.clone(),
            normals.clone(),
            centres.clone(),
            &proj,
            depth,
            0.01,
        ))
    };
    assert_eq!(w(Fusion::Average, None), vec![1.0; 4]);
    let o = w(Fusion::Orientation, None);
    assert!((o[0] - 1.0).abs() < 1e-6 && o[1] < 0.05, "view 0: {o:?}");
    assert!(o[2] == 0.0 && o[3] > 0.99, "view 1: {o:?}");
    // A wall at z = 2 m in view 0 hides both points there; view 1 sees everything.
    let mut depth = vec![2.0f32; 24 * 32];
    depth.extend(vec![f32::INFINITY; 24 * 32]);
    let depth = Tensor::<3>::from_data(TensorData::new(depth, [2, 24, 32]), &device);
    assert_eq!(
        w(Fusion::Occlusion, Some(depth.clone())),
        vec![0.0, 0.0, 1.0, 1.0]
    );
    let full = w(Fusion::Full, Some(depth));
    assert!(
        full[0] == 0.0 && full[1] == 0.0 && full[2] == 0.0 && full[3] > 0.99,
        "{full:?}"
    );
    // The fused feature is the weighted mean; no weight, no feature.
    let features = Tensor::<3>::from_data(
        TensorData::new(vec![1.0f32, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0], [2, 2, 2]),
        &device,
    );
    let weights_in = Tensor::<2>::from_data(
        TensorData::new(vec![1.0f32, 0.0, 3.0, 0.0], [2, 2]),
        &device,
    );
    let fused = host(fuse(features, weights_in));
    assert_eq!(
        fused,
        vec![(1.0 + 3.0 * 5.0) / 4.0, (2.0 + 3.0 * 6.0) / 4.0, 0.0, 0.0]
    );
}

#[test]
fn fused_features_differentiate_by_finite_differences() {
    let device = Device::flex();
    let (views, centres) = views(&device);
    // A smooth feature map (sin of the image position).
    let (fw, fh) = (8, 6);
    let values: Vec<f32> = (0..fh * fw)
        .map(|i| ((i % fw) as f32 * 0.7).sin() + ((i / fw) as f32 * 0.5).cos())
        .collect();
    let map = Tensor::<4>::from_data(TensorData::new(values, [1, 1, fh, fw]), &device)
        .expand([2, 1, fh, fw]);
    let base = [0.05f32, -0.07, 0.02];
    let value = |p: [f32; 3]| -> f64 {
        let points = Tensor::<2>::from_data(TensorData::new(p.to_vec(), [1, 3]), &device);
        let normals =
            Tensor::<2>::from_data(TensorData::new(vec![0.0f32, 0.0, -1.0], [1, 3]), &device);
        let proj = project(points.clone(), &views);
        let w = weights(
            Fusion::Average,
            points,
            normals,
            centres.clone(),
            &proj,
            None,
            0.01,
        );
        host(fuse(sample(map.clone(), &proj, views.size), w))[0] as f64
    };
    let leaf = Tensor::<2>::from_data(TensorData::new(base.to_vec(), [1, 3]), &device)
        .autodiff()
        .require_grad();
    let normals = Tensor::<2>::from_data(TensorData::new(vec![0.0f32, 0.0, -1.0], [1, 3]), &device)
        .autodiff();
    let proj = project(
        leaf.clone(),
        &Views {
            intrinsics: views.intrinsics.clone().autodiff(),
            world_to_camera: views.world_to_camera.clone().autodiff(),
            size: views.size,
        },
    );
    let w = weights(
        Fusion::Average,
        leaf.clone(),
        normals,
        centres.clone().autodiff(),
        &proj,
        None,
        0.01,
    );
    let out = fuse(sample(map.clone().autodiff(), &proj, views.size), w).sum();
    let grads = out.backward();
    let g = host(leaf.grad(&grads).unwrap());
    for a in 0..3 {
        let h = 1e-3f32;
        let (mut plus, mut minus) = (base, base);
        plus[a] += h;
        minus[a] -= h;
        let fd = (value(plus) - value(minus)) / (2.0 * h as f64);
        assert!(
            (g[a] as f64 - fd).abs() < 2e-2 * fd.abs().max(0.1),
            "axis {a}: {} vs {fd}",
            g[a]
        );
    }
}

#[test]
fn the_decoder_stays_bounded_at_extreme_inputs() {
    let device = Device::flex();
    let decoder = Decoder::new(8, &[16, 16], 0.02, 0.05, &device);
    for scale in [0.0f32, 1.0, 1e3, 1e6, -1e6] {
        let x = Tensor::<2>::from_data(
            TensorData::new(
                (0..40)
                    .map(|i| scale * ((i % 7) as f32 - 3.0))
                    .collect::<Vec<_>>(),
                [5, 8],
            ),
            &device,
        );
        let a = decoder.forward(x);
        let offset = host(a.offset);
        assert!(
            offset.iter().all(|v| v.abs() <= 0.02 + 1e-6),
            "{scale}: {offset:?}"
        );
        let q = host(a.quats);
        for row in q.chunks(4) {
            let n: f32 = row.iter().map(|v| v * v).sum::<f32>().sqrt();
            assert!((n - 1.0).abs() < 1e-4, "{scale}: {row:?}");
        }
        let s = host(a.log_scales);
        assert!(
            s.iter().all(|v| v.is_finite() && *v <= 0.05f32.ln() + 1e-5),
            "{scale}: {s:?}"
        );
        let rgb = host(a.rgb);
        assert!(rgb.iter().all(|v| (0.0..=1.0).contains(v)), "{scale}");
        assert!(
            host(a.opacity_logits).iter().all(|v| !v.is_nan()),
            "{scale}"
        );
    }
}

/// The indexed bilinear sampling against `grid_sample_2d` on fresh random maps and points,
/// including points on the image border, just outside it, and far away: values, gradients with
/// respect to the maps, and gradients with respect to the pixel positions.
#[test]
fn indexed_sampling_matches_grid_sampling() {
    let device = Device::flex();
    let seed = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_nanos() as u64;
    println!("seed {seed}");
    let mut rng = StdRng::seed_from_u64(seed);
    let mut normal = move || -> f32 {
        // Sum of uniforms: close enough to normal for test data.
        (0..6).map(|_| rng.random::<f32>()).sum::<f32>() - 3.0
    };
    let mut rng2 = StdRng::seed_from_u64(seed ^ 0x9e37);
    for (v, c, h, w, size) in [(2, 3, 6, 8, [32, 24]), (1, 5, 7, 5, [21, 28])] {
        let maps: Vec<f32> = (0..v * c * h * w).map(|_| normal()).collect();
        let mut pixels = Vec::new();
        for _ in 0..v {
            for i in 0..40 {
                let (u, y) = match i {
                    0 => (0.0, 0.0),
                    1 => (size[0] as f64, size[1] as f64),
                    2 => (-0.3, 5.0),
                    3 => (size[0] as f64 + 0.2, 3.0),
                    4 => (-1e4, 1e4),
                    _ => (
                        rng2.random_range(-2.0..size[0] as f64 + 2.0),
                        rng2.random_range(-2.0..size[1] as f64 + 2.0),
                    ),
                };
                pixels.extend([u as f32, y as f32]);
            }
        }
        let map = Tensor::<4>::from_data(TensorData::new(maps, [v, c, h, w]), &device);
        let at = Tensor::<3>::from_data(TensorData::new(pixels, [v, 40, 2]), &device);
        let weights: Vec<f32> = (0..v * 40 * c).map(|_| normal()).collect();
        let weights = Tensor::<3>::from_data(TensorData::new(weights, [v, 40, c]), &device);
        let run = |by_grid: bool| {
            let map = map.clone().autodiff().require_grad();
            let at = at.clone().autodiff().require_grad();
            let projection = Projection {
                camera: Tensor::zeros([v, 40, 3], &device).autodiff(),
                pixels: at.clone(),
                inside: Tensor::<2>::zeros([v, 40], &device).greater_elem(1.0),
            };
            let out = if by_grid {
                sample_by_grid(map.clone(), &projection, size)
            } else {
                sample(map.clone(), &projection, size)
            };
            let grads = (out.clone() * weights.clone().autodiff()).sum().backward();
            (
                host(out.inner()),
                host(map.grad(&grads).unwrap()),
                at.grad(&grads).map(host),
            )
        };
        let (fast, fast_map, fast_at) = run(false);
        let (reference, reference_map, reference_at) = run(true);
        let close = |a: &[f32], b: &[f32], what: &str| {
            for (i, (x, y)) in a.iter().zip(b).enumerate() {
                assert!(
                    (x - y).abs() < 1e-4 * (1.0 + y.abs()),
                    "{what}[{i}]: {x} vs {y}"
                );
            }
        };
        close(&fast, &reference, "values");
        close(&fast_map, &reference_map, "map gradient");
        // Burn's grid sampling may not differentiate through the grid; where it does, agree.
        if let (Some(a), Some(b)) = (fast_at, reference_at) {
            close(&a, &b, "position gradient");
        }
    }
}
