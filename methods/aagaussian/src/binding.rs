//! U9 of AAGaussian (HumanGaussian's animation binding): each canonical Gaussian is tied to its
//! nearest face of the canonical body mesh by the barycentrics `b_i` of its closest surface
//! point and its signed distance `s_i` along that face's normal; rows whose centre that pair
//! does not reproduce within `cull_distance` are dropped. A posed mesh then carries the kept
//! rows zero-shot, `μ_i(t) = Σ_j b_ij v_{f_i j}(t) + s_i n_{f_i}(t)`; with `rotate` (our choice)
//! each Gaussian also turns with its face frame, `q_i(t) = q(R_f(t) R_f(0)ᵀ) ⊗ q_i`, while
//! HumanGaussian keeps rotations (and both keep scales).
//!
//! Nearest faces come from the engine's [`FaceIndex`] (the faces around the 8 nearest vertices,
//! each tested exactly); [`bind_brute_force`] tests every face and is the reference the tests
//! pair it with.

use rayon::prelude::*;
use splatzoo_models::closest_face::{FaceIndex, barycentric_point, closest_point_on_triangle};
use splatzoo_train::gaussians::GaussianRows;

/// Every kept Gaussian's anchor on the canonical mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct SurfaceBinding {
    /// The canonical rows that are kept (reconstruction error within the cull distance).
    pub kept: Vec<usize>,
    /// Per kept row: its face, the barycentrics of its closest point, its signed normal offset.
    pub face: Vec<u32>,
    pub barycentric: Vec<[f32; 3]>,
    pub normal_offset: Vec<f32>,
    /// Rows dropped by the cull.
    pub culled: usize,
    /// `[F]` each face's canonical frame (columns tangent, bitangent, normal).
    canonical_frames: Vec<[[f64; 3]; 3]>,
}

fn corners(vertices: &[[f32; 3]], face: [u32; 3]) -> [[f64; 3]; 3] {
    face.map(|v| vertices[v as usize].map(f64::from))
}

