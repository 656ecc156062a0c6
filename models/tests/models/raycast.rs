//! The triangle BVH against the brute-force loop on fresh random triangle soups and on the
//! built-in body (a closed surface: every ray from inside leaves through it), hand-made hits,
//! misses, ranges and degenerate triangles.

use crate::common::{SplitMix, fresh_seed};
use splatzoo_models::body::builtin_body;
use splatzoo_models::raycast::{TriangleBvh, first_hit_brute_force, intersect_triangle};

#[test]
fn a_ray_through_a_triangle_hits_it_where_expected_and_misses_otherwise() {
    let tri = [[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0]];
    let t = intersect_triangle([0.25, 0.25, 0.0], [0.0, 0.0, 2.0], tri).unwrap();
    assert!((t - 0.5).abs() < 1e-15, "t in units of |d|: {t}");
    // Behind the origin: a negative t, which the range then excludes.
    let behind = intersect_triangle([0.25, 0.25, 2.0], [0.0, 0.0, 1.0], tri).unwrap();
    assert!((behind + 1.0).abs() < 1e-15);
    assert!(intersect_triangle([0.75, 0.75, 0.0], [0.0, 0.0, 1.0], tri).is_none());
    assert!(intersect_triangle([0.2, 0.2, 0.0], [1.0, 0.0, 0.0], tri).is_none());
    let degenerate = [[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [2.0, 0.0, 1.0]];
    assert!(intersect_triangle([0.5, 0.0, 0.0], [0.0, 0.0, 1.0], degenerate).is_none());
    assert!(intersect_triangle([0.2, 0.2, 0.0], [0.0, 0.0, 0.0], tri).is_none());

    let vertices = tri.to_vec();
    let bvh = TriangleBvh::new(&vertices, &[[0, 1, 2]]);
    assert!(bvh.occluded([0.25, 0.25, 0.0], [0.0, 0.0, 1.0], (1e-9, f64::INFINITY)));
    assert!(!bvh.occluded([0.25, 0.25, 0.0], [0.0, 0.0, 1.0], (1e-9, 0.99)));
    assert!(!bvh.occluded([0.25, 0.25, 2.0], [0.0, 0.0, 1.0], (1e-9, f64::INFINITY)));
    let empty = TriangleBvh::new(&[], &[]);
    assert_eq!(empty.triangle_count(), 0);
    assert!(
        empty
            .first_hit([0.0; 3], [0.0, 0.0, 1.0], (0.0, 1.0))
            .is_none()
    );
}

#[test]
fn the_bvh_finds_the_same_first_hit_as_the_brute_force_loop() {
    let seed = fresh_seed();
    let mut rng = SplitMix(seed);
    // A soup of 600 small triangles in the unit cube, some of them degenerate.
    let mut vertices = Vec::new();
    let mut faces = Vec::new();
    for k in 0..600u32 {
        let c = [rng.unit(), rng.unit(), rng.unit()];
        for _ in 0..3 {
            vertices.push([
                c[0] + 0.1 * rng.signed(),
                c[1] + 0.1 * rng.signed(),
                c[2] + 0.1 * rng.signed(),
            ]);
        }
        if k % 50 == 0 {
            vertices[3 * k as usize + 2] = vertices[3 * k as usize + 1];
        }
        faces.push([3 * k, 3 * k + 1, 3 * k + 2]);
    }
    let bvh = TriangleBvh::new(&vertices, &faces);
    let mut hits = 0;
    for _ in 0..2000 {
        let origin = [
            1.5 * rng.signed() + 0.5,
            1.5 * rng.signed() + 0.5,
            1.5 * rng.signed() + 0.5,
        ];
        // Half the rays aim into the cloud, half go anywhere.
        let direction = if rng.unit() < 0.5 {
            let target = [rng.unit(), rng.unit(), rng.unit()];
            let d = [0, 1, 2].map(|k| target[k] - origin[k]);
            let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt().max(1e-9);
            d.map(|v| v / n)
        } else {
            rng.direction()
        };
        let range = (1e-9, if rng.unit() < 0.3 { 0.7 } else { f64::INFINITY });
        let want = first_hit_brute_force(&vertices, &faces, origin, direction, range);
        let got = bvh.first_hit(origin, direction, range);
        assert_eq!(
            got.map(|h| h.triangle),
            want.map(|h| h.triangle),
            "seed {seed}: {origin:?} {direction:?}"
        );
        if let (Some(g), Some(w)) = (got, want) {
            assert!((g.t - w.t).abs() < 1e-12, "seed {seed}");
        }
        assert_eq!(bvh.occluded(origin, direction, range), want.is_some());
        hits += want.is_some() as usize;
    }
    assert!(
        hits > 200,
        "seed {seed}: only {hits} hits, the test is too easy"
    );
}

#[test]
fn every_ray_from_inside_the_built_in_body_leaves_through_its_surface() {
    let seed = fresh_seed();
    let mut rng = SplitMix(seed);
    let model = &builtin_body().model;
    let vertices: Vec<[f64; 3]> = model
        .template
        .chunks(3)
        .map(|p| [p[0], p[1], p[2]].map(f64::from))
        .collect();
    let faces: Vec<[u32; 3]> = model.faces.chunks(3).map(|f| [f[0], f[1], f[2]]).collect();
    let bvh = TriangleBvh::new(&vertices, &faces);
    // The root joint (the pelvis), regressed from the template, lies inside the body.
    let v = vertices.len();
    let centre: [f64; 3] = std::array::from_fn(|k| {
        (0..v)
            .map(|i| f64::from(model.joint_regressor[i]) * vertices[i][k])
            .sum::<f64>()
    });
    for _ in 0..200 {
        let direction = rng.direction();
        let want =
            first_hit_brute_force(&vertices, &faces, centre, direction, (0.0, f64::INFINITY));
        let got = bvh.first_hit(centre, direction, (0.0, f64::INFINITY));
        assert!(
            got.is_some(),
            "seed {seed}: {direction:?} escaped a closed body"
        );
        assert_eq!(
            got.map(|h| h.triangle),
            want.map(|h| h.triangle),
            "seed {seed}"
        );
    }
    // From far outside, pointing away: nothing.
    assert!(!bvh.occluded([0.0, 0.0, 10.0], [0.0, 0.0, 1.0], (0.0, f64::INFINITY)));
}
