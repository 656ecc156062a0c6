//! Marching tetrahedra: the zero set of a signed distance sampled on a lattice, as a closed,
//! consistently oriented triangle mesh.
//!
//! Each lattice cube is split into six tetrahedra around its main diagonal (the Kuhn split),
//! which every neighbouring cube splits the same way, so there is no ambiguous case and the
//! surface has no cracks: every edge of the output is shared by exactly two triangles as long as
//! the surface stays inside the lattice. Vertices sit on lattice edges and are shared through the
//! edge's two lattice-point ids.

use super::sdf::{Body, V3, cross, dot, sub};
use rayon::prelude::*;
use std::collections::HashMap;

/// An indexed triangle mesh in f64.
#[derive(Debug, Clone, Default)]
pub struct Mesh {
    pub vertices: Vec<V3>,
    pub faces: Vec<[u32; 3]>,
}

/// The six tetrahedra of a cube, as corner bit masks (x = 1, y = 2, z = 4).
const KUHN: [[usize; 4]; 6] = [
    [0, 1, 3, 7],
    [0, 1, 5, 7],
    [0, 2, 3, 7],
    [0, 2, 6, 7],
    [0, 4, 5, 7],
    [0, 4, 6, 7],
];

/// Meshes `body`'s surface on a lattice of spacing `h`.
pub fn march(body: &Body, h: f64) -> Mesh {
    let (lo, hi) = body.bounds(2.0 * h);
    let n: [usize; 3] = std::array::from_fn(|k| ((hi[k] - lo[k]) / h).ceil() as usize + 1);
    let point = |i: usize, j: usize, k: usize| -> V3 {
        [
            lo[0] + i as f64 * h,
            lo[1] + j as f64 * h,
            lo[2] + k as f64 * h,
        ]
    };
    // Values, z-slab by z-slab in parallel. Exact zeros count as outside.
    let values: Vec<f64> = (0..n[2])
        .into_par_iter()
        .flat_map_iter(|k| {
            (0..n[1]).flat_map(move |j| (0..n[0]).map(move |i| body.distance(point(i, j, k))))
        })
        .collect();
    let id = |i: usize, j: usize, k: usize| (k * n[1] + j) * n[0] + i;

    let mut vertex_of_edge: HashMap<(usize, usize), u32> = HashMap::new();
    let mut mesh = Mesh::default();
    let mut edge_vertex =
        |a: usize, pa: V3, fa: f64, b: usize, pb: V3, fb: f64, mesh: &mut Mesh| {
            let key = (a.min(b), a.max(b));
            *vertex_of_edge.entry(key).or_insert_with(|| {
                let t = fa / (fa - fb);
                let p = [
                    pa[0] + t * (pb[0] - pa[0]),
                    pa[1] + t * (pb[1] - pa[1]),
                    pa[2] + t * (pb[2] - pa[2]),
                ];
                mesh.vertices.push(p);
                (mesh.vertices.len() - 1) as u32
            })
        };
    for k in 0..n[2] - 1 {
        for j in 0..n[1] - 1 {
            for i in 0..n[0] - 1 {
                let corner_id: [usize; 8] = std::array::from_fn(|c| {
                    id(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1))
                });
                let inside: [bool; 8] = std::array::from_fn(|c| values[corner_id[c]] < 0.0);
                if inside.iter().all(|&x| x) || inside.iter().all(|&x| !x) {
                    continue;
                }
                let corner_pos: [V3; 8] = std::array::from_fn(|c| {
                    point(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1))
                });
                for tet in KUHN {
                    let ins: Vec<usize> = tet.iter().copied().filter(|&c| inside[c]).collect();
                    let outs: Vec<usize> = tet.iter().copied().filter(|&c| !inside[c]).collect();
                    if ins.is_empty() || outs.is_empty() {
                        continue;
                    }
                    let mut v = |a: usize, b: usize, mesh: &mut Mesh| {
                        edge_vertex(
                            corner_id[a],
                            corner_pos[a],
                            values[corner_id[a]],
                            corner_id[b],
                            corner_pos[b],
                            values[corner_id[b]],
                            mesh,
                        )
                    };
                    // Outward direction: from the inside corners to the outside ones.
                    let centroid = |cs: &[usize]| {
                        let mut c = [0.0; 3];
                        for &x in cs {
                            for d in 0..3 {
                                c[d] += corner_pos[x][d] / cs.len() as f64;
                            }
                        }
                        c
                    };
                    let outward = sub(centroid(&outs), centroid(&ins));
                    // Each triangle as pairs of (inside, outside) corners on its edges. The
                    // orientation is decided on the edges' midpoints, which never degenerate
                    // (the interpolated vertices can, where the surface passes a corner).
                    let tris: Vec<[(usize, usize); 3]> = match (ins.len(), outs.len()) {
                        (1, 3) => vec![[(ins[0], outs[0]), (ins[0], outs[1]), (ins[0], outs[2])]],
                        (3, 1) => vec![[(ins[0], outs[0]), (ins[1], outs[0]), (ins[2], outs[0])]],
                        _ => {
                            // Quad a-c, a-d, b-d, b-c around the tetrahedron's waist.
                            let (a, b, c, d) = (ins[0], ins[1], outs[0], outs[1]);
                            vec![[(a, c), (a, d), (b, d)], [(a, c), (b, d), (b, c)]]
                        }
                    };
                    for mut tri in tris {
                        let mid = |(a, b): (usize, usize)| {
                            let (pa, pb) = (corner_pos[a], corner_pos[b]);
                            [
                                0.5 * (pa[0] + pb[0]),
                                0.5 * (pa[1] + pb[1]),
                                0.5 * (pa[2] + pb[2]),
                            ]
                        };
                        let normal =
                            cross(sub(mid(tri[1]), mid(tri[0])), sub(mid(tri[2]), mid(tri[0])));
                        if dot(normal, outward) < 0.0 {
                            tri.swap(1, 2);
                        }
                        let t = tri.map(|(a, b)| v(a, b, &mut mesh));
                        mesh.faces.push(t);
                    }
                }
            }
        }
    }
    mesh
}
