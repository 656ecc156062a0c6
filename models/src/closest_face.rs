//! The closest point of a triangle mesh to a query point: which face, where on it
//! (barycentrics) and how far. Binding Gaussians to a body's surface (each to its nearest face)
//! and pruning Gaussians that drifted off it (GauHuman's distance-to-mesh rule) both ask this.
//!
//! [`FaceIndex::nearest`] searches the faces around the query's nearest vertices (a
//! [`PointIndex`] over the vertices), each tested exactly by [`closest_point_on_triangle`];
//! [`FaceIndex::nearest_brute_force`] tests every face and is the reference the tests pair it
//! with. The vertex search can miss the true nearest face only where a face is much larger
//! than the spacing of the vertices around the query (long slivers), which body meshes do not
//! have.

use crate::knn::PointIndex;

/// Vertices whose incident faces are searched for each query.
const NEAREST_VERTICES: usize = 8;

/// The closest point of triangle `abc` to `p` as barycentrics `(u, v, w)` on `(a, b, c)`
/// (Ericson's region test), with its squared distance. A degenerate triangle answers with its
/// nearest edge or corner, never NaN.
pub fn closest_point_on_triangle(
    p: [f64; 3],
    a: [f64; 3],
    b: [f64; 3],
    c: [f64; 3],
) -> ([f64; 3], f64) {
    let (ab, ac, ap) = (sub(b, a), sub(c, a), sub(p, a));
    let (d1, d2) = (dot(ab, ap), dot(ac, ap));
    let bary = if d1 <= 0.0 && d2 <= 0.0 {
        [1.0, 0.0, 0.0]
    } else {
        let bp = sub(p, b);
        let (d3, d4) = (dot(ab, bp), dot(ac, bp));
        let cp = sub(p, c);
        let (d5, d6) = (dot(ab, cp), dot(ac, cp));
        let vc = d1 * d4 - d3 * d2;
        let vb = d5 * d2 - d1 * d6;
        let va = d3 * d6 - d5 * d4;
        if d3 >= 0.0 && d4 <= d3 {
            [0.0, 1.0, 0.0]
        } else if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
            let v = d1 / (d1 - d3);
            [1.0 - v, v, 0.0]
        } else if d6 >= 0.0 && d5 <= d6 {
            [0.0, 0.0, 1.0]
        } else if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
            let w = d2 / (d2 - d6);
            [1.0 - w, 0.0, w]
        } else if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
            let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
            [0.0, 1.0 - w, w]
        } else {
            let denom = va + vb + vc;
            if denom.abs() < 1e-300 {
                // A degenerate triangle: its first corner.
                [1.0, 0.0, 0.0]
            } else {
                let (v, w) = (vb / denom, vc / denom);
                [1.0 - v - w, v, w]
            }
        }
    };
    let q = barycentric_point(bary, a, b, c);
    let d = sub(p, q);
    (bary, dot(d, d))
}

/// `u a + v b + w c`.
pub fn barycentric_point(bary: [f64; 3], a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|k| bary[0] * a[k] + bary[1] * b[k] + bary[2] * c[k])
}

fn sub(x: [f64; 3], y: [f64; 3]) -> [f64; 3] {
    [x[0] - y[0], x[1] - y[1], x[2] - y[2]]
}

fn dot(x: [f64; 3], y: [f64; 3]) -> f64 {
    x[0] * y[0] + x[1] * y[1] + x[2] * y[2]
}

/// A query's nearest face.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClosestFace {
    pub face: usize,
    /// Of the closest point, on the face's corners in order.
    pub barycentric: [f64; 3],
    pub squared_distance: f64,
}

/// A fixed mesh ready for nearest-face queries.
#[derive(Debug, Clone)]
pub struct FaceIndex {
    vertices: Vec<[f32; 3]>,
    faces: Vec<[u32; 3]>,
    faces_of_vertex: Vec<Vec<usize>>,
    index: PointIndex,
}

impl FaceIndex {
    /// Faces index `vertices` (an out-of-range index panics with its face, as
    /// [`crate::raycast::TriangleBvh::new`]: meshes come from validated body models).
    pub fn new(vertices: &[[f32; 3]], faces: &[[u32; 3]]) -> Self {
        let mut faces_of_vertex = vec![Vec::new(); vertices.len()];
        for (f, face) in faces.iter().enumerate() {
            for &v in face {
                faces_of_vertex
                    .get_mut(v as usize)
                    .unwrap_or_else(|| panic!("face {f} indexes vertex {v} of {}", vertices.len()))
                    .push(f);
            }
        }
        Self {
            vertices: vertices.to_vec(),
            faces: faces.to_vec(),
            faces_of_vertex,
            index: PointIndex::new(vertices),
        }
    }

    pub fn face_count(&self) -> usize {
        self.faces.len()
    }

    /// Face `f`'s corners in f64.
    pub fn corners(&self, f: usize) -> [[f64; 3]; 3] {
        self.faces[f].map(|v| self.vertices[v as usize].map(f64::from))
    }

    fn closest_of(&self, p: [f64; 3], faces: impl Iterator<Item = usize>) -> Option<ClosestFace> {
        let mut best: Option<ClosestFace> = None;
        for f in faces {
            let [a, b, c] = self.corners(f);
            let (barycentric, squared_distance) = closest_point_on_triangle(p, a, b, c);
            if best.is_none_or(|b| squared_distance < b.squared_distance) {
                best = Some(ClosestFace {
                    face: f,
                    barycentric,
                    squared_distance,
                });
            }
        }
        best
    }

    /// The nearest face among those around `p`'s nearest vertices; `None` for a mesh without
    /// faces (or a non-finite `p`).
    pub fn nearest(&self, p: [f64; 3]) -> Option<ClosestFace> {
        if !p.iter().all(|x| x.is_finite()) {
            return None;
        }
        let query = p.map(|x| x as f32);
        let near = self.index.k_nearest(query, NEAREST_VERTICES, None);
        self.closest_of(
            p,
            near.into_iter()
                .flat_map(|(v, _)| self.faces_of_vertex[v].iter().copied()),
        )
    }

    /// The nearest face testing every face: the plain reference.
    pub fn nearest_brute_force(&self, p: [f64; 3]) -> Option<ClosestFace> {
        if !p.iter().all(|x| x.is_finite()) {
            return None;
        }
        self.closest_of(p, 0..self.faces.len())
    }
}
