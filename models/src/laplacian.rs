//! The uniform (umbrella) Laplacian of a triangle mesh, `(L v)_i = v_i − mean_{j ∈ N(i)} v_j`
//! over each vertex's edge neighbours, and the smoothness energy `(1/V) Σ_i ‖(L v)_i‖²` a mesh
//! refinement is regularised with (iHuman's mesh term). The neighbour lists are built once
//! from the faces ([`UniformLaplacian::new`], CSR); applying it is one gather and one
//! scatter-add in Burn ops, so the energy's gradient reaches the vertices.
//! [`UniformLaplacian::apply_reference`] is the same rule in scalar f64.

use burn::tensor::{Device, IndexingUpdateOp, Int, Tensor, TensorData};
use std::collections::BTreeSet;

/// Each vertex's edge neighbours, CSR: `neighbours[offsets[i]..offsets[i + 1]]`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UniformLaplacian {
    pub offsets: Vec<usize>,
    pub neighbours: Vec<u32>,
}

impl UniformLaplacian {
    /// Neighbour lists of `vertex_count` vertices from triangles (`3 F` indices); a vertex no
    /// face touches has none (its Laplacian is zero).
    pub fn new(vertex_count: usize, faces: &[u32]) -> Self {
        assert_eq!(faces.len() % 3, 0, "faces must hold 3 indices per triangle");
        let mut sets = vec![BTreeSet::new(); vertex_count];
        for t in faces.chunks(3) {
            for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                assert!(
                    (a as usize) < vertex_count && (b as usize) < vertex_count,
                    "a face indexes a vertex beyond {vertex_count}"
                );
                if a != b {
                    sets[a as usize].insert(b);
                    sets[b as usize].insert(a);
                }
            }
        }
        let mut offsets = Vec::with_capacity(vertex_count + 1);
        let mut neighbours = Vec::new();
        offsets.push(0);
        for set in sets {
            neighbours.extend(set);
            offsets.push(neighbours.len());
        }
        Self {
            offsets,
            neighbours,
        }
    }

    pub fn vertex_count(&self) -> usize {
        self.offsets.len() - 1
    }

    /// `L v` `[B, V, 3]` of vertices `[B, V, 3]`.
    pub fn apply(&self, vertices: Tensor<3>) -> Tensor<3> {
        let [b, v, d] = vertices.dims();
        assert_eq!(
            v,
            self.vertex_count(),
            "the Laplacian was built for {} vertices",
            self.vertex_count()
        );
        let device = vertices.device();
        let (rows, columns, weights) = self.edge_tensors(&device);
        let e = self.neighbours.len();
        let weighted = vertices.clone().select(1, columns) * weights.reshape([1, e, 1]);
        let mean = Tensor::<3>::zeros([b, v, d], &device).select_assign(
            1,
            rows,
            weighted,
            IndexingUpdateOp::Add,
        );
        // Isolated vertices have no neighbours: their mean is themselves.
        let isolated = self.isolated_mask(&device).reshape([1, v, 1]);
        vertices.clone() - mean - vertices * isolated
    }

    /// `(1/V) Σ_i ‖(L v)_i‖²`, averaged over the batch: `[1]`.
    pub fn energy(&self, vertices: Tensor<3>) -> Tensor<1> {
        self.apply(vertices).powi_scalar(2).sum_dim(2).mean()
    }

    /// The row (vertex), column (neighbour) and weight `1/|N(i)|` of every CSR entry.
    fn edge_tensors(&self, device: &Device) -> (Tensor<1, Int>, Tensor<1, Int>, Tensor<1>) {
        let e = self.neighbours.len();
        let mut rows = Vec::with_capacity(e);
        let mut weights = Vec::with_capacity(e);
        for i in 0..self.vertex_count() {
            let degree = self.offsets[i + 1] - self.offsets[i];
            for _ in 0..degree {
                rows.push(i as i64);
                weights.push(1.0 / degree as f32);
            }
        }
        let columns: Vec<i64> = self.neighbours.iter().map(|&j| j as i64).collect();
        (
            Tensor::<1, Int>::from_data(TensorData::new(rows, [e]), device),
            Tensor::<1, Int>::from_data(TensorData::new(columns, [e]), device),
            Tensor::<1>::from_data(TensorData::new(weights, [e]), device),
        )
    }

    fn isolated_mask(&self, device: &Device) -> Tensor<1> {
        let mask: Vec<f32> = (0..self.vertex_count())
            .map(|i| f32::from(u8::from(self.offsets[i + 1] == self.offsets[i])))
            .collect();
        let v = mask.len();
        Tensor::<1>::from_data(TensorData::new(mask, [v]), device)
    }

    /// [`Self::apply`] of one mesh in f64.
    pub fn apply_reference(&self, vertices: &[[f64; 3]]) -> Vec<[f64; 3]> {
        (0..self.vertex_count())
            .map(|i| {
                let around = &self.neighbours[self.offsets[i]..self.offsets[i + 1]];
                if around.is_empty() {
                    return [0.0; 3];
                }
                std::array::from_fn(|k| {
                    let mean = around.iter().map(|&j| vertices[j as usize][k]).sum::<f64>()
                        / around.len() as f64;
                    vertices[i][k] - mean
                })
            })
            .collect()
    }
}
