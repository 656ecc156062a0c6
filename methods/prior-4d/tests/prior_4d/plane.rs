//! The floor plane π: RANSAC against synthetic floors with outliers, the Jacobi eigen-solver
//! against known decompositions, and the initial scale σ₀ against a known σ*.

use crate::Rng;
use glam::{DMat3, DQuat, DVec3, EulerRot};
use splatzoo_prior_4d::Prior4dError;
use splatzoo_prior_4d::plane::{
    Plane, RansacConfig, ScaleFrame, initial_scale, ransac_plane, symmetric_eigen,
};

/// A unit normal within `max_tilt_deg` of +y.
fn tilted_normal(rng: &mut Rng, max_tilt_deg: f64) -> DVec3 {
    let tilt = rng.range(0.0, max_tilt_deg.to_radians());
    let azimuth = rng.range(0.0, std::f64::consts::TAU);
    DVec3::new(
        tilt.sin() * azimuth.cos(),
        tilt.cos(),
        tilt.sin() * azimuth.sin(),
    )
}

/// A floor scene at a scene scale: the true plane, the points and a point 1 m (× scale) above it.
struct Floor {
    truth: Plane,
    points: Vec<[f64; 3]>,
    above: [f64; 3],
}

/// 700 inliers on a 4×4 patch of a random tilted floor (noise σ = 1 mm), then 300 outliers
/// uniform in a 4×4×2 box around the patch, all coordinates × `scale`.
fn floor(rng: &mut Rng, scale: f64) -> Floor {
    let n = tilted_normal(rng, 20.0);
    let d = rng.range(-1.0, 1.0);
    let origin = -d * n;
    let (u, w) = n.any_orthonormal_pair();
    let mut points = Vec::with_capacity(1000);
    for _ in 0..700 {
        let noise = DVec3::new(rng.gauss(), rng.gauss(), rng.gauss()) * 0.001;
        let p = origin + u * rng.range(-2.0, 2.0) + w * rng.range(-2.0, 2.0) + noise;
        points.push((p * scale).to_array());
    }
    for _ in 0..300 {
        let offset = DVec3::new(
            rng.range(-2.0, 2.0),
            rng.range(-1.0, 1.0),
            rng.range(-2.0, 2.0),
        );
        points.push(((origin + offset) * scale).to_array());
    }
    Floor {
        truth: Plane::new(n.to_array(), d * scale).expect("a unit normal"),
        points,
        above: ((origin + n) * scale).to_array(),
    }
}

/// The angle and offset error of `fit` against `floor`'s truth, both oriented towards `above`.
fn errors(fit: &Plane, floor: &Floor) -> (f64, f64) {
    let got = fit.oriented_towards(floor.above);
    let want = floor.truth.oriented_towards(floor.above);
    (got.angle_degrees(&want), (got.offset - want.offset).abs())
}

/// RANSAC recovers a tilted floor from 700 noisy inliers and 300 outliers, at scene scales 1 and 0.7.
#[test]
fn ransac_recovers_a_floor_with_30_percent_outliers() {
    let seed = crate::fresh_seed();
    let mut rng = Rng(seed);
    for scale in [1.0, 0.7] {
        let scene = floor(&mut rng, scale);
        let config = RansacConfig {
            threshold: 0.01 * scale,
            seed,
            ..RansacConfig::default()
        };
        let fit = ransac_plane(&scene.points, &config).expect("a floor");
        let (angle, offset) = errors(&fit.plane, &scene);
        assert!(angle < 0.5, "seed {seed}, scale {scale}: angle {angle}°");
        assert!(
            offset < 0.005 * scale,
            "seed {seed}, scale {scale}: |Δd| {offset}"
        );
        assert!(
            fit.inliers.len() >= 650,
            "seed {seed}, scale {scale}: {} inliers",
            fit.inliers.len()
        );
        assert!(
            fit.rms < 0.003 * scale,
            "seed {seed}, scale {scale}: rms {}",
            fit.rms
        );
    }
}

