//! A texture parameterisation of the built-in body: one chart per bone, unrolled around the
//! bone's axis (arc length × length along the bone, so texel density is the same everywhere),
//! charts shelf-packed into the unit square. Corners carry their own coordinates (as OBJ's `vt`
//! and SMPL's `ft` do), so seams split texture coordinates without splitting the mesh.

use super::mesher::Mesh;
use super::proportions::{JOINTS, Skeleton};
use super::sdf::{V3, cross, dot, norm, normalize, scale, sub};
use std::f64::consts::PI;

/// Gap between charts, metres of surface.
const PADDING: f64 = 0.01;

/// Texture coordinates per face corner.
#[derive(Debug, Clone)]
pub struct UvMap {
    /// `[T, 2]` coordinates in [0, 1]², v up.
    pub coords: Vec<f32>,
    /// `[F, 3]` indices into `coords` for each face's corners.
    pub faces: Vec<u32>,
}

struct Chart {
    axis_origin: V3,
    axis: V3,
    e1: V3,
    e2: V3,
    radius: f64,
}

impl Chart {
    fn new(skeleton: &Skeleton, j: usize, radius: f64) -> Self {
        let (a, b) = (skeleton.heads[j], skeleton.tails[j]);
        let d = sub(b, a);
        let axis = normalize(d);
        // Seam at the back (−z); along z-ish bones (feet), on the sole (−y).
        let reference = if axis[2].abs() > 0.7 {
            [0.0, 1.0, 0.0]
        } else {
            [0.0, 0.0, 1.0]
        };
        let e1 = normalize(sub(reference, scale(axis, dot(reference, axis))));
        let e2 = cross(axis, e1);
        Self {
            axis_origin: a,
            axis,
            e1,
            e2,
            radius,
        }
    }

    /// (arc length around, length along) in metres.
    fn unroll(&self, p: V3) -> (f64, f64) {
        let r = sub(p, self.axis_origin);
        let along = dot(r, self.axis);
        let theta = dot(r, self.e2).atan2(dot(r, self.e1));
        (theta * self.radius, along)
    }
}

/// The chart of a face: the bone most of its corners belong to (the first corner's on a tie).
fn face_chart(face: &[u32; 3], labels: &[u8]) -> usize {
    let l = face.map(|v| labels[v as usize]);
    if l[1] == l[2] {
        l[1] as usize
    } else {
        l[0] as usize
    }
}

pub fn unwrap(mesh: &Mesh, labels: &[u8], skeleton: &Skeleton) -> UvMap {
    // Mean distance from each bone's axis of the vertices it owns.
    let mut sum = [0.0f64; JOINTS];
    let mut count = [0usize; JOINTS];
    for (p, &l) in mesh.vertices.iter().zip(labels) {
        let j = l as usize;
        let (a, b) = (skeleton.heads[j], skeleton.tails[j]);
        let axis = normalize(sub(b, a));
        let r = sub(*p, a);
        sum[j] += norm(sub(r, scale(axis, dot(r, axis))));
        count[j] += 1;
    }
    let charts: Vec<Chart> = (0..JOINTS)
        .map(|j| Chart::new(skeleton, j, sum[j] / count[j].max(1) as f64 + 1e-3))
        .collect();

    // Unrolled corners, with angles unwrapped relative to each face's first corner.
    let mut corners: Vec<(usize, [(f64, f64); 3])> = Vec::with_capacity(mesh.faces.len());
    for face in &mesh.faces {
        let j = face_chart(face, labels);
        let chart = &charts[j];
        let mut uv = face.map(|v| chart.unroll(mesh.vertices[v as usize]));
        let period = 2.0 * PI * chart.radius;
        for k in 1..3 {
            while uv[k].0 - uv[0].0 > 0.5 * period {
                uv[k].0 -= period;
            }
            while uv[0].0 - uv[k].0 > 0.5 * period {
                uv[k].0 += period;
            }
        }
        corners.push((j, uv));
    }

    // Chart extents, then shelf packing (tallest first).
    let mut lo = [(f64::INFINITY, f64::INFINITY); JOINTS];
    let mut hi = [(f64::NEG_INFINITY, f64::NEG_INFINITY); JOINTS];
    for (j, uv) in &corners {
        for &(u, v) in uv {
            lo[*j] = (lo[*j].0.min(u), lo[*j].1.min(v));
            hi[*j] = (hi[*j].0.max(u), hi[*j].1.max(v));
        }
    }
    let used: Vec<usize> = (0..JOINTS).filter(|&j| lo[j].0.is_finite()).collect();
    let size = |j: usize| (hi[j].0 - lo[j].0 + PADDING, hi[j].1 - lo[j].1 + PADDING);
    let area: f64 = used.iter().map(|&j| size(j).0 * size(j).1).sum();
    let shelf_width = (area * 1.2)
        .sqrt()
        .max(used.iter().map(|&j| size(j).0).fold(0.0, f64::max));
    let mut order = used.clone();
    order.sort_by(|&a, &b| size(b).1.total_cmp(&size(a).1).then(a.cmp(&b)));
    let mut origin = [(0.0f64, 0.0f64); JOINTS];
    let (mut x, mut y, mut shelf_height) = (0.0f64, 0.0f64, 0.0f64);
    for &j in &order {
        let (w, h) = size(j);
        if x + w > shelf_width && x > 0.0 {
            x = 0.0;
            y += shelf_height;
            shelf_height = 0.0;
        }
        origin[j] = (x + 0.5 * PADDING, y + 0.5 * PADDING);
        x += w;
        shelf_height = shelf_height.max(h);
    }
    let extent = shelf_width.max(y + shelf_height);

    let mut coords = Vec::with_capacity(corners.len() * 6);
    let mut faces = Vec::with_capacity(corners.len() * 3);
    for (j, uv) in &corners {
        for &(u, v) in uv {
            faces.push((coords.len() / 2) as u32);
            coords.push(((origin[*j].0 + u - lo[*j].0) / extent) as f32);
            coords.push(((origin[*j].1 + v - lo[*j].1) / extent) as f32);
        }
    }
    UvMap { coords, faces }
}
