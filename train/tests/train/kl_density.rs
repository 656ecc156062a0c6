//! GauHuman's KL density control: the closed-form divergence against the isotropic formula,
//! its invariance under a shared rotation and zero on identical Gaussians; a decision merges
//! a duplicated pair, grows an isolated Gaussian the image pulls on, leaves a redundant one
//! that the image also pulls on, prunes a transparent one, records the lineage, and with the
//! body's mesh given prunes the Gaussians off it.

use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_datasets::synth::rng::Rng;
use splatzoo_models::closest_face::FaceIndex;
use splatzoo_models::rotation_scalar::quaternion_matrix;
use splatzoo_train::densify::kl::{GaussianShape, SurfacePrune, gaussian_kl, kl_density_control};
use splatzoo_train::densify::strategy::RowEdit;
use splatzoo_train::densify::{DensifyConfig, DensifyReport, DensityStats, Strategy};
use splatzoo_train::gaussians::GaussianSet;
use splatzoo_train::optimizer::{GaussianOptimizer, LearningRates};

fn seed() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_nanos() as u64
}

fn isotropic(mean: [f64; 3], s: f64) -> GaussianShape {
    GaussianShape {
        mean,
        scale: [s; 3],
        rotation: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
    }
}

#[test]
fn the_divergence_matches_its_isotropic_form_and_ignores_a_shared_rotation() {
    let seed = seed();
    let mut rng = Rng(seed);
    for _ in 0..20 {
        let (s0, s1) = (rng.range(0.01, 0.3), rng.range(0.01, 0.3));
        let m0 = [0; 3].map(|_| rng.range(-0.5, 0.5));
        let m1 = [0; 3].map(|_| rng.range(-0.5, 0.5));
        let d2: f64 = (0..3).map(|a| (m1[a] - m0[a]).powi(2)).sum();
        let expected =
            0.5 * (3.0 * s0 * s0 / (s1 * s1) + d2 / (s1 * s1) - 3.0 + 6.0 * (s1 / s0).ln());
        let kl = gaussian_kl(&isotropic(m0, s0), &isotropic(m1, s1));
        assert!(
            (kl - expected).abs() <= 1e-9 * expected.abs().max(1.0),
            "seed {seed}: {kl} vs {expected}"
        );
        assert!(gaussian_kl(&isotropic(m0, s0), &isotropic(m0, s0)).abs() < 1e-12);

        // Anisotropic pair, both turned by the same rotation about the origin: same value.
        let shape = |rng: &mut Rng| GaussianShape {
            mean: [0; 3].map(|_| rng.range(-0.5, 0.5)),
            scale: [0; 3].map(|_| rng.range(0.01, 0.3)),
            rotation: quaternion_matrix([0; 4].map(|_| rng.range(-1.0, 1.0))),
        };
        let (p, q) = (shape(&mut rng), shape(&mut rng));
        let turn = quaternion_matrix([0; 4].map(|_| rng.range(-1.0, 1.0)));
        let apply = |g: &GaussianShape| GaussianShape {
            mean: std::array::from_fn(|a| (0..3).map(|b| turn[a][b] * g.mean[b]).sum()),
            rotation: std::array::from_fn(|a| {
                std::array::from_fn(|c| (0..3).map(|b| turn[a][b] * g.rotation[b][c]).sum())
            }),
            ..*g
        };
        let (before, after) = (gaussian_kl(&p, &q), gaussian_kl(&apply(&p), &apply(&q)));
        assert!(before > 0.0);
        assert!(
            (before - after).abs() <= 1e-9 * before.max(1.0),
            "seed {seed}: {before} vs {after}"
        );
    }
    // A flat Gaussian gives a large finite value, not NaN.
    let flat = GaussianShape {
        scale: [0.1, 0.1, 0.0],
        ..isotropic([0.0; 3], 0.1)
    };
    let kl = gaussian_kl(&isotropic([0.0; 3], 0.1), &flat);
    assert!(kl.is_finite() && kl > 1e6, "{kl}");
}

/// One KL decision on `set` (extent 1) with every Gaussian pulled on by the image (a mean
/// screen gradient of 1); the report and the lineage.
fn decide(
    config: &DensifyConfig,
    set: &mut GaussianSet,
    surface: Option<&SurfacePrune>,
) -> (DensifyReport, Vec<usize>) {
    let device = set.means.device();
    let n = set.len();
    let mut optimizer = GaussianOptimizer::new(set, LearningRates::default(), 1.0);
    let mut stats = DensityStats::new(n, &device);
    stats.grad_sum = Tensor::full([n], 1.0, &device);
    stats.count = Tensor::full([n], 1.0, &device);
    let mut lineage = Vec::new();
    let report = kl_density_control(
        config,
        RowEdit {
            set,
            optimizer: &mut optimizer,
            rng: &mut Rng(3),
            step: 1,
            progress: 0.0,
            old_from_new: &mut lineage,
        },
        &mut stats,
        1.0,
        surface,
    );
    (report, lineage)
}

