//! The k-nearest-neighbour index against sorting every distance: clustered clouds with far
//! outliers and duplicates, queries inside and far outside the cloud, a skipped self, `k`
//! beyond the cloud's size, and an empty cloud.

use crate::common::{SplitMix, fresh_seed};
use splatzoo_models::knn::{PointIndex, k_nearest_brute_force};

#[test]
fn the_index_finds_the_same_neighbours_as_sorting_every_distance() {
    let seed = fresh_seed();
    let mut rng = SplitMix(seed);
    let mut points: Vec<[f32; 3]> = (0..800)
        .map(|k| {
            let spread = match k % 10 {
                0 => 40.0,
                1..=3 => 2.0,
                _ => 0.1,
            };
            std::array::from_fn(|_| (rng.signed() * spread) as f32)
        })
        .collect();
    points.push(points[11]);
    points.push(points[11]);
    let index = PointIndex::new(&points);
    assert_eq!(index.len(), points.len());
    for (i, p) in points.iter().enumerate().step_by(7) {
        for k in [1, 3, 8] {
            let got = index.k_nearest(*p, k, Some(i));
            let want = k_nearest_brute_force(&points, *p, k, Some(i));
            assert_eq!(got, want, "seed {seed}: point {i}, k {k}");
        }
    }
    for _ in 0..100 {
        let scale = if rng.signed() > 0.5 { 1e4 } else { 5.0 };
        let q: [f32; 3] = std::array::from_fn(|_| (rng.signed() * scale) as f32);
        let got = index.k_nearest(q, 5, None);
        let want = k_nearest_brute_force(&points, q, 5, None);
        assert_eq!(got, want, "seed {seed}: query {q:?}");
    }
}

#[test]
fn small_and_empty_clouds_return_what_they_hold() {
    let points = [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 2.0, 0.0]];
    let index = PointIndex::new(&points);
    let all = index.k_nearest([0.1, 0.0, 0.0], 10, None);
    let order: Vec<usize> = all.iter().map(|&(j, _)| j).collect();
    assert_eq!(order, vec![0, 1, 2]);
    for (&(_, got), want) in all.iter().zip([0.01f32, 0.81, 4.01]) {
        assert!((got - want).abs() < 1e-6, "{got} vs {want}");
    }
    assert_eq!(index.k_nearest([0.0; 3], 10, Some(0)).len(), 2);
    let one = PointIndex::new(&[[3.0, 3.0, 3.0]]);
    assert!(one.k_nearest([3.0; 3], 2, Some(0)).is_empty());
    let empty = PointIndex::new(&[]);
    assert!(empty.is_empty());
    assert!(empty.k_nearest([0.0; 3], 3, None).is_empty());
}