/// The same points and config give the identical fit; another seed still finds the floor.
#[test]
fn ransac_is_deterministic_for_a_seed() {
    let seed = crate::fresh_seed();
    let mut rng = Rng(seed);
    let scene = floor(&mut rng, 1.0);
    let config = RansacConfig {
        seed,
        ..RansacConfig::default()
    };
    let first = ransac_plane(&scene.points, &config).expect("a floor");
    let again = ransac_plane(&scene.points, &config).expect("a floor");
    assert_eq!(first, again, "seed {seed}");
    let other = RansacConfig {
        seed: seed ^ 0x5DEE_CE66_D1CE_5EED,
        ..config
    };
    let fit = ransac_plane(&scene.points, &other).expect("a floor");
    let (angle, _) = errors(&fit.plane, &scene);
    assert!(
        angle < 0.5,
        "seed {seed}: angle {angle}° with another RANSAC seed"
    );
}

/// Bad ground points or knobs give errors that say what is wrong, never a panic.
#[test]
fn ransac_errors_are_clear() {
    let config = RansacConfig::default();
    let message = |points: &[[f64; 3]], config: &RansacConfig| match ransac_plane(points, config)
        .expect_err("an error")
    {
        Prior4dError::Input { what, problem } => {
            assert_eq!(what, "ground points", "{problem}");
            format!("{what}: {problem}")
        }
        other => panic!("unexpected error {other}"),
    };
    let two = message(&[[0.0; 3], [1.0, 0.0, 0.0]], &config);
    assert!(two.contains('3'), "{two}");

    let line: Vec<[f64; 3]> = (0..10_u32)
        .map(|i| {
            let t = f64::from(i) * 0.1;
            [t, 2.0 * t, -t]
        })
        .collect();
    let collinear = message(&line, &config);
    assert!(collinear.contains("no plane"), "{collinear}");
    let coincident = message(&[[1.0, 2.0, 3.0]; 5], &config);
    assert!(coincident.contains("no plane"), "{coincident}");

    let mut grid: Vec<[f64; 3]> = (0..12_u32)
        .map(|i| [f64::from(i % 4), 0.0, f64::from(i / 4)])
        .collect();
    assert!(ransac_plane(&grid, &config).is_ok());
    grid[7][1] = f64::NAN;
    let nan = message(&grid, &config);
    assert!(nan.contains("point 7"), "{nan}");
    grid[7][1] = 0.0;

    for bad in [
        RansacConfig {
            iterations: 0,
            ..config
        },
        RansacConfig {
            threshold: 0.0,
            ..config
        },
        RansacConfig {
            threshold: f64::NAN,
            ..config
        },
        RansacConfig {
            threshold: f64::INFINITY,
            ..config
        },
    ] {
        let problem = message(&grid, &bad);
        assert!(problem.contains("RANSAC"), "{problem}");
    }
}

/// `Plane::new` normalises the normal and offset, rejects a zero or non-finite normal, and
/// orientation and angles behave.
#[test]
fn plane_normalises_orients_and_measures_angles() {
    let plane = Plane::new([0.0, 2.0, 0.0], 4.0).expect("a plane");
    assert_eq!(
        plane,
        Plane {
            normal: [0.0, 1.0, 0.0],
            offset: 2.0
        }
    );
    assert!((plane.signed_distance([5.0, 1.0, -3.0]) - 3.0).abs() < 1e-15);
    let flipped = plane.oriented_towards([0.0, -5.0, 0.0]);
    assert_eq!(
        flipped,
        Plane {
            normal: [0.0, -1.0, 0.0],
            offset: -2.0
        }
    );
    assert_eq!(flipped.oriented_towards([0.0, -5.0, 0.0]), flipped);
    assert!((plane.angle_degrees(&flipped) - 180.0).abs() < 1e-12);
    assert!(plane.angle_degrees(&plane).abs() < 1e-12);
    assert!(Plane::new([0.0; 3], 1.0).is_err());
    assert!(Plane::new([f64::NAN, 1.0, 0.0], 1.0).is_err());
    assert!(Plane::new([0.0, 1.0, 0.0], f64::INFINITY).is_err());
}

