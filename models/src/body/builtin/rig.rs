//! Rigging the meshed body: which bone owns each vertex, smooth skinning weights, the binding
//! of the surface to the bones that makes shape components exact blend shapes, and a joint
//! regressor that reproduces the skeleton from the vertices for every shape.

use super::mesher::Mesh;
use super::proportions::{JOINTS, Radial, SHAPE_COUNT, Skeleton};
use super::sdf::{Body, V3, dot, norm, scale, sub};

/// Rounds of neighbour averaging that turn the hard bone labels into skinning weights; with
/// 2 cm edges on the limbs, the blend reaches about 6 cm either side of a joint.
const WEIGHT_SMOOTHING_ROUNDS: usize = 16;
/// Bones a vertex may follow at most (as in SMPL's released weights).
const MAX_INFLUENCES: usize = 4;
/// Vertices around each joint that the regressor reads.
const REGRESSOR_SUPPORT: usize = 64;

/// Closest point parameter on the segment `a`–`b` (clamped) and the distance to it.
fn segment_distance(p: V3, a: V3, b: V3) -> f64 {
    let ab = sub(b, a);
    let t = (dot(sub(p, a), ab) / dot(ab, ab)).clamp(0.0, 1.0);
    norm(sub(p, super::sdf::add(a, scale(ab, t))))
}

/// The joint whose bone owns each vertex: among the joints the nearest primitive allows, the
/// one whose bone segment is closest.
pub fn bone_labels(body: &Body, mesh: &Mesh, skeleton: &Skeleton) -> Vec<u8> {
    mesh.vertices
        .iter()
        .map(|&p| {
            let prim = &body.primitives[body.nearest(p)];
            let mut best = (f64::INFINITY, prim.joints[0]);
            for &j in &prim.joints {
                let d = segment_distance(p, skeleton.heads[j], skeleton.tails[j]);
                if d < best.0 {
                    best = (d, j);
                }
            }
            best.1 as u8
        })
        .collect()
}

/// Sorted neighbour lists of every vertex.
pub fn vertex_neighbours(mesh: &Mesh) -> Vec<Vec<u32>> {
    let mut nb = vec![Vec::new(); mesh.vertices.len()];
    for f in &mesh.faces {
        for k in 0..3 {
            nb[f[k] as usize].push(f[(k + 1) % 3]);
            nb[f[k] as usize].push(f[(k + 2) % 3]);
        }
    }
    for list in &mut nb {
        list.sort_unstable();
        list.dedup();
    }
    nb
}

/// `[V, J]` skinning weights: one-hot labels diffused over the mesh, then the largest
/// `MAX_INFLUENCES` kept and renormalised.
pub fn skinning_weights(labels: &[u8], neighbours: &[Vec<u32>]) -> Vec<f64> {
    let v = labels.len();
    let mut w = vec![0.0f64; v * JOINTS];
    for (i, &l) in labels.iter().enumerate() {
        w[i * JOINTS + l as usize] = 1.0;
    }
    for _ in 0..WEIGHT_SMOOTHING_ROUNDS {
        let mut next = vec![0.0f64; v * JOINTS];
        for i in 0..v {
            let nb = &neighbours[i];
            for j in 0..JOINTS {
                let mean: f64 =
                    nb.iter().map(|&n| w[n as usize * JOINTS + j]).sum::<f64>() / nb.len() as f64;
                next[i * JOINTS + j] = 0.5 * w[i * JOINTS + j] + 0.5 * mean;
            }
        }
        w = next;
    }
    for row in w.chunks_mut(JOINTS) {
        let mut order: Vec<usize> = (0..JOINTS).collect();
        order.sort_by(|&a, &b| row[b].total_cmp(&row[a]).then(a.cmp(&b)));
        for &j in &order[MAX_INFLUENCES..] {
            row[j] = 0.0;
        }
        let total: f64 = row.iter().sum();
        for x in row.iter_mut() {
            *x /= total;
        }
    }
    w
}

/// A vertex bound to one bone: where it projects on the bone's line and its offset from it.
#[derive(Debug, Clone, Copy)]
struct Binding {
    joint: usize,
    weight: f64,
    along: f64,
    offset: V3,
}

fn apply_radial(radial: &Radial, r: V3) -> V3 {
    let z = if r[2] > 0.0 { radial[2] } else { radial[3] };
    [radial[0] * r[0], radial[1] * r[1], z * r[2]]
}

/// The surface bound to the mean skeleton through the skinning weights.
pub struct SurfaceBinding {
    bindings: Vec<Vec<Binding>>,
}

impl SurfaceBinding {
    pub fn new(mesh: &Mesh, weights: &[f64], mean: &Skeleton) -> Self {
        let bindings = mesh
            .vertices
            .iter()
            .enumerate()
            .map(|(i, &p)| {
                (0..JOINTS)
                    .filter(|&j| weights[i * JOINTS + j] > 0.0)
                    .map(|j| {
                        let (a, b) = (mean.heads[j], mean.tails[j]);
                        let ab = sub(b, a);
                        let along = dot(sub(p, a), ab) / dot(ab, ab);
                        let offset = sub(sub(p, a), scale(ab, along));
                        Binding {
                            joint: j,
                            weight: weights[i * JOINTS + j],
                            along,
                            offset,
                        }
                    })
                    .collect()
            })
            .collect();
        Self { bindings }
    }