#[test]
fn a_decision_merges_twins_grows_the_isolated_and_prunes_the_transparent() {
    let device = Device::flex();
    // 0 and 1: identical twins; 2: alone, far away; 3: transparent; 4 and 5: a near pair
    // (KL between the thresholds: neither merged nor grown).
    let positions = [
        [0.0, 0.0, 0.0],
        [0.0, 0.0, 0.0],
        [5.0, 0.0, 0.0],
        [-5.0, 0.0, 0.0],
        [0.0, 5.0, 0.0],
        [0.0, 5.0, 0.03],
    ];
    let colours = [
        [0.2, 0.4, 0.6],
        [0.6, 0.4, 0.2],
        [0.5; 3],
        [0.5; 3],
        [0.5; 3],
        [0.5; 3],
    ];
    let mut set = GaussianSet::from_points(&positions, &colours, &[0.05; 6], &device);
    let opacity = [2.0f32, 2.0, 2.0, -9.0, 2.0, 2.0];
    set.opacity_logits = Tensor::from_data(TensorData::new(opacity.to_vec(), [6]), &device);
    let config = DensifyConfig {
        strategy: Strategy::Kl,
        grad_threshold: 1e-3,
        percent_dense: 0.1,
        ..DensifyConfig::default()
    };
    let (report, lineage) = decide(&config, &mut set, None);
    // KL(4 → 5) = ½ · 0.03² / 0.05² = 0.18: between 0.1 and 0.4.
    assert_eq!(report.merged, 1, "{report:?}");
    assert_eq!(report.pruned, 1, "{report:?}");
    assert_eq!(report.cloned, 1, "{report:?}");
    assert_eq!(report.split, 0, "{report:?}");
    // Kept: 2, 4, 5; added: the merged twin (from 0) and the clone of 2.
    assert_eq!(lineage, vec![2, 4, 5, 0, 2]);
    assert_eq!(set.len(), 5);
    let dc = splatzoo_train::host_f32(&set.sh_dc);
    let merged = &dc[9..12];
    let expected = splatzoo_train::host_f32(
        &GaussianSet::from_points(&[[0.0; 3]], &[[0.4, 0.4, 0.4]], &[0.05], &device).sh_dc,
    );
    for (a, b) in merged.iter().zip(&expected) {
        assert!(
            (a - b).abs() < 1e-6,
            "merged colour {merged:?} vs {expected:?}"
        );
    }
}

/// With the surface given, a decision prunes exactly the centres farther than `max_distance`
/// from the mesh (above the square, beside it, far off), counted as off the surface, and keeps
/// those near it; without it (the case above) none goes for its distance.
#[test]
fn a_decision_prunes_the_gaussians_off_the_mesh() {
    let device = Device::flex();
    // A unit square at z = 0 from two triangles.
    let vertices = [
        [0.0f32, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ];
    let surface = SurfacePrune {
        mesh: FaceIndex::new(&vertices, &[[0, 1, 2], [0, 2, 3]]),
        max_distance: 0.1,
    };
    // Kept: on it, 0.09 above it, 0.05 past its edge; pruned: 0.2 above, 0.3 past the corner,
    // far away.
    let positions = [
        [0.5, 0.5, 0.0],
        [0.2, 0.7, 0.09],
        [1.05, 0.5, 0.0],
        [0.5, 0.2, 0.2],
        [1.3, 1.0, 0.0],
        [9.0, 9.0, 9.0],
    ];
    let mut set = GaussianSet::from_points(&positions, &[[0.5; 3]; 6], &[0.05; 6], &device);
    let config = DensifyConfig {
        strategy: Strategy::Kl,
        // No growth: only the prune acts.
        grad_threshold: 1e9,
        ..DensifyConfig::default()
    };
    let (report, lineage) = decide(&config, &mut set, Some(&surface));
    assert_eq!((report.pruned, report.off_surface), (3, 3), "{report:?}");
    assert_eq!(lineage, vec![0, 1, 2]);
    assert_eq!(set.len(), 3);
}