/// Checks `symmetric_eigen(m)` against the eigenvalues `lambda` of `m`.
fn check_eigen(m: DMat3, lambda: [f64; 3], context: &str) {
    let (values, vectors) = symmetric_eigen(m.to_cols_array_2d());
    let mut expected = lambda;
    expected.sort_by(f64::total_cmp);
    let tolerance = 1e-12 * lambda.iter().fold(1.0_f64, |a, l| a.max(l.abs()));
    assert!(
        values[0] <= values[1] && values[1] <= values[2],
        "{context}: {values:?}"
    );
    for ((value, want), vector) in values.iter().zip(&expected).zip(&vectors) {
        assert!(
            (value - want).abs() <= tolerance,
            "{context}: {values:?} vs {expected:?}"
        );
        let v = DVec3::from(*vector);
        assert!(
            (v.length() - 1.0).abs() < 1e-12,
            "{context}: ‖v‖ = {}",
            v.length()
        );
        let residual = (m * v - v * *value).length();
        assert!(residual < 1e-10, "{context}: ‖M v − λ v‖ = {residual}");
    }
    let q = DMat3::from_cols(vectors[0].into(), vectors[1].into(), vectors[2].into());
    let gram = q.transpose() * q - DMat3::IDENTITY;
    assert!(
        gram.abs().to_cols_array().iter().all(|e| *e < 1e-12),
        "{context}: QᵀQ − I = {gram}"
    );
}

/// The Jacobi solver recovers M = Q diag(λ) Qᵀ's λ and eigenvectors, with repeated and zero
/// eigenvalues and the zero matrix.
#[test]
fn symmetric_eigen_matches_a_known_decomposition() {
    let seed = crate::fresh_seed();
    let mut rng = Rng(seed);
    for trial in 0..40 {
        let quat = DQuat::from_xyzw(rng.gauss(), rng.gauss(), rng.gauss(), rng.gauss());
        let q = DMat3::from_quat(quat.normalize());
        let mut lambda = [
            rng.range(-5.0, 5.0),
            rng.range(-5.0, 5.0),
            rng.range(-5.0, 5.0),
        ];
        match trial % 4 {
            1 => lambda[1] = lambda[0],
            2 => lambda = [lambda[0]; 3],
            3 => lambda[2] = 0.0,
            _ => {}
        }
        let m = q * DMat3::from_diagonal(DVec3::from(lambda)) * q.transpose();
        check_eigen(
            m,
            lambda,
            &format!("seed {seed}, trial {trial}, λ {lambda:?}"),
        );
    }
    check_eigen(DMat3::ZERO, [0.0; 3], "zero matrix");
    let diagonal = [3.0, -1.0, 2.0];
    check_eigen(
        DMat3::from_diagonal(DVec3::from(diagonal)),
        diagonal,
        "diagonal",
    );
}

/// One synthetic frame for `initial_scale`, owning its feet.
struct Shot {
    rotation: [[f64; 3]; 3],
    centre: [f64; 3],
    feet: Vec<[f64; 3]>,
}

