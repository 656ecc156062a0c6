//! Stage 2's lighting pipeline: the KNN transfer (weights summing to one, a Gaussian on a
//! vertex reading that vertex, constants kept, the neighbours the brute-force search finds),
//! the hand-over identity (unit light, no visibility, no specular, `b = sRGB⁻¹(c)` gives back
//! `c`: spec check 10 per Gaussian), linearity in the probes' SH, and visibility 0 gives black.

use crate::{Rng, fresh_seed, values};
use burn::module::Param;
use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_illum::light_volume::{LightVolume, ProbeGrid};
use splatzoo_illum::lighting::{
    KnnTransfer, LitGaussians, Material, SamplingConfig, shade_gaussians,
};
use splatzoo_illum::pbr::{Shading, linear_to_srgb, srgb_to_linear};
use splatzoo_illum::sampling::HemisphereRule;
use splatzoo_models::knn::k_nearest_brute_force;

fn tensor2(rows: &[[f32; 3]], device: &Device) -> Tensor<2> {
    Tensor::<2>::from_data(
        TensorData::new(
            rows.iter().flatten().copied().collect::<Vec<_>>(),
            [rows.len(), 3],
        ),
        device,
    )
}

fn random_points(rng: &mut Rng, n: usize, spread: f64) -> Vec<[f32; 3]> {
    (0..n)
        .map(|_| std::array::from_fn(|_| rng.range(-spread, spread) as f32))
        .collect()
}

#[test]
fn the_knn_transfer_blends_the_nearest_vertices() {
    let seed = fresh_seed();
    let mut rng = Rng(seed);
    let device = Device::flex();
    let vertices = random_points(&mut rng, 300, 1.0);
    let mut points = random_points(&mut rng, 50, 1.1);
    points.push(vertices[17]);
    let transfer = KnnTransfer::new(&points, &vertices, 3, &device);
    assert_eq!(transfer.len(), points.len());
    let weights = values(transfer.weights.clone());
    for row in weights.chunks(3) {
        assert!((row.iter().sum::<f32>() - 1.0).abs() < 1e-5, "seed {seed}");
        assert!(
            row.windows(2).all(|w| w[0] >= w[1]),
            "nearest first: {row:?}"
        );
    }
    let indices: Vec<i64> = transfer
        .indices
        .clone()
        .into_data()
        .convert::<i64>()
        .try_into_vec::<i64>()
        .unwrap();
    for (i, p) in points.iter().enumerate() {
        let want: Vec<i64> = k_nearest_brute_force(&vertices, *p, 3, None)
            .iter()
            .map(|&(j, _)| j as i64)
            .collect();
        assert_eq!(
            &indices[i * 3..i * 3 + 3],
            &want[..],
            "seed {seed}: point {i}"
        );
    }
    // A field of values [V, 2]: a constant column stays constant, and the Gaussian on vertex
    // 17 reads vertex 17.
    let field: Vec<f32> = (0..300).flat_map(|v| [0.25, v as f32]).collect();
    let blended = values(transfer.apply(Tensor::<2>::from_data(
        TensorData::new(field, [300, 2]),
        &device,
    )));
    for row in blended.chunks(2) {
        assert!((row[0] - 0.25).abs() < 1e-6);
    }
    assert!(
        (blended[blended.len() - 1] - 17.0).abs() < 1e-3,
        "seed {seed}"
    );
}

/// A volume over the cube `[-1.5, 1.5]³`.
fn volume(device: &Device) -> LightVolume {
    let grid = ProbeGrid::covering([-1.0; 3], [1.0; 3], 0.5, 0.5, 32).expect("a grid");
    LightVolume::new(grid, 2, 8, 1, device).expect("a volume")
}

fn gaussians(rng: &mut Rng, albedo: Tensor<2>, device: &Device) -> LitGaussians {
    let n = albedo.dims()[0];
    let normals: Vec<[f32; 3]> = (0..n)
        .map(|_| {
            let v: [f64; 3] = std::array::from_fn(|_| rng.gauss());
            let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt().max(1e-9);
            v.map(|x| (x / l) as f32)
        })
        .collect();
    LitGaussians {
        points: tensor2(&random_points(rng, n, 1.0), device),
        normals: tensor2(&normals, device),
        material: Material {
            albedo,
            metallic: Tensor::<2>::zeros([n, 1], device),
            roughness: Tensor::<2>::full([n, 1], 0.5, device),
        },
        camera_centre: [0.3, 0.5, 4.0],
        azimuth_offsets: None,
    }
}

#[test]
fn unit_light_without_specular_hands_over_the_stage_one_colour() {
    let seed = fresh_seed();
    let mut rng = Rng(seed);
    let device = Device::flex();
    let colours: Vec<[f32; 3]> = (0..64)
        .map(|_| std::array::from_fn(|_| rng.range(0.02, 0.98) as f32))
        .collect();
    let stage1 = tensor2(&colours, &device);
    let lit = gaussians(&mut rng, srgb_to_linear(stage1.clone()), &device);
    let sampling = SamplingConfig {
        count: 32,
        rule: HemisphereRule::Midpoint,
    };
    let linear = shade_gaussians(
        &volume(&device),
        lit,
        sampling,
        |directions| {
            assert_eq!(directions.dims(), [64, 32, 3]);
            None
        },
        &Shading { specular: false },
    );
    let got = values(linear_to_srgb(linear));
    let want = values(stage1);
    let worst = got
        .iter()
        .zip(&want)
        .map(|(g, w)| (g - w).abs())
        .fold(0.0f32, f32::max);
    assert!(worst < 2e-4, "seed {seed}: worst {worst}");
}

#[test]
fn shading_is_linear_in_the_probes_and_blocked_light_is_black() {
    let seed = fresh_seed();
    let mut rng = Rng(seed);
    let device = Device::flex();
    let albedo = Tensor::<2>::full([40, 3], 0.6, &device);
    let lit = gaussians(&mut rng, albedo, &device);
    let sampling = SamplingConfig {
        count: 16,
        rule: HemisphereRule::Midpoint,
    };
    let mut light = volume(&device);
    // A random but positive light: a strong DC and small higher bands.
    let [p, k, c] = light.sh.dims();
    let sh: Vec<f32> = (0..p * k * c)
        .map(|i| {
            if (i / c) % k == 0 {
                4.0
            } else {
                rng.range(-0.3, 0.3) as f32
            }
        })
        .collect();
    light.sh = Param::from_tensor(Tensor::<3>::from_data(
        TensorData::new(sh, [p, k, c]),
        &device,
    ));
    let shading = Shading::default();
    let once = values(shade_gaussians(
        &light,
        lit.clone(),
        sampling,
        |_| None,
        &shading,
    ));
    let doubled_sh = light.sh.val() * 2.0;
    light.sh = Param::from_tensor(doubled_sh);
    let twice = values(shade_gaussians(
        &light,
        lit.clone(),
        sampling,
        |_| None,
        &shading,
    ));
    for (a, b) in once.iter().zip(&twice) {
        assert!(
            (2.0 * a - b).abs() <= 1e-4 * b.abs().max(1.0),
            "seed {seed}: {a} {b}"
        );
    }
    assert!(
        once.iter().any(|&v| v > 0.05),
        "seed {seed}: the light reaches the Gaussians"
    );
    let blocked = values(shade_gaussians(
        &light,
        lit,
        sampling,
        |d| {
            let [n, s, _] = d.dims();
            Some(Tensor::<2>::zeros([n, s], &d.device()))
        },
        &shading,
    ));
    assert!(blocked.iter().all(|&v| v == 0.0));
}
