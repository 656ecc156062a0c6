//! Ray casting against triangle meshes on the CPU: a bounding-volume hierarchy over a mesh's
//! triangles ([`TriangleBvh`]) answering "does this ray hit anything before `t_max`" (an
//! any-hit shadow ray) and "where does it first hit", beside a brute-force loop over every
//! triangle ([`first_hit_brute_force`]) it is tested against. Visibility labels for a posed
//! body (is the light direction ω open from a vertex?) are the main use: tens of thousands of
//! rays per pose, where the brute-force loop would cost `rays × triangles`.
//!
//! Intersections use the Möller–Trumbore test in f64; rays are `o + t d` with `t ∈ (t_min,
//! t_max)`, `d` need not be unit (`t` is then in units of `|d|`). Degenerate (zero-area)
//! triangles never hit.

/// One ray–triangle hit: the distance along the ray and the triangle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    pub t: f64,
    pub triangle: usize,
}

/// Möller–Trumbore: the `t` at which `o + t d` crosses triangle `(a, b, c)`, if it does.
pub fn intersect_triangle(
    origin: [f64; 3],
    direction: [f64; 3],
    [a, b, c]: [[f64; 3]; 3],
) -> Option<f64> {
    let e1 = sub(b, a);
    let e2 = sub(c, a);
    let p = cross(direction, e2);
    let det = dot(e1, p);
    // Parallel rays and zero-area triangles: no hit. The bound is relative to the edge sizes.
    let scale = (dot(e1, e1) * dot(e2, e2)).sqrt() * dot(direction, direction).sqrt();
    if det.abs() <= 1e-14 * scale || scale == 0.0 {
        return None;
    }
    let inv = 1.0 / det;
    let s = sub(origin, a);
    let u = dot(s, p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = cross(s, e1);
    let v = dot(direction, q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    Some(dot(e2, q) * inv)
}

/// The nearest hit with `t_min < t < t_max` by testing every triangle: the reference.
pub fn first_hit_brute_force(
    vertices: &[[f64; 3]],
    faces: &[[u32; 3]],
    origin: [f64; 3],
    direction: [f64; 3],
    (t_min, t_max): (f64, f64),
) -> Option<Hit> {
    let mut best: Option<Hit> = None;
    for (triangle, f) in faces.iter().enumerate() {
        let corners = f.map(|i| vertices[i as usize]);
        if let Some(t) = intersect_triangle(origin, direction, corners)
            && t > t_min
            && t < best.map_or(t_max, |h| h.t)
        {
            best = Some(Hit { t, triangle });
        }
    }
    best
}

#[derive(Debug, Clone, Copy)]
struct Aabb {
    lo: [f64; 3],
    hi: [f64; 3],
}

impl Aabb {
    const EMPTY: Aabb = Aabb {
        lo: [f64::INFINITY; 3],
        hi: [f64::NEG_INFINITY; 3],
    };

    fn grow(&mut self, p: [f64; 3]) {
        self.lo = std::array::from_fn(|k| self.lo[k].min(p[k]));
        self.hi = std::array::from_fn(|k| self.hi[k].max(p[k]));
    }

    /// The slab test: whether the ray meets the box within `(t_min, t_max)`.
    fn hit(&self, origin: [f64; 3], inverse: [f64; 3], t_min: f64, t_max: f64) -> bool {
        let (mut near, mut far) = (t_min, t_max);
        for k in 0..3 {
            let t0 = (self.lo[k] - origin[k]) * inverse[k];
            let t1 = (self.hi[k] - origin[k]) * inverse[k];
            let (t0, t1) = if t0 <= t1 { (t0, t1) } else { (t1, t0) };
            // NaN (a zero direction component on the slab's plane) keeps the bound as it was.
            near = if t0 > near { t0 } else { near };
            far = if t1 < far { t1 } else { far };
            if near > far {
                return false;
            }
        }
        true
    }
}

/// A node: a box, and either two children or a run of triangles in `order`.
#[derive(Debug, Clone)]
struct Node {
    bounds: Aabb,
    /// Leaf: `(first, count)` into `order`; inner: `count == 0` and `first` is the right child
    /// (the left child follows its parent).
    first: usize,
    count: usize,
}

/// A BVH over one mesh's triangles (median split on the widest centroid axis, ≤ 4 triangles
/// per leaf). Build once per pose; queries take `&self` and run in parallel.
#[derive(Debug, Clone)]
pub struct TriangleBvh {
    triangles: Vec<[[f64; 3]; 3]>,
    order: Vec<usize>,
    nodes: Vec<Node>,
}

const LEAF_SIZE: usize = 4;

impl TriangleBvh {
    /// Builds the tree; faces index `vertices` (an out-of-range index panics with its face).
    pub fn new(vertices: &[[f64; 3]], faces: &[[u32; 3]]) -> Self {
        let triangles: Vec<[[f64; 3]; 3]> = faces
            .iter()
            .enumerate()
            .map(|(k, f)| {
                f.map(|i| {
                    *vertices.get(i as usize).unwrap_or_else(|| {
                        panic!("face {k} indexes vertex {i} of {}", vertices.len())
                    })
                })
            })
            .collect();
        let centroids: Vec<[f64; 3]> = triangles
            .iter()
            .map(|t| std::array::from_fn(|k| (t[0][k] + t[1][k] + t[2][k]) / 3.0))
            .collect();
        let mut bvh = Self {
            order: (0..triangles.len()).collect(),
            triangles,
            nodes: Vec::new(),
        };
        if !bvh.triangles.is_empty() {
            bvh.build(0, bvh.order.len(), &centroids);
        }
        bvh
    }

    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    fn build(&mut self, first: usize, count: usize, centroids: &[[f64; 3]]) -> usize {
        let mut bounds = Aabb::EMPTY;
        let mut centre_bounds = Aabb::EMPTY;
        for &t in &self.order[first..first + count] {
            for p in self.triangles[t] {
                bounds.grow(p);
            }
            centre_bounds.grow(centroids[t]);
        }
        let index = self.nodes.len();
        self.nodes.push(Node {
            bounds,
            first,
            count,
        });
        if count <= LEAF_SIZE {
            return index;
        }
        let extent: [f64; 3] = std::array::from_fn(|k| centre_bounds.hi[k] - centre_bounds.lo[k]);
        let axis = (0..3)
            .max_by(|&a, &b| extent[a].total_cmp(&extent[b]))
            .unwrap_or(0);
        let half = count / 2;
        self.order[first..first + count].select_nth_unstable_by(half, |&a, &b| {
            centroids[a][axis].total_cmp(&centroids[b][axis])
        });
        self.build(first, half, centroids);
        let right = self.build(first + half, count - half, centroids);
        self.nodes[index].first = right;
        self.nodes[index].count = 0;
        index
    }

    /// Walks the boxes the ray meets, shrinking `t_max` at each hit; with `any` it returns the
    /// first hit found instead of the nearest.
    fn walk(
        &self,
        origin: [f64; 3],
        direction: [f64; 3],
        (t_min, mut t_max): (f64, f64),
        any: bool,
    ) -> Option<Hit> {
        if self.nodes.is_empty() {
            return None;
        }
        let inverse = direction.map(|d| 1.0 / d);
        let mut best = None;
        let mut stack = vec![0usize];
        while let Some(index) = stack.pop() {
            let node = &self.nodes[index];
            if !node.bounds.hit(origin, inverse, t_min, t_max) {
                continue;
            }
            if node.count == 0 {
                stack.push(node.first);
                stack.push(index + 1);
                continue;
            }
            for &triangle in &self.order[node.first..node.first + node.count] {
                if let Some(t) = intersect_triangle(origin, direction, self.triangles[triangle])
                    && t > t_min
                    && t < t_max
                {
                    best = Some(Hit { t, triangle });
                    if any {
                        return best;
                    }
                    t_max = t;
                }
            }
        }
        best
    }

    /// The nearest hit with `t_min < t < t_max`.
    pub fn first_hit(
        &self,
        origin: [f64; 3],
        direction: [f64; 3],
        range: (f64, f64),
    ) -> Option<Hit> {
        self.walk(origin, direction, range, false)
    }

    /// Whether anything is hit with `t_min < t < t_max` (stops at the first hit found).
    pub fn occluded(&self, origin: [f64; 3], direction: [f64; 3], range: (f64, f64)) -> bool {
        self.walk(origin, direction, range, true).is_some()
    }
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