/// Ten frames over `plane`: per frame 25 foot points on the floor and 35 raised 0.5–5 cm (all
/// raised 10 cm more in `lifted` frames), seen by a camera at a height in `heights` with a random
/// yaw and a 10–25° downward pitch, in camera-space body units v = Rᵀ(x − c)/σ*.
fn shots(
    rng: &mut Rng,
    plane: &Plane,
    sigma: f64,
    heights: (f64, f64),
    lifted: &[usize],
) -> Vec<Shot> {
    let n = DVec3::from(plane.normal);
    let origin = -plane.offset * n;
    let (u, w) = n.any_orthonormal_pair();
    let mut shots = Vec::new();
    for t in 0..10 {
        let person = origin + u * rng.range(-1.0, 1.0) + w * rng.range(-1.0, 1.0);
        let lift = if lifted.contains(&t) { 0.1 } else { 0.0 };
        let rotation = DMat3::from_euler(
            EulerRot::YXZ,
            rng.range(0.0, std::f64::consts::TAU),
            rng.range(-25.0_f64, -10.0).to_radians(),
            0.0,
        );
        // Back the camera off from the person along its horizontal viewing direction.
        let forward = rotation * DVec3::Z;
        let horizontal = (forward - n * n.dot(forward)).normalize_or(u);
        let centre =
            person - horizontal * rng.range(2.0, 4.0) + n * rng.range(heights.0, heights.1);
        let mut feet = Vec::with_capacity(60);
        for i in 0..60 {
            let raise = if i < 25 { 0.0 } else { rng.range(0.005, 0.05) };
            let x = person
                + u * rng.range(-0.15, 0.15)
                + w * rng.range(-0.15, 0.15)
                + n * (raise + lift);
            feet.push((rotation.transpose() * (x - centre) / sigma).to_array());
        }
        shots.push(Shot {
            rotation: rotation.transpose().to_cols_array_2d(),
            centre: centre.to_array(),
            feet,
        });
    }
    shots
}

/// Borrowed views of `shots` for `initial_scale`.
fn views(shots: &[Shot]) -> Vec<ScaleFrame<'_>> {
    shots
        .iter()
        .map(|s| ScaleFrame {
            rotation: s.rotation,
            centre: s.centre,
            feet: &s.feet,
        })
        .collect()
}

/// σ₀ equals σ* on noise-free frames over a tilted floor, and the median shrugs off 3 of 10
/// frames with a lifted foot.
#[test]
fn initial_scale_recovers_the_true_scale() {
    let seed = crate::fresh_seed();
    let mut rng = Rng(seed);
    let sigma = 0.7;
    let n = tilted_normal(&mut rng, 10.0);
    let plane = Plane::new(n.to_array(), rng.range(-0.5, 0.5)).expect("a unit normal");
    let exact = shots(&mut rng, &plane, sigma, (1.0, 1.7), &[]);
    let got = initial_scale(&plane, &views(&exact), 25).expect("usable frames");
    assert!(
        ((got - sigma) / sigma).abs() < 1e-9,
        "seed {seed}: σ₀ {got} vs σ* {sigma}"
    );
    let lifted = shots(&mut rng, &plane, sigma, (1.0, 1.7), &[1, 4, 8]);
    let got = initial_scale(&plane, &views(&lifted), 25).expect("usable frames");
    assert!(
        ((got - sigma) / sigma).abs() < 0.02,
        "seed {seed}: σ₀ {got} vs σ* {sigma} with lifted feet"
    );
}

/// A zero contact count, a frame short of feet and cameras under the floor give clear errors.
#[test]
fn initial_scale_errors_are_clear() {
    let seed = crate::fresh_seed();
    let mut rng = Rng(seed);
    let plane = Plane::new([0.0, 1.0, 0.0], 0.0).expect("a plane");
    let good = shots(&mut rng, &plane, 0.7, (1.0, 1.7), &[]);
    let zero = initial_scale(&plane, &views(&good), 0).expect_err("zero contacts");
    assert!(zero.to_string().contains("contact_count"), "{zero}");
    let mut short = views(&good);
    short[3].feet = &good[3].feet[..5];
    let few = initial_scale(&plane, &short, 25).expect_err("a frame with 5 feet");
    assert!(few.to_string().contains("frame 3"), "seed {seed}: {few}");
    let below = shots(&mut rng, &plane, 0.7, (-1.7, -1.0), &[]);
    let none = initial_scale(&plane, &views(&below), 25).expect_err("cameras under the floor");
    assert!(none.to_string().contains("no frame"), "seed {seed}: {none}");
    let empty = initial_scale(&plane, &[], 25).expect_err("no frames");
    assert!(empty.to_string().contains("no frame"), "{empty}");
}
