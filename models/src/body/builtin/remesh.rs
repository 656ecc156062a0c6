//! From the dense marching-tetrahedra surface to the body's mesh: shortest-edge-first edge
//! collapse down to a vertex budget, with edge lengths measured against a per-region target (so
//! the face and hands keep their detail), then tangential relaxation. Every moved vertex is put
//! back on the implicit surface.
//!
//! A collapse is only taken when the edge's two ends share exactly the two neighbours opposite
//! the edge (the link condition, which keeps a closed manifold closed and manifold) and no
//! surrounding triangle turns over, so the result stays watertight and consistently oriented.

use super::mesher::Mesh;
use super::sdf::{Body, V3, cross, dot, norm, scale, sub};
use std::cmp::Reverse;
use std::collections::BinaryHeap;

struct Work<'a> {
    body: &'a Body,
    positions: Vec<V3>,
    /// Wanted edge length at each vertex.
    target: Vec<f64>,
    faces: Vec<[u32; 3]>,
    face_alive: Vec<bool>,
    vertex_alive: Vec<bool>,
    faces_of_vertex: Vec<Vec<u32>>,
    stamp: Vec<u32>,
}

fn face_normal(p: [V3; 3]) -> V3 {
    cross(sub(p[1], p[0]), sub(p[2], p[0]))
}

impl Work<'_> {
    fn alive_faces(&self, v: u32) -> impl Iterator<Item = u32> + '_ {
        self.faces_of_vertex[v as usize]
            .iter()
            .copied()
            .filter(|&f| self.face_alive[f as usize])
    }

    fn neighbours(&self, v: u32) -> Vec<u32> {
        let mut out: Vec<u32> = self
            .alive_faces(v)
            .flat_map(|f| self.faces[f as usize])
            .filter(|&w| w != v)
            .collect();
        out.sort_unstable();
        out.dedup();
        out
    }

    fn edge_key(&self, u: u32, v: u32) -> u64 {
        let (pu, pv) = (self.positions[u as usize], self.positions[v as usize]);
        let wanted = 0.5 * (self.target[u as usize] + self.target[v as usize]);
        let ratio = norm(sub(pu, pv)) / wanted;
        // Positive finite f64s order like their bit patterns.
        ratio.to_bits()
    }

    /// Whether every face around `u` and `v` (except those on the edge) keeps its orientation
    /// when both ends move to `p`.
    fn collapse_keeps_orientation(&self, u: u32, v: u32, p: V3) -> bool {
        for w in [u, v] {
            for f in self.alive_faces(w) {
                let face = self.faces[f as usize];
                if face.contains(&u) && face.contains(&v) {
                    continue;
                }
                let old = face.map(|x| self.positions[x as usize]);
                let new = face.map(|x| {
                    if x == u || x == v {
                        p
                    } else {
                        self.positions[x as usize]
                    }
                });
                let (n_old, n_new) = (face_normal(old), face_normal(new));
                let (l_old, l_new) = (norm(n_old), norm(n_new));
                if l_new <= 1e-14 || dot(n_old, n_new) < 0.3 * l_old * l_new {
                    return false;
                }
            }
        }
        true
    }

    /// Collapses `v` into `u` at `p` if the link condition and orientation allow.
    fn try_collapse(&mut self, u: u32, v: u32) -> bool {
        let on_edge: Vec<u32> = self
            .alive_faces(u)
            .filter(|&f| self.faces[f as usize].contains(&v))
            .collect();
        if on_edge.len() != 2 {
            return false;
        }
        let apexes: Vec<u32> = on_edge
            .iter()
            .map(|&f| {
                *self.faces[f as usize]
                    .iter()
                    .find(|&&x| x != u && x != v)
                    .expect("a triangle has a third vertex")
            })
            .collect();
        let (nu, nv) = (self.neighbours(u), self.neighbours(v));
        let common: Vec<u32> = nu.iter().copied().filter(|w| nv.contains(w)).collect();
        if common.len() != 2 || !apexes.iter().all(|a| common.contains(a)) {
            return false;
        }
        let (pu, pv) = (self.positions[u as usize], self.positions[v as usize]);
        let p = self.body.project(scale(super::sdf::add(pu, pv), 0.5));
        if !self.collapse_keeps_orientation(u, v, p) {
            return false;
        }
        for f in on_edge {
            self.face_alive[f as usize] = false;
        }
        let moved: Vec<u32> = self.alive_faces(v).collect();
        for f in moved {
            for x in &mut self.faces[f as usize] {
                if *x == v {
                    *x = u;
                }
            }
            self.faces_of_vertex[u as usize].push(f);
        }
        self.faces_of_vertex[v as usize].clear();
        self.vertex_alive[v as usize] = false;
        self.positions[u as usize] = p;
        self.target[u as usize] = edge_target(self.body, p);
        self.stamp[u as usize] += 1;
        let alive: Vec<u32> = self.alive_faces(u).collect();
        self.faces_of_vertex[u as usize] = alive;
        true
    }
}