    /// Vertex positions for a skeleton: each bone carries its vertices (along its line, and
    /// radially scaled), blended by the weights. Reproduces the mesh for the mean skeleton.
    pub fn positions(&self, skeleton: &Skeleton) -> Vec<V3> {
        self.bindings
            .iter()
            .map(|binds| {
                let mut p = [0.0; 3];
                for b in binds {
                    let (a, t) = (skeleton.heads[b.joint], skeleton.tails[b.joint]);
                    let on_line = super::sdf::add(a, scale(sub(t, a), b.along));
                    let x =
                        super::sdf::add(on_line, apply_radial(&skeleton.radial[b.joint], b.offset));
                    for k in 0..3 {
                        p[k] += b.weight * x[k];
                    }
                }
                p
            })
            .collect()
    }
}

/// `[V, 3, S]` shape directions: the displacement of every vertex per unit of each component.
pub fn shape_directions(binding: &SurfaceBinding, rest: &[V3]) -> Vec<f64> {
    let v = rest.len();
    let mut dirs = vec![0.0; v * 3 * SHAPE_COUNT];
    for s in 0..SHAPE_COUNT {
        let mut betas = [0.0; SHAPE_COUNT];
        betas[s] = 1.0;
        let moved = binding.positions(&Skeleton::shaped(&betas));
        for i in 0..v {
            for k in 0..3 {
                dirs[(i * 3 + k) * SHAPE_COUNT + s] = moved[i][k] - rest[i][k];
            }
        }
    }
    dirs
}

/// `[J, V]` joint regressor. Each joint reads the `REGRESSOR_SUPPORT` vertices nearest to it,
/// with the weights closest to uniform that reproduce the joint exactly for the mean body and for
/// every shape direction (so it holds for every shape, the model being affine in them).
pub fn joint_regressor(rest: &[V3], shape_dirs: &[f64], mean: &Skeleton) -> Vec<f64> {
    let v = rest.len();
    let mut regressor = vec![0.0; JOINTS * v];
    for j in 0..JOINTS {
        let joint = mean.heads[j];
        let mut order: Vec<usize> = (0..v).collect();
        order.sort_by(|&a, &b| {
            norm(sub(rest[a], joint))
                .total_cmp(&norm(sub(rest[b], joint)))
                .then(a.cmp(&b))
        });
        let support = &order[..REGRESSOR_SUPPORT.min(v)];
        let k = support.len();
        // Constraint rows: sum of weights, the joint's 3 coordinates, and per shape component
        // the joint's displacement (3 rows each).
        let mut rows: Vec<(Vec<f64>, f64)> = Vec::new();
        rows.push((vec![1.0; k], 1.0));
        for c in 0..3 {
            rows.push((support.iter().map(|&i| rest[i][c]).collect(), joint[c]));
        }
        for s in 0..SHAPE_COUNT {
            let mut betas = [0.0; SHAPE_COUNT];
            betas[s] = 1.0;
            let moved = Skeleton::shaped(&betas).heads[j];
            for c in 0..3 {
                let row: Vec<f64> = support
                    .iter()
                    .map(|&i| shape_dirs[(i * 3 + c) * SHAPE_COUNT + s])
                    .collect();
                rows.push((row, moved[c] - joint[c]));
            }
        }
        let w0 = vec![1.0 / k as f64; k];
        let weights = closest_satisfying(&rows, &w0);
        for (&i, w) in support.iter().zip(weights) {
            regressor[j * v + i] = w;
        }
    }
    regressor
}

/// The vector nearest `w0` (least squares) satisfying the linear constraints `rows`
/// (`row · w = rhs`), via the normal equations with a tiny ridge for redundant rows.
fn closest_satisfying(rows: &[(Vec<f64>, f64)], w0: &[f64]) -> Vec<f64> {
    let m = rows.len();
    let residual: Vec<f64> = rows
        .iter()
        .map(|(a, rhs)| rhs - a.iter().zip(w0).map(|(x, y)| x * y).sum::<f64>())
        .collect();
    let mut gram = vec![0.0; m * m];
    for p in 0..m {
        for q in 0..m {
            gram[p * m + q] = rows[p].0.iter().zip(&rows[q].0).map(|(x, y)| x * y).sum();
        }
    }
    let trace: f64 = (0..m).map(|p| gram[p * m + p]).sum();
    for p in 0..m {
        gram[p * m + p] += 1e-13 * trace;
    }
    let lambda = solve_spd(&mut gram, residual, m);
    let mut w = w0.to_vec();
    for (p, (a, _)) in rows.iter().enumerate() {
        for (wi, ai) in w.iter_mut().zip(a) {
            *wi += lambda[p] * ai;
        }
    }
    w
}

/// Solves a symmetric positive-definite system by Cholesky factorisation (in place).
fn solve_spd(a: &mut [f64], mut b: Vec<f64>, n: usize) -> Vec<f64> {
    for j in 0..n {
        let mut d = a[j * n + j];
        for k in 0..j {
            d -= a[j * n + k] * a[j * n + k];
        }
        let d = d.max(1e-300).sqrt();
        a[j * n + j] = d;
        for i in j + 1..n {
            let mut s = a[i * n + j];
            for k in 0..j {
                s -= a[i * n + k] * a[j * n + k];
            }
            a[i * n + j] = s / d;
        }
    }
    for i in 0..n {
        let mut s = b[i];
        for k in 0..i {
            s -= a[i * n + k] * b[k];
        }
        b[i] = s / a[i * n + i];
    }
    for i in (0..n).rev() {
        let mut s = b[i];
        for k in i + 1..n {
            s -= a[k * n + i] * b[k];
        }
        b[i] = s / a[i * n + i];
    }
    b
}
