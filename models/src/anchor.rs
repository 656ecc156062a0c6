//! Gaussians anchored to a triangle mesh: K per face at fixed barycentric weights plus an
//! offset in the face's tangent frame (Eq. 1 of NLF-GS), mesh subdivision that carries skinning
//! and blend shapes (Illum up-samples the body mesh), and area-uniform surface sampling
//! (AAGaussian initialises from 100k surface points).

use crate::body::BodyModel;
use burn::tensor::{Int, Tensor, TensorData};
use rand::{Rng, SeedableRng, rngs::StdRng};
use std::collections::HashMap;

/// `k` fixed barycentric points inside a triangle, spread evenly: the centroid for 1; the
/// centroid and three points towards the corners for 4; otherwise a Hammersley set mapped to the
/// triangle (square-root warp), deterministic.
pub fn fixed_barycentrics(k: usize) -> Vec<[f32; 3]> {
    match k {
        0 => Vec::new(),
        1 => vec![[1.0 / 3.0; 3]],
        4 => vec![
            [1.0 / 3.0; 3],
            [2.0 / 3.0, 1.0 / 6.0, 1.0 / 6.0],
            [1.0 / 6.0, 2.0 / 3.0, 1.0 / 6.0],
            [1.0 / 6.0, 1.0 / 6.0, 2.0 / 3.0],
        ],
        _ => (0..k)
            .map(|i| {
                let u = (i as f32 + 0.5) / k as f32;
                let v = radical_inverse(i as u32);
                warp_to_triangle(u, v)
            })
            .collect(),
    }
}

fn radical_inverse(mut bits: u32) -> f32 {
    bits = bits.reverse_bits();
    bits as f32 / 4_294_967_296.0
}

/// Uniform square → uniform triangle (Osada et al. 2002).
fn warp_to_triangle(u: f32, v: f32) -> [f32; 3] {
    let s = u.sqrt();
    [1.0 - s, s * (1.0 - v), s * v]
}

/// Which face and where on it each anchored Gaussian sits.
#[derive(Debug, Clone)]
pub struct MeshAnchors {
    /// `[G]` the parent face of each Gaussian (`p_{f,k}` of NLF-GS).
    pub face_from_gaussian: Vec<u32>,
    /// `[G, 3]` barycentric weights `β_{f,k,j}`.
    pub barycentric: Vec<[f32; 3]>,
}

impl MeshAnchors {
    /// `per_face` Gaussians on each of `face_count` faces (face-major order).
    pub fn per_face(face_count: usize, per_face: usize) -> Self {
        let weights = fixed_barycentrics(per_face);
        Self {
            face_from_gaussian: (0..face_count as u32)
                .flat_map(|f| std::iter::repeat_n(f, per_face))
                .collect(),
            barycentric: (0..face_count)
                .flat_map(|_| weights.iter().copied())
                .collect(),
        }
    }

    /// Area-uniform random points on a mesh (`[V, 3]` vertices, `[F, 3]` faces), seeded.
    pub fn sample_surface(vertices: &[f32], faces: &[u32], count: usize, seed: u64) -> Self {
        let areas: Vec<f64> = faces
            .chunks(3)
            .map(|f| {
                let p =
                    |i: u32| -> [f64; 3] { [0, 1, 2].map(|c| vertices[3 * i as usize + c] as f64) };
                let (a, b, c) = (p(f[0]), p(f[1]), p(f[2]));
                let e1 = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
                let e2 = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
                let cr = [
                    e1[1] * e2[2] - e1[2] * e2[1],
                    e1[2] * e2[0] - e1[0] * e2[2],
                    e1[0] * e2[1] - e1[1] * e2[0],
                ];
                0.5 * (cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]).sqrt()
            })
            .collect();
        let mut cdf = Vec::with_capacity(areas.len());
        let mut total = 0.0;
        for a in &areas {
            total += a;
            cdf.push(total);
        }
        let mut rng = StdRng::seed_from_u64(seed);
        let mut face_from_gaussian = Vec::with_capacity(count);
        let mut barycentric = Vec::with_capacity(count);
        for _ in 0..count {
            let target = rng.random_range(0.0..total.max(f64::MIN_POSITIVE));
            let face = cdf.partition_point(|&c| c <= target).min(areas.len() - 1);
            face_from_gaussian.push(face as u32);
            barycentric.push(warp_to_triangle(rng.random(), rng.random()));
        }
        Self {
            face_from_gaussian,
            barycentric,
        }
    }

    pub fn len(&self) -> usize {
        self.face_from_gaussian.len()
    }

    pub fn is_empty(&self) -> bool {
        self.face_from_gaussian.is_empty()
    }
}

/// Per-face orthonormal frames `[B, F, 3, 3]` of a batch of meshes `[B, V, 3]`: columns are the
/// tangent (first edge), bitangent (normal × tangent) and unit normal (right-handed winding).
pub fn face_frames(vertices: Tensor<3>, faces: &[u32]) -> Tensor<4> {
    let [b, _, _] = vertices.dims();
    let f = faces.len() / 3;
    let corner = |j: usize| {
        let idx: Vec<i64> = faces.chunks(3).map(|t| t[j] as i64).collect();
        let idx = Tensor::<1, Int>::from_data(TensorData::new(idx, [f]), &vertices.device());
        vertices.clone().select(1, idx) // [B, F, 3]
    };
    let (a, b1, c) = (corner(0), corner(1), corner(2));
    let unit = |v: Tensor<3>| {
        let n = v.clone().powi_scalar(2).sum_dim(2).sqrt().clamp_min(1e-12);
        v / n
    };
    let cross = |u: Tensor<3>, v: Tensor<3>| {
        let comp = |t: &Tensor<3>, k: usize| t.clone().slice([0..b, 0..f, k..k + 1]);
        Tensor::cat(
            vec![
                comp(&u, 1) * comp(&v, 2) - comp(&u, 2) * comp(&v, 1),
                comp(&u, 2) * comp(&v, 0) - comp(&u, 0) * comp(&v, 2),
                comp(&u, 0) * comp(&v, 1) - comp(&u, 1) * comp(&v, 0),
            ],
            2,
        )
    };
    let e1 = b1 - a.clone();
    let e2 = c - a;
    let tangent = unit(e1.clone());
    let normal = unit(cross(e1, e2));
    let bitangent = cross(normal.clone(), tangent.clone());
    Tensor::stack::<4>(vec![tangent, bitangent, normal], 3)
}