/// Edge length wanted at `p`: that of the primitive shaping the surface there.
fn edge_target(body: &Body, p: V3) -> f64 {
    body.primitives[body.nearest(p)].edge
}

type Entry = Reverse<(u64, u32, u32, u32, u32)>;

/// Collapses edges (shortest relative to their region's target first) until at most
/// `vertex_budget` vertices remain, then relaxes.
pub fn simplify(body: &Body, mesh: &Mesh, vertex_budget: usize, relax_rounds: usize) -> Mesh {
    let n = mesh.vertices.len();
    let mut faces_of_vertex = vec![Vec::new(); n];
    for (f, face) in mesh.faces.iter().enumerate() {
        for &v in face {
            faces_of_vertex[v as usize].push(f as u32);
        }
    }
    let mut work = Work {
        body,
        positions: mesh.vertices.clone(),
        target: mesh
            .vertices
            .iter()
            .map(|&p| edge_target(body, p))
            .collect(),
        faces: mesh.faces.clone(),
        face_alive: vec![true; mesh.faces.len()],
        vertex_alive: vec![true; n],
        faces_of_vertex,
        stamp: vec![0; n],
    };
    let mut heap: BinaryHeap<Entry> = BinaryHeap::new();
    for face in &mesh.faces {
        for k in 0..3 {
            let (a, b) = (face[k], face[(k + 1) % 3]);
            if a < b {
                heap.push(Reverse((work.edge_key(a, b), a, b, 0, 0)));
            }
        }
    }
    let mut alive = n;
    while alive > vertex_budget {
        let Some(Reverse((_, u, v, su, sv))) = heap.pop() else {
            break;
        };
        let (ui, vi) = (u as usize, v as usize);
        if !work.vertex_alive[ui] || !work.vertex_alive[vi] {
            continue;
        }
        if work.stamp[ui] != su || work.stamp[vi] != sv {
            continue;
        }
        if !work.try_collapse(u, v) {
            continue;
        }
        alive -= 1;
        for w in work.neighbours(u) {
            let (a, b) = (u.min(w), u.max(w));
            let key = work.edge_key(a, b);
            heap.push(Reverse((
                key,
                a,
                b,
                work.stamp[a as usize],
                work.stamp[b as usize],
            )));
        }
    }
    for _ in 0..relax_rounds {
        flip_to_delaunay(&mut work);
        relax(&mut work);
    }
    flip_to_delaunay(&mut work);
    compact(&work)
}

