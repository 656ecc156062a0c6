//! The triangle rasteriser at the heart of the mesh renderer: which triangle is nearest at each
//! pixel centre, and where on it (perspective-correct barycentrics), for a perspective or an
//! orthographic view. Triangles are clipped against the near plane first; rows are split into
//! bands rendered in parallel. Equal depths keep the earlier triangle, so output does not depend
//! on thread count.

use rayon::prelude::*;

pub type V3 = [f64; 3];

/// How view space (x right, y down, z forward) maps to pixels.
#[derive(Debug, Clone, Copy)]
pub enum Projection {
    /// `(fx x / z + cx, fy y / z + cy)`.
    Perspective { fx: f64, fy: f64, cx: f64, cy: f64 },
    /// `(sx x + cx, sy y + cy)`.
    Orthographic { sx: f64, sy: f64, cx: f64, cy: f64 },
}

/// A view of the scene: a rigid world → view transform, a projection, an image size and a
/// depth range.
#[derive(Debug, Clone, Copy)]
pub struct View {
    /// Rows `[R | t]`: `x_view = R x_world + t`.
    pub world_to_view: [[f64; 4]; 3],
    pub projection: Projection,
    pub width: usize,
    pub height: usize,
    pub near: f64,
    pub far: f64,
}

impl View {
    pub fn to_view(&self, p: V3) -> V3 {
        let m = &self.world_to_view;
        std::array::from_fn(|r| m[r][0] * p[0] + m[r][1] * p[1] + m[r][2] * p[2] + m[r][3])
    }

    /// Pixel coordinates of a view-space point (pixel centres at +0.5).
    pub fn project(&self, q: V3) -> [f64; 2] {
        match self.projection {
            Projection::Perspective { fx, fy, cx, cy } => {
                [fx * q[0] / q[2] + cx, fy * q[1] / q[2] + cy]
            }
            Projection::Orthographic { sx, sy, cx, cy } => [sx * q[0] + cx, sy * q[1] + cy],
        }
    }

    fn perspective(&self) -> bool {
        matches!(self.projection, Projection::Perspective { .. })
    }
}

/// The nearest surface at one pixel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// View-space depth.
    pub depth: f64,
    pub mesh: u32,
    pub face: u32,
    /// Barycentric weights on the original (unclipped) triangle.
    pub bary: [f64; 3],
}

/// One triangle as the rasteriser sees it: indexed mesh positions in world space.
#[derive(Debug, Clone, Copy)]
pub struct MeshRef<'a> {
    pub positions: &'a [[f32; 3]],
    pub faces: &'a [[u32; 3]],
}

/// A clipped, projected triangle: screen positions, `q` = 1/z (perspective) or 1, view depth,
/// and original barycentrics per corner.
#[derive(Debug, Clone, Copy)]
struct ScreenTri {
    xy: [[f64; 2]; 3],
    q: [f64; 3],
    z: [f64; 3],
    bary: [[f64; 3]; 3],
    mesh: u32,
    face: u32,
}

const BAND_ROWS: usize = 16;

/// Clips a view-space triangle (with barycentric tags) against `z > near`.
fn clip_near(v: [(V3, [f64; 3]); 3], near: f64) -> Vec<(V3, [f64; 3])> {
    let mut out = Vec::with_capacity(4);
    for k in 0..3 {
        let (a, b) = (v[k], v[(k + 1) % 3]);
        let (ina, inb) = (a.0[2] > near, b.0[2] > near);
        if ina {
            out.push(a);
        }
        if ina != inb {
            let t = (near - a.0[2]) / (b.0[2] - a.0[2]);
            let lerp = |x: f64, y: f64| x + t * (y - x);
            let p = [lerp(a.0[0], b.0[0]), lerp(a.0[1], b.0[1]), near];
            let w = [
                lerp(a.1[0], b.1[0]),
                lerp(a.1[1], b.1[1]),
                lerp(a.1[2], b.1[2]),
            ];
            out.push((p, w));
        }
    }
    out
}

fn setup(meshes: &[MeshRef], view: &View) -> Vec<ScreenTri> {
    let eye = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let mut tris = Vec::new();
    for (m, mesh) in meshes.iter().enumerate() {
        let viewed: Vec<V3> = mesh
            .positions
            .par_iter()
            .map(|p| view.to_view([p[0] as f64, p[1] as f64, p[2] as f64]))
            .collect();
        for (f, face) in mesh.faces.iter().enumerate() {
            let corners: [(V3, [f64; 3]); 3] =
                std::array::from_fn(|k| (viewed[face[k] as usize], eye[k]));
            if corners
                .iter()
                .any(|(p, _)| !p.iter().all(|x| x.is_finite()))
            {
                continue;
            }
            if corners.iter().all(|(p, _)| p[2] <= view.near)
                || corners.iter().all(|(p, _)| p[2] > view.far)
            {
                continue;
            }
            let poly = clip_near(corners, view.near);
            for k in 1..poly.len().saturating_sub(1) {
                let pick = [poly[0], poly[k], poly[k + 1]];
                let persp = view.perspective();
                tris.push(ScreenTri {
                    xy: pick.map(|(p, _)| view.project(p)),
                    q: pick.map(|(p, _)| if persp { 1.0 / p[2] } else { 1.0 }),
                    z: pick.map(|(p, _)| p[2]),
                    bary: pick.map(|(_, w)| w),
                    mesh: m as u32,
                    face: f as u32,
                });
            }
        }
    }
    tris
}