/// Eq. 1 of NLF-GS, with the offset expressed in the face frame so it follows the posed mesh:
/// `x = Σ_j β_j v_j + T_f Δx` for vertices `[B, V, 3]` and local offsets `[B, G, 3]`.
/// Returns the centres `[B, G, 3]` and each Gaussian's face frame `[B, G, 3, 3]` (compose it
/// with a local rotation to orient the Gaussian).
pub fn anchored_positions(
    vertices: Tensor<3>,
    faces: &[u32],
    anchors: &MeshAnchors,
    local_offsets: Tensor<3>,
) -> (Tensor<3>, Tensor<4>) {
    let [b, _, _] = vertices.dims();
    let g = anchors.len();
    let device = vertices.device();
    let face_idx: Vec<i64> = anchors
        .face_from_gaussian
        .iter()
        .map(|&f| f as i64)
        .collect();
    let face_idx = Tensor::<1, Int>::from_data(TensorData::new(face_idx, [g]), &device);
    let mut centre = Tensor::<3>::zeros([b, g, 3], &device);
    for j in 0..3 {
        let vid: Vec<i64> = anchors
            .face_from_gaussian
            .iter()
            .map(|&f| faces[3 * f as usize + j] as i64)
            .collect();
        let vid = Tensor::<1, Int>::from_data(TensorData::new(vid, [g]), &device);
        let w: Vec<f32> = anchors.barycentric.iter().map(|w| w[j]).collect();
        let w = Tensor::<3>::from_data(TensorData::new(w, [1, g, 1]), &device);
        centre = centre + vertices.clone().select(1, vid) * w;
    }
    let frames = face_frames(vertices, faces).select(1, face_idx); // [B, G, 3, 3]
    let offset = frames
        .clone()
        .matmul(local_offsets.reshape([b, g, 3, 1]))
        .reshape([b, g, 3]);
    (centre + offset, frames)
}

/// Splits every triangle into four at its edge midpoints. Per-vertex data of the new vertices
/// (template, skinning weights, shape/pose/expression directions) is the mean of the edge's
/// two ends; the joint regressor keeps reading the original vertices, so joints do not move.
/// Returns the finer model and, for each new vertex, its two parents.
pub fn subdivide(model: &BodyModel) -> (BodyModel, Vec<[u32; 2]>) {
    let v0 = model.vertex_count();
    let mut midpoint: HashMap<(u32, u32), u32> = HashMap::new();
    let mut parents: Vec<[u32; 2]> = Vec::new();
    let mut faces = Vec::with_capacity(model.faces.len() * 4);
    for t in model.faces.chunks(3) {
        let mut mid = |a: u32, b: u32| {
            let key = (a.min(b), a.max(b));
            *midpoint.entry(key).or_insert_with(|| {
                parents.push([key.0, key.1]);
                (v0 + parents.len() - 1) as u32
            })
        };
        let (a, b, c) = (t[0], t[1], t[2]);
        let (ab, bc, ca) = (mid(a, b), mid(b, c), mid(c, a));
        faces.extend_from_slice(&[a, ab, ca, ab, b, bc, ca, bc, c, ab, bc, ca]);
    }
    // Rows of `per_vertex` values per vertex, extended by midpoint averages.
    let extend = |data: &[f32], per_vertex: usize| -> Vec<f32> {
        let mut out = data.to_vec();
        out.reserve(parents.len() * per_vertex);
        for [p, q] in &parents {
            for k in 0..per_vertex {
                let x = data[*p as usize * per_vertex + k];
                let y = data[*q as usize * per_vertex + k];
                out.push(0.5 * (x + y));
            }
        }
        out
    };
    let j = model.joint_count();
    let v1 = v0 + parents.len();
    let per = |len: usize| len / v0;
    let mut regressor = vec![0.0f32; j * v1];
    for r in 0..j {
        regressor[r * v1..r * v1 + v0]
            .copy_from_slice(&model.joint_regressor[r * v0..(r + 1) * v0]);
    }
    let fine = BodyModel {
        kind: model.kind,
        template: extend(&model.template, 3),
        faces,
        joint_regressor: regressor,
        parents: model.parents.clone(),
        skin_weights: extend(&model.skin_weights, j),
        shape_dirs: extend(&model.shape_dirs, per(model.shape_dirs.len())),
        pose_dirs: model.pose_dirs.as_ref().map(|p| extend(p, per(p.len()))),
        expression_dirs: model
            .expression_dirs
            .as_ref()
            .map(|e| extend(e, per(e.len()))),
        joint_names: model.joint_names.clone(),
        // Subdivision renumbers the faces the landmarks sit on.
        face_landmarks: None,
    };
    (fine, parents)
}
