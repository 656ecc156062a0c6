//! Per-vertex normals of triangle meshes: the area-weighted mean of the incident faces' normals
//! (each face contributes its unnormalised cross product `(b − a) × (c − a)`, whose length is
//! twice its area), normalised. [`vertex_normals`] is differentiable Burn ops (a gather per
//! corner, cross products, one scatter-add per corner) so a loss on rendered normals reaches
//! the vertex positions; [`vertex_normals_reference`] is the same rule in scalar f64 for tests.
//! Winding is right-handed: counter-clockwise seen from outside gives outward normals.

use burn::tensor::{Device, IndexingUpdateOp, Int, Tensor, TensorData};

/// Added to a summed normal's squared length before the root, so a zero sum (a vertex no face
/// touches) gives the zero vector with a zero gradient instead of a NaN. A fan that collapses to
/// zero area still gets a finite gradient, but a large one: its normal is undefined there.
pub const NORMAL_EPS: f64 = 1e-30;

/// One corner's vertex index per face, `[F]`.
fn corner_indices(faces: &[u32], corner: usize, device: &Device) -> Tensor<1, Int> {
    let idx: Vec<i64> = faces.chunks(3).map(|t| t[corner] as i64).collect();
    let f = idx.len();
    Tensor::<1, Int>::from_data(TensorData::new(idx, [f]), device)
}

/// `u × v` over the last axis of `[B, N, 3]` tensors.
pub fn cross(u: Tensor<3>, v: Tensor<3>) -> Tensor<3> {
    let [b, n, _] = u.dims();
    let comp = |t: &Tensor<3>, k: usize| t.clone().slice([0..b, 0..n, k..k + 1]);
    Tensor::cat(
        vec![
            comp(&u, 1) * comp(&v, 2) - comp(&u, 2) * comp(&v, 1),
            comp(&u, 2) * comp(&v, 0) - comp(&u, 0) * comp(&v, 2),
            comp(&u, 0) * comp(&v, 1) - comp(&u, 1) * comp(&v, 0),
        ],
        2,
    )
}

/// Unit area-weighted vertex normals `[B, V, 3]` of meshes `[B, V, 3]` sharing `faces`
/// (`3 F` indices). Vertices no face touches get the zero vector.
pub fn vertex_normals(vertices: Tensor<3>, faces: &[u32]) -> Tensor<3> {
    let [b, v, d] = vertices.dims();
    assert_eq!(d, 3, "vertices must be [B, V, 3]");
    assert_eq!(faces.len() % 3, 0, "faces must hold 3 indices per triangle");
    assert!(
        faces.iter().all(|&i| (i as usize) < v),
        "a face index is out of range for {v} vertices"
    );
    let device = vertices.device();
    let corners: Vec<Tensor<1, Int>> = (0..3).map(|c| corner_indices(faces, c, &device)).collect();
    let at = |c: usize| vertices.clone().select(1, corners[c].clone());
    let (a, bb, c) = (at(0), at(1), at(2));
    let face_normals = cross(bb - a.clone(), c - a); // [B, F, 3], length = 2 · area
    let mut sum = Tensor::<3>::zeros([b, v, 3], &device);
    for idx in corners {
        sum = sum.select_assign(1, idx, face_normals.clone(), IndexingUpdateOp::Add);
    }
    // The eps inside the root keeps zero sums at zero with a finite gradient.
    let length = (sum.clone().powi_scalar(2).sum_dim(2) + NORMAL_EPS).sqrt();
    sum / length
}

/// [`vertex_normals`] in f64, one mesh.
pub fn vertex_normals_reference(vertices: &[[f64; 3]], faces: &[u32]) -> Vec<[f64; 3]> {
    let mut sum = vec![[0.0f64; 3]; vertices.len()];
    for t in faces.chunks(3) {
        let [a, b, c] = [t[0], t[1], t[2]].map(|i| vertices[i as usize]);
        let e1 = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let e2 = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
        let n = [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ];
        for &i in t {
            for k in 0..3 {
                sum[i as usize][k] += n[k];
            }
        }
    }
    sum.into_iter()
        .map(|n| {
            let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            if l * l <= NORMAL_EPS {
                [0.0; 3]
            } else {
                [n[0] / l, n[1] / l, n[2] / l]
            }
        })
        .collect()
}