/// The nearest hit at every pixel centre (`None` where nothing is in `(near, far]`).
pub fn rasterize(meshes: &[MeshRef], view: &View) -> Vec<Option<Hit>> {
    let tris = setup(meshes, view);
    let (w, h) = (view.width, view.height);
    let bands = h.div_ceil(BAND_ROWS);
    let mut in_band: Vec<Vec<u32>> = vec![Vec::new(); bands];
    for (i, t) in tris.iter().enumerate() {
        let y0 = t.xy.iter().map(|p| p[1]).fold(f64::INFINITY, f64::min);
        let y1 = t.xy.iter().map(|p| p[1]).fold(f64::NEG_INFINITY, f64::max);
        if y1 < 0.0 || y0 > h as f64 {
            continue;
        }
        let b0 = ((y0.max(0.0) as usize) / BAND_ROWS).min(bands - 1);
        let b1 = ((y1.min(h as f64 - 1.0).max(0.0) as usize) / BAND_ROWS).min(bands - 1);
        for list in &mut in_band[b0..=b1] {
            list.push(i as u32);
        }
    }
    let mut hits = vec![None; w * h];
    hits.par_chunks_mut(BAND_ROWS * w)
        .enumerate()
        .for_each(|(band, out)| {
            let row0 = band * BAND_ROWS;
            let rows = out.len() / w;
            for &i in &in_band[band] {
                draw(&tris[i as usize], view, row0, rows, w, out);
            }
        });
    hits
}

fn draw(t: &ScreenTri, view: &View, row0: usize, rows: usize, w: usize, out: &mut [Option<Hit>]) {
    let [a, b, c] = t.xy;
    let area = (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]);
    if area.abs() < 1e-12 || !area.is_finite() {
        return;
    }
    let xs = [a[0], b[0], c[0]];
    let ys = [a[1], b[1], c[1]];
    let x0 = (xs.iter().cloned().fold(f64::INFINITY, f64::min) - 0.5)
        .ceil()
        .max(0.0) as usize;
    let x1 = (xs.iter().cloned().fold(f64::NEG_INFINITY, f64::max) - 0.5)
        .floor()
        .min(w as f64 - 1.0);
    let y0 = (ys.iter().cloned().fold(f64::INFINITY, f64::min) - 0.5)
        .ceil()
        .max(row0 as f64) as usize;
    let y1 = (ys.iter().cloned().fold(f64::NEG_INFINITY, f64::max) - 0.5)
        .floor()
        .min((row0 + rows) as f64 - 1.0);
    if x1 < 0.0 || y1 < 0.0 {
        return;
    }
    let (x1, y1) = (x1 as usize, y1 as usize);
    let persp = view.perspective();
    for y in y0..=y1 {
        let py = y as f64 + 0.5;
        for x in x0..=x1 {
            let px = x as f64 + 0.5;
            let edge = |p: [f64; 2], q: [f64; 2]| {
                (q[0] - p[0]) * (py - p[1]) - (q[1] - p[1]) * (px - p[0])
            };
            let l = [edge(b, c) / area, edge(c, a) / area, edge(a, b) / area];
            if l.iter().any(|&v| v < 0.0) {
                continue;
            }
            let q = l[0] * t.q[0] + l[1] * t.q[1] + l[2] * t.q[2];
            let depth = if persp {
                1.0 / q
            } else {
                l[0] * t.z[0] + l[1] * t.z[1] + l[2] * t.z[2]
            };
            if !(depth > view.near && depth <= view.far) {
                continue;
            }
            let slot = &mut out[(y - row0) * w + x];
            if slot.is_some_and(|h| h.depth <= depth) {
                continue;
            }
            let mut bary = [0.0; 3];
            for (k, lk) in l.iter().enumerate() {
                let wk = lk * t.q[k] / q;
                for (j, bj) in bary.iter_mut().enumerate() {
                    *bj += wk * t.bary[k][j];
                }
            }
            *slot = Some(Hit {
                depth,
                mesh: t.mesh,
                face: t.face,
                bary,
            });
        }
    }
}
