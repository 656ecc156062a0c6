//! The nearest face of a mesh: the closest point of one triangle against dense samples of it
//! (random, needle and point triangles), and the vertex-neighbourhood search against testing
//! every face, on the built-in body at fresh random points near and far from its surface.

use crate::common::{SplitMix, fresh_seed};
use splatzoo_models::body::builtin_body;
use splatzoo_models::closest_face::{FaceIndex, barycentric_point, closest_point_on_triangle};

fn random_point(rng: &mut SplitMix, scale: f64) -> [f64; 3] {
    [0, 1, 2].map(|_| scale * rng.signed())
}

fn dist2(p: [f64; 3], q: [f64; 3]) -> f64 {
    (0..3).map(|k| (p[k] - q[k]).powi(2)).sum()
}

/// The closest point is on the triangle and no sampled point of the triangle is closer, on
/// random and on degenerate (needle, point) triangles.
#[test]
fn closest_point_beats_every_sample_of_the_triangle() {
    let seed = fresh_seed();
    let mut rng = SplitMix(seed);
    for case in 0..200 {
        let a = random_point(&mut rng, 1.0);
        let mut b = random_point(&mut rng, 1.0);
        let mut c = random_point(&mut rng, 1.0);
        if case % 10 == 0 {
            c = [0, 1, 2].map(|k| 0.5 * (a[k] + b[k])); // collinear
        }
        if case % 10 == 1 {
            (b, c) = (a, a); // a point
        }
        let p = random_point(&mut rng, 2.0);
        let (bary, d2) = closest_point_on_triangle(p, a, b, c);
        assert!(bary.iter().all(|w| *w >= -1e-12), "seed {seed}: {bary:?}");
        assert!((bary.iter().sum::<f64>() - 1.0).abs() < 1e-9);
        assert!((dist2(p, barycentric_point(bary, a, b, c)) - d2).abs() < 1e-9);
        for _ in 0..300 {
            let (u, v) = (rng.unit(), rng.unit());
            let (u, v) = if u + v > 1.0 {
                (1.0 - u, 1.0 - v)
            } else {
                (u, v)
            };
            let q = barycentric_point([1.0 - u - v, u, v], a, b, c);
            assert!(dist2(p, q) >= d2 - 1e-9, "seed {seed}, case {case}");
        }
    }
}

/// On the built-in body, the search around the nearest vertices finds a face as near as the
/// brute-force loop's (the same distance; ties between faces sharing the closest point may
/// name either) for points on, near and far from the surface; a mesh without faces and a
/// non-finite point answer `None`.
#[test]
fn the_vertex_search_finds_the_nearest_face_of_the_body() {
    let seed = fresh_seed();
    let mut rng = SplitMix(seed);
    let model = &builtin_body().model;
    let vertices: Vec<[f32; 3]> = model
        .template
        .chunks(3)
        .map(|v| [v[0], v[1], v[2]])
        .collect();
    let faces: Vec<[u32; 3]> = model.faces.chunks(3).map(|f| [f[0], f[1], f[2]]).collect();
    let index = FaceIndex::new(&vertices, &faces);
    assert_eq!(index.face_count(), faces.len());
    for case in 0..300 {
        let anchor = vertices[(rng.unit() * vertices.len() as f64) as usize].map(f64::from);
        let reach = [0.0, 0.01, 0.05, 0.3][case % 4];
        let p: [f64; 3] = std::array::from_fn(|k| anchor[k] + reach * rng.signed());
        let fast = index.nearest(p).unwrap();
        let slow = index.nearest_brute_force(p).unwrap();
        assert!(
            (fast.squared_distance.sqrt() - slow.squared_distance.sqrt()).abs() < 1e-9,
            "seed {seed}, case {case}: {fast:?} against {slow:?}"
        );
        let [a, b, c] = index.corners(fast.face);
        let q = barycentric_point(fast.barycentric, a, b, c);
        assert!((dist2(p, q) - fast.squared_distance).abs() < 1e-12);
    }
    assert!(index.nearest([f64::NAN, 0.0, 0.0]).is_none());
    assert!(FaceIndex::new(&vertices, &[]).nearest([0.0; 3]).is_none());
}