/// A face's frame: columns the unit first edge, normal × tangent and the unit normal
/// (right-handed winding), as `splatzoo_models::anchor::face_frames` builds it.
pub fn face_frame(corners: [[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let [a, b, c] = corners;
    let e1 = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let e2 = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
    let unit = |v: [f64; 3]| {
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt().max(1e-12);
        v.map(|x| x / n)
    };
    let cross = |u: [f64; 3], v: [f64; 3]| {
        [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ]
    };
    let tangent = unit(e1);
    let normal = unit(cross(e1, e2));
    let bitangent = cross(normal, tangent);
    std::array::from_fn(|r| [tangent[r], bitangent[r], normal[r]])
}

fn frames(vertices: &[[f32; 3]], faces: &[[u32; 3]]) -> Vec<[[f64; 3]; 3]> {
    faces
        .iter()
        .map(|&f| face_frame(corners(vertices, f)))
        .collect()
}

/// The anchor of `p` on face `f`: barycentrics, signed normal offset, reconstruction error.
fn anchor_on(p: [f64; 3], corners: [[f64; 3]; 3], frame: &[[f64; 3]; 3]) -> ([f32; 3], f32, f64) {
    let (bary, _) = closest_point_on_triangle(p, corners[0], corners[1], corners[2]);
    let q = barycentric_point(bary, corners[0], corners[1], corners[2]);
    let n = [frame[0][2], frame[1][2], frame[2][2]];
    let d: [f64; 3] = std::array::from_fn(|k| p[k] - q[k]);
    let s = d[0] * n[0] + d[1] * n[1] + d[2] * n[2];
    let residual: f64 = (0..3)
        .map(|k| (d[k] - s * n[k]).powi(2))
        .sum::<f64>()
        .sqrt();
    (bary.map(|x| x as f32), s as f32, residual)
}

fn assemble(
    means: &[[f32; 3]],
    vertices: &[[f32; 3]],
    faces: &[[u32; 3]],
    cull_distance: f64,
    nearest: impl Fn(usize, [f64; 3]) -> usize + Sync,
) -> SurfaceBinding {
    let canonical_frames = frames(vertices, faces);
    let anchors: Vec<(u32, [f32; 3], f32, f64)> = means
        .par_iter()
        .enumerate()
        .map(|(i, m)| {
            let p = m.map(f64::from);
            let f = nearest(i, p);
            let (bary, s, err) = anchor_on(p, corners(vertices, faces[f]), &canonical_frames[f]);
            (f as u32, bary, s, err)
        })
        .collect();
    let mut binding = SurfaceBinding {
        kept: Vec::new(),
        face: Vec::new(),
        barycentric: Vec::new(),
        normal_offset: Vec::new(),
        culled: 0,
        canonical_frames,
    };
    for (i, (f, bary, s, err)) in anchors.into_iter().enumerate() {
        if err.is_finite() && err <= cull_distance {
            binding.kept.push(i);
            binding.face.push(f);
            binding.barycentric.push(bary);
            binding.normal_offset.push(s);
        } else {
            binding.culled += 1;
        }
    }
    binding
}

/// Binds `means` to the canonical mesh (`vertices`, `faces`), searching the faces around each
/// centre's nearest vertices.
pub fn bind(
    means: &[[f32; 3]],
    vertices: &[[f32; 3]],
    faces: &[[u32; 3]],
    cull_distance: f64,
) -> SurfaceBinding {
    let index = FaceIndex::new(vertices, faces);
    assemble(means, vertices, faces, cull_distance, |_, p| {
        index.nearest(p).map_or(0, |closest| closest.face)
    })
}

/// [`bind`] testing every face: the plain reference.
pub fn bind_brute_force(
    means: &[[f32; 3]],
    vertices: &[[f32; 3]],
    faces: &[[u32; 3]],
    cull_distance: f64,
) -> SurfaceBinding {
    let index = FaceIndex::new(vertices, faces);
    assemble(means, vertices, faces, cull_distance, |_, p| {
        index
            .nearest_brute_force(p)
            .map_or(0, |closest| closest.face)
    })
}

impl SurfaceBinding {
    /// The kept rows of `canonical` carried onto the posed mesh `posed` (same faces as at
    /// binding), turned with their faces when `rotate`.
    pub fn pose(
        &self,
        canonical: &GaussianRows,
        posed: &[[f32; 3]],
        faces: &[[u32; 3]],
        rotate: bool,
    ) -> GaussianRows {
        let mut out = GaussianRows::default();
        for (k, &row) in self.kept.iter().enumerate() {
            out.push_from(canonical, row);
            let f = self.face[k] as usize;
            let c = corners(posed, faces[f]);
            let frame = face_frame(c);
            let b = self.barycentric[k].map(f64::from);
            let s = f64::from(self.normal_offset[k]);
            let q = barycentric_point(b, c[0], c[1], c[2]);
            for a in 0..3 {
                out.means[3 * k + a] = (q[a] + s * frame[a][2]) as f32;
            }
            if rotate {
                let turn = mat_mul_transposed(&frame, &self.canonical_frames[f]);
                let quat: [f64; 4] =
                    std::array::from_fn(|i| f64::from(canonical.quats[4 * row + i]));
                let turned = quaternion_product(matrix_quaternion(&turn), normalised(quat));
                for (o, v) in out.quats[4 * k..4 * k + 4].iter_mut().zip(turned) {
                    *o = v as f32;
                }
            }
        }
        out
    }
}

/// `A Bᵀ` of two 3 × 3 matrices.
fn mat_mul_transposed(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    std::array::from_fn(|r| std::array::from_fn(|c| (0..3).map(|k| a[r][k] * b[c][k]).sum()))
}

fn normalised(q: [f64; 4]) -> [f64; 4] {
    let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
    if n == 0.0 || !n.is_finite() {
        [1.0, 0.0, 0.0, 0.0]
    } else {
        q.map(|v| v / n)
    }
}

/// `a ⊗ b` for `(w, x, y, z)` quaternions.
pub fn quaternion_product(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
    [
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    ]
}

/// The unit `(w, x, y, z)` quaternion of a rotation matrix (Shepperd's branch on the largest
/// of `w², x², y², z²`);
/// `splatzoo_models::rotation_scalar::quaternion_matrix` inverts it.
pub fn matrix_quaternion(m: &[[f64; 3]; 3]) -> [f64; 4] {
    let trace = m[0][0] + m[1][1] + m[2][2];
    let q = if trace > 0.0 {
        let s = 2.0 * (1.0 + trace).sqrt();
        [
            0.25 * s,
            (m[2][1] - m[1][2]) / s,
            (m[0][2] - m[2][0]) / s,
            (m[1][0] - m[0][1]) / s,
        ]
    } else if m[0][0] > m[1][1] && m[0][0] > m[2][2] {
        let s = 2.0 * (1.0 + m[0][0] - m[1][1] - m[2][2]).sqrt();
        [
            (m[2][1] - m[1][2]) / s,
            0.25 * s,
            (m[0][1] + m[1][0]) / s,
            (m[0][2] + m[2][0]) / s,
        ]
    } else if m[1][1] > m[2][2] {
        let s = 2.0 * (1.0 + m[1][1] - m[0][0] - m[2][2]).sqrt();
        [
            (m[0][2] - m[2][0]) / s,
            (m[0][1] + m[1][0]) / s,
            0.25 * s,
            (m[1][2] + m[2][1]) / s,
        ]
    } else {
        let s = 2.0 * (1.0 + m[2][2] - m[0][0] - m[1][1]).sqrt();
        [
            (m[1][0] - m[0][1]) / s,
            (m[0][2] + m[2][0]) / s,
            (m[1][2] + m[2][1]) / s,
            0.25 * s,
        ]
    };
    normalised(q)
}
