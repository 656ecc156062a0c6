//! Exact k-nearest-neighbour queries over a fixed 3-D point cloud: a uniform grid of buckets
//! searched in growing cubic shells around the query's cell, a shell skipped only once no point
//! in it can be nearer than the k-th found. Gaussians' initial scales (the three nearest
//! neighbours, as 3DGS's `distCUDA2`), a Gaussian's nearest mesh vertices for attribute
//! transfer and a scene Gaussian's neighbours for smoothness terms all ask this.
//! [`k_nearest_brute_force`] is the reference it is tested against.

use std::collections::HashMap;

/// A bucket grid over `[f32; 3]` points (squared distances in `f32`, as the callers store).
#[derive(Debug, Clone)]
pub struct PointIndex {
    points: Vec<[f32; 3]>,
    lo: [f32; 3],
    cell: f32,
    buckets: HashMap<[i64; 3], Vec<u32>>,
    /// Shells beyond this hold no point.
    max_shell: i64,
}

impl PointIndex {
    /// Buckets sized for about four points each over an evenly spread cloud.
    pub fn new(points: &[[f32; 3]]) -> Self {
        let mut lo = [f32::INFINITY; 3];
        let mut hi = [f32::NEG_INFINITY; 3];
        for p in points {
            for a in 0..3 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
        }
        if points.is_empty() {
            lo = [0.0; 3];
            hi = [0.0; 3];
        }
        let diagonal = (0..3).map(|a| (hi[a] - lo[a]).powi(2)).sum::<f32>().sqrt();
        let floor = (diagonal * 1e-7).max(f32::MIN_POSITIVE);
        let volume: f32 = (0..3)
            .map(|a| (hi[a] - lo[a]).max(diagonal * 1e-3))
            .product();
        let cell = (4.0 * volume / points.len().max(1) as f32)
            .cbrt()
            .max(floor);
        let mut index = Self {
            points: points.to_vec(),
            lo,
            cell,
            buckets: HashMap::new(),
            max_shell: ((diagonal / cell).ceil() as i64).max(1) + 1,
        };
        for (i, p) in points.iter().enumerate() {
            let key = index.key(p);
            index.buckets.entry(key).or_default().push(i as u32);
        }
        index
    }

    pub fn len(&self) -> usize {
        self.points.len()
    }

    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// The points the index was built on.
    pub fn points(&self) -> &[[f32; 3]] {
        &self.points
    }

    fn key(&self, p: &[f32; 3]) -> [i64; 3] {
        std::array::from_fn(|a| ((p[a] - self.lo[a]) / self.cell).floor() as i64)
    }

    /// The `k` points nearest `query` as `(index, squared distance)`, nearest first (ties in
    /// index order), leaving out point `skip` (a query that is itself a point of the cloud).
    /// Fewer than `k` when the cloud holds fewer.
    pub fn k_nearest(&self, query: [f32; 3], k: usize, skip: Option<usize>) -> Vec<(usize, f32)> {
        let available = self.points.len() - usize::from(skip.is_some_and(|s| s < self.len()));
        let want = k.min(available);
        let mut best: Vec<(usize, f32)> = Vec::with_capacity(want + 1);
        if want == 0 {
            return best;
        }
        let centre = self.key(&query);
        let outside = centre
            .iter()
            .map(|&c| (-c).max(c - self.max_shell).max(0))
            .max()
            .unwrap_or(0);
        // A query far outside the cloud would search many empty shells: test every point.
        if outside > 2 || !query.iter().all(|v| v.is_finite()) {
            return k_nearest_brute_force(&self.points, query, want, skip);
        }
        let mut shell = 0i64;
        loop {
            for dx in -shell..=shell {
                for dy in -shell..=shell {
                    for dz in -shell..=shell {
                        if dx.abs().max(dy.abs()).max(dz.abs()) != shell {
                            continue;
                        }
                        let c = [centre[0] + dx, centre[1] + dy, centre[2] + dz];
                        for &j in self.buckets.get(&c).map_or(&[][..], |v| v.as_slice()) {
                            let j = j as usize;
                            if Some(j) == skip {
                                continue;
                            }
                            let q = self.points[j];
                            let d2 = (0..3).map(|a| (q[a] - query[a]).powi(2)).sum::<f32>();
                            let at = best.partition_point(|&(i, b)| (b, i) <= (d2, j));
                            if at < want {
                                best.insert(at, (j, d2));
                                best.truncate(want);
                            }
                        }
                    }
                }
            }
            // Every point outside the searched cube is at least `shell · cell` away.
            let reach = shell as f32 * self.cell;
            let done = best.len() == want && best.last().is_some_and(|&(_, b)| b <= reach * reach);
            if done || shell > self.max_shell + outside {
                break;
            }
            shell += 1;
        }
        best
    }
}

/// [`PointIndex::k_nearest`] by sorting every distance: the reference.
pub fn k_nearest_brute_force(
    points: &[[f32; 3]],
    query: [f32; 3],
    k: usize,
    skip: Option<usize>,
) -> Vec<(usize, f32)> {
    let mut all: Vec<(usize, f32)> = points
        .iter()
        .enumerate()
        .filter(|&(j, _)| Some(j) != skip)
        .map(|(j, q)| (j, (0..3).map(|a| (q[a] - query[a]).powi(2)).sum::<f32>()))
        .collect();
    all.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
    all.truncate(k);
    all
}
