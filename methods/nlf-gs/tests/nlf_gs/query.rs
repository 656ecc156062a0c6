//! NLF-GS's query and fusion (Eq. 2–4) against scalar formulas: projection, the pixel-centre
//! convention of the sampling, each fusion variant's weights, the weighted mean, gradients by
//! finite differences; and the decoder's bounds at extreme inputs.
#![allow(clippy::needless_range_loop)] // the f64 references mirror the equations index by index

use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_datasets::synth::rng::Rng;
use splatzoo_nlf_gs::decoder::Decoder;
use splatzoo_nlf_gs::query::{
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
    let seed = crate::fresh_seed();
    println!("seed {seed}");
    let mut rng = Rng(seed);
    let mut normal = move || -> f32 {
        // Sum of uniforms: close enough to normal for test data.
        (0..6).map(|_| rng.next() as f32).sum::<f32>() - 3.0
    };
    let mut rng2 = Rng(seed ^ 0x9e37);
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
                        rng2.range(-2.0, size[0] as f64 + 2.0),
                        rng2.range(-2.0, size[1] as f64 + 2.0),
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

/// The occlusion test of Eq. 4 on a depth map that varies differently along rows and columns
/// (H = 24 ≠ W = 32, different per view, with empty pixels at ∞): each point's weight comes from
/// the depth pixel under its own projection, `depth[v][⌊y⌋][⌊u⌋]`, compared with a scalar f64
/// computation for every variant, and the fused features with it. The same data give other
/// weights under a transposed lookup (axes or strides swapped), so such a bug cannot pass.
#[test]
fn occlusion_reads_the_depth_pixel_under_each_projection() {
    let device = Device::flex();
    let (views, centres) = views(&device);
    let seed = crate::fresh_seed();
    println!("seed {seed}");
    let mut rng = Rng(seed);
    let [width, height] = views.size;
    assert_ne!(width, height, "the test needs a non-square image");
    // The cameras of `views`, in f64.
    let k = [[40.0f64, 42.0, 16.0, 12.0], [50.0, 50.0, 16.5, 11.5]];
    let r: [[[f64; 3]; 3]; 2] = [
        [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        [[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]],
    ];
    let t = [[0.0f64, 0.0, 3.0], [0.0, 0.0, 3.0]];
    let camera_centres = [[0.0f64, 0.0, -3.0], [3.0, 0.0, 0.0]];
    let tolerance = 0.01f64;
    // Depth: a different slope along rows and columns, per view, with holes.
    let depth_at = |v: usize, row: usize, col: usize| -> f32 {
        if (row + 2 * col + 3 * v).is_multiple_of(13) {
            f32::INFINITY
        } else if v == 0 {
            2.0 + 0.09 * row as f32 + 0.025 * col as f32
        } else {
            2.2 + 0.04 * row as f32 + 0.06 * col as f32
        }
    };
    let mut depth = Vec::with_capacity(2 * height * width);
    for v in 0..2 {
        for row in 0..height {
            for col in 0..width {
                depth.push(depth_at(v, row, col));
            }
        }
    }
    let camera = |v: usize, p: [f64; 3]| -> [f64; 3] {
        std::array::from_fn(|a| (0..3).map(|b| r[v][a][b] * p[b]).sum::<f64>() + t[v][a])
    };
    let pixel = |v: usize, c: [f64; 3]| -> [f64; 2] {
        [
            k[v][0] * c[0] / c[2] + k[v][2],
            k[v][1] * c[1] / c[2] + k[v][3],
        ]
    };
    let inside = |c: [f64; 3], [u, y]: [f64; 2]| {
        c[2] > 1e-6 && (0.0..width as f64).contains(&u) && (0.0..height as f64).contains(&y)
    };
    // The surface depth under pixel (u, y): lookup 0 is the definition (row from y, column
    // from u, row-major [H, W]); 1 swaps the axes; 2 swaps the strides (reads [W, H]).
    let surface = |v: usize, u: f64, y: f64, lookup: usize| -> f64 {
        let plane = &depth[v * height * width..(v + 1) * height * width];
        let clamp = |x: f64, n: usize| x.floor().clamp(0.0, (n - 1) as f64) as usize;
        let index = match lookup {
            0 => clamp(y, height) * width + clamp(u, width),
            1 => clamp(u, height) * width + clamp(y, width),
            _ => clamp(u, width) * height + clamp(y, height),
        };
        plane[index] as f64
    };
    // Random points, kept only where f32 rounding cannot change the answer: away from pixel
    // edges (so from the image border too) and from the occlusion threshold.
    let n = 48;
    let mut points: Vec<[f32; 3]> = Vec::with_capacity(n);
    let mut normals: Vec<[f32; 3]> = Vec::with_capacity(n);
    while points.len() < n {
        let p = [
            rng.range(-0.8, 0.8) as f32,
            rng.range(-0.8, 0.8) as f32,
            rng.range(-0.4, 0.4) as f32,
        ];
        let pd = p.map(f64::from);
        let clear = (0..2).all(|v| {
            let c = camera(v, pd);
            let [u, y] = pixel(v, c);
            let off_edge = |x: f64| (x - x.round()).abs() > 0.02;
            if !(off_edge(u) && off_edge(y)) {
                return false;
            }
            if !inside(c, [u, y]) {
                return true;
            }
            let s = surface(v, u, y, 0);
            !s.is_finite() || (c[2] - s * (1.0 + tolerance)).abs() > 1e-3 * s
        });
        if clear {
            points.push(p);
            let q = [rng.normal(), rng.normal(), rng.normal()];
            let len = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt().max(1e-9);
            normals.push(q.map(|a| (a / len) as f32));
        }
    }
    let expected = |variant: Fusion, lookup: usize| -> Vec<f64> {
        let mut out = Vec::with_capacity(2 * n);
        for v in 0..2 {
            for (p, normal) in points.iter().zip(&normals) {
                let pd = p.map(f64::from);
                let c = camera(v, pd);
                let [u, y] = pixel(v, c);
                let mut w = if inside(c, [u, y]) { 1.0 } else { 0.0 };
                if matches!(variant, Fusion::Orientation | Fusion::Full) {
                    let d: [f64; 3] = std::array::from_fn(|a| camera_centres[v][a] - pd[a]);
                    let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                    let cos = (0..3).map(|a| d[a] / len * normal[a] as f64).sum::<f64>();
                    w *= cos.max(0.0);
                }
                if matches!(variant, Fusion::Occlusion | Fusion::Full)
                    && c[2] > surface(v, u, y, lookup) * (1.0 + tolerance)
                {
                    w = 0.0;
                }
                out.push(w);
            }
        }
        out
    };
    let points_t = Tensor::<2>::from_data(TensorData::new(points.concat(), [n, 3]), &device);
    let normals_t = Tensor::<2>::from_data(TensorData::new(normals.concat(), [n, 3]), &device);
    let depth_t =
        Tensor::<3>::from_data(TensorData::new(depth.clone(), [2, height, width]), &device);
    let proj = project(points_t.clone(), &views);
    let run = |variant: Fusion| {
        weights(
            variant,
            points_t.clone(),
            normals_t.clone(),
            centres.clone(),
            &proj,
            Some(depth_t.clone()),
            tolerance,
        )
    };
    for variant in [
        Fusion::Average,
        Fusion::Occlusion,
        Fusion::Orientation,
        Fusion::Full,
    ] {
        let got = host(run(variant));
        let want = expected(variant, 0);
        assert_eq!(got.len(), want.len());
        for (i, (g, w)) in got.iter().zip(&want).enumerate() {
            assert!(
                (*g as f64 - w).abs() < 1e-5,
                "{variant:?}, view {}, point {}: {g} vs {w} (seed {seed})",
                i / n,
                i % n
            );
        }
    }
    // The data exercise the test: inside points both seen and hidden, and a transposed lookup
    // would give different weights.
    let seen = expected(Fusion::Average, 0);
    let occlusion = expected(Fusion::Occlusion, 0);
    let visible = (0..2 * n)
        .filter(|&i| seen[i] == 1.0 && occlusion[i] == 1.0)
        .count();
    let hidden = (0..2 * n)
        .filter(|&i| seen[i] == 1.0 && occlusion[i] == 0.0)
        .count();
    assert!(
        visible > 0 && hidden > 0,
        "{visible} visible, {hidden} hidden (seed {seed})"
    );
    for lookup in [1, 2] {
        let swapped = expected(Fusion::Occlusion, lookup);
        let differ = occlusion
            .iter()
            .zip(&swapped)
            .filter(|(a, b)| a != b)
            .count();
        assert!(
            differ > 0,
            "lookup {lookup} gives the same weights (seed {seed})"
        );
    }
    // The fused features with the full weights: Σ_v w_v q_v / Σ_v w_v, q_v bilinear samples
    // (zero padding) of per-view random maps at the image's resolution.
    let features: Vec<f32> = (0..2 * height * width)
        .map(|_| rng.normal() as f32)
        .collect();
    let bilinear = |v: usize, u: f64, y: f64| -> f64 {
        let (x, yy) = (u - 0.5, y - 0.5);
        let (x0, y0) = (x.floor(), yy.floor());
        let mut acc = 0.0;
        for (dx, dy) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)] {
            let (xi, yi): (f64, f64) = (x0 + dx, y0 + dy);
            if xi < 0.0 || yi < 0.0 || xi >= width as f64 || yi >= height as f64 {
                continue;
            }
            let weight = (1.0 - (x - xi).abs()) * (1.0 - (yy - yi).abs());
            acc += weight * features[(v * height + yi as usize) * width + xi as usize] as f64;
        }
        acc
    };
    let full = expected(Fusion::Full, 0);
    let fused = host(sample_and_fuse(
        Tensor::<4>::from_data(
            TensorData::new(features.clone(), [2, 1, height, width]),
            &device,
        ),
        &proj,
        run(Fusion::Full),
        views.size,
    ));
    for (i, p) in points.iter().enumerate() {
        let pd = p.map(f64::from);
        let (mut sum, mut total) = (0.0, 0.0);
        for v in 0..2 {
            let [u, y] = pixel(v, camera(v, pd));
            sum += full[v * n + i] * bilinear(v, u, y);
            total += full[v * n + i];
        }
        let want = sum / total.max(1e-6);
        assert!(
            (fused[i] as f64 - want).abs() < 1e-4 * (1.0 + want.abs()),
            "point {i}: fused {} vs {want} (seed {seed})",
            fused[i]
        );
    }
}