/// One Gauss–Seidel round of tangential smoothing: each vertex moves half-way towards its
/// neighbours' centroid within its tangent plane, back onto the surface, unless that would turn
/// an adjacent triangle over.
fn relax(work: &mut Work) {
    for v in 0..work.positions.len() as u32 {
        if !work.vertex_alive[v as usize] {
            continue;
        }
        let nb = work.neighbours(v);
        if nb.is_empty() {
            continue;
        }
        let p = work.positions[v as usize];
        let mut c = [0.0; 3];
        for &w in &nb {
            let q = work.positions[w as usize];
            for k in 0..3 {
                c[k] += q[k] / nb.len() as f64;
            }
        }
        let g = work.body.gradient(p);
        let gn = norm(g);
        if gn == 0.0 {
            continue;
        }
        let nrm = scale(g, 1.0 / gn);
        let step = scale(sub(c, p), 0.5);
        let tangential = sub(step, scale(nrm, dot(step, nrm)));
        let candidate = work.body.project(super::sdf::add(p, tangential));
        let ok = work.alive_faces(v).all(|f| {
            let face = work.faces[f as usize];
            let old = face.map(|x| work.positions[x as usize]);
            let new = face.map(|x| {
                if x == v {
                    candidate
                } else {
                    work.positions[x as usize]
                }
            });
            let (a, b) = (face_normal(old), face_normal(new));
            dot(a, b) > 0.5 * norm(a) * norm(b)
        });
        if ok {
            work.positions[v as usize] = candidate;
        }
    }
}

fn angle_at(o: V3, a: V3, b: V3) -> f64 {
    let (u, w) = (sub(a, o), sub(b, o));
    let c = dot(u, w) / (norm(u) * norm(w));
    c.clamp(-1.0, 1.0).acos()
}

/// One pass of edge flips towards the intrinsic Delaunay condition: an edge whose two opposite
/// angles sum to more than π is replaced by the other diagonal of its two triangles, unless
/// that diagonal already exists or the new triangles would bend away from the old ones. Removes
/// the obtuse slivers that collapse and relaxation leave.
fn flip_to_delaunay(work: &mut Work) {
    for f in 0..work.faces.len() {
        if !work.face_alive[f] {
            continue;
        }
        for k in 0..3 {
            let face = work.faces[f];
            let (a, b, c) = (face[k], face[(k + 1) % 3], face[(k + 2) % 3]);
            let Some(g) = work
                .alive_faces(a)
                .find(|&g| g as usize != f && work.faces[g as usize].contains(&b))
            else {
                continue;
            };
            let other = work.faces[g as usize];
            let d = *other
                .iter()
                .find(|&&x| x != a && x != b)
                .expect("a triangle has a third vertex");
            if d == c || work.neighbours(c).contains(&d) {
                continue;
            }
            let p = |x: u32| work.positions[x as usize];
            if angle_at(p(c), p(a), p(b)) + angle_at(p(d), p(a), p(b))
                <= std::f64::consts::PI + 1e-9
            {
                continue;
            }
            let before = super::sdf::add(
                face_normal([p(a), p(b), p(c)]),
                face_normal([p(b), p(a), p(d)]),
            );
            let new_f = [c, a, d];
            let new_g = [d, b, c];
            let bends = [new_f, new_g].iter().any(|t| {
                let n = face_normal(t.map(p));
                dot(n, before) <= 0.5 * norm(n) * norm(before)
            });
            if bends {
                continue;
            }
            work.faces[f] = new_f;
            work.faces[g as usize] = new_g;
            work.faces_of_vertex[a as usize].retain(|&x| x != g);
            work.faces_of_vertex[b as usize].retain(|&x| x as usize != f);
            work.faces_of_vertex[c as usize].push(g);
            work.faces_of_vertex[d as usize].push(f as u32);
            break;
        }
    }
}

/// Drops dead vertices and faces, renumbering the rest in their original order.
fn compact(work: &Work) -> Mesh {
    let mut new_from_old = vec![u32::MAX; work.positions.len()];
    let mut vertices = Vec::new();
    for (v, &alive) in work.vertex_alive.iter().enumerate() {
        if alive {
            new_from_old[v] = vertices.len() as u32;
            vertices.push(work.positions[v]);
        }
    }
    let faces = work
        .faces
        .iter()
        .zip(&work.face_alive)
        .filter(|(_, alive)| **alive)
        .map(|(f, _)| f.map(|x| new_from_old[x as usize]))
        .collect();
    Mesh { vertices, faces }
}
