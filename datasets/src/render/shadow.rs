//! Shadow maps: depth as seen from the light, looked up with a slope-free bias and 3×3
//! percentage-closer filtering. A directional light gets one orthographic map fitted to the
//! scene's bounding sphere; a point light gets a cube of six 90° perspective maps, so it may sit
//! inside the scene (a lamp in a room).

use super::visibility::{MeshRef, Projection, V3, View, rasterize};

/// Depth from one light view.
struct DepthMap {
    view: View,
    depth: Vec<f64>,
    /// World size of one texel at unit depth (perspective) or everywhere (orthographic).
    texel: f64,
}

impl DepthMap {
    fn new(meshes: &[MeshRef], view: View, texel: f64) -> Self {
        let depth = rasterize(meshes, &view)
            .into_iter()
            .map(|h| h.map_or(f64::INFINITY, |h| h.depth))
            .collect();
        Self { view, depth, texel }
    }

    /// Fraction of the 3×3 neighbourhood that sees `q` (view space) lit.
    fn lit(&self, q: V3) -> f64 {
        let [x, y] = self.view.project(q);
        let (w, h) = (self.view.width as i64, self.view.height as i64);
        let texel = match self.view.projection {
            Projection::Perspective { .. } => self.texel * q[2],
            Projection::Orthographic { .. } => self.texel,
        };
        let bias = 3.0 * texel + 2e-3;
        let (cx, cy) = (x.floor() as i64, y.floor() as i64);
        let mut lit = 0.0;
        for dy in -1..=1 {
            for dx in -1..=1 {
                let (px, py) = (cx + dx, cy + dy);
                let occluder = if px < 0 || py < 0 || px >= w || py >= h {
                    f64::INFINITY
                } else {
                    self.depth[(py * w + px) as usize]
                };
                if q[2] - bias <= occluder {
                    lit += 1.0;
                }
            }
        }
        lit / 9.0
    }
}

/// A light's shadow maps.
pub enum ShadowMap {
    Directional(DepthMapBox),
    Point {
        position: V3,
        faces: Vec<DepthMapBox>,
    },
}

/// Opaque holder of one depth map.
pub struct DepthMapBox(DepthMap);

/// Rows of a rotation whose third row is `forward`.
fn frame(forward: V3) -> [V3; 3] {
    let n = (forward[0] * forward[0] + forward[1] * forward[1] + forward[2] * forward[2]).sqrt();
    let f = [forward[0] / n, forward[1] / n, forward[2] / n];
    let helper = if f[1].abs() < 0.9 {
        [0.0, 1.0, 0.0]
    } else {
        [1.0, 0.0, 0.0]
    };
    let cross = |a: V3, b: V3| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let r = cross(helper, f);
    let rn = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
    let r = [r[0] / rn, r[1] / rn, r[2] / rn];
    let d = cross(f, r);
    [r, d, f]
}

fn rigid(rows: [V3; 3], origin: V3) -> [[f64; 4]; 3] {
    std::array::from_fn(|i| {
        let r = rows[i];
        [
            r[0],
            r[1],
            r[2],
            -(r[0] * origin[0] + r[1] * origin[1] + r[2] * origin[2]),
        ]
    })
}

impl ShadowMap {
    /// An orthographic map along `direction` (from the light into the scene) covering the sphere
    /// (`centre`, `radius`).
    pub fn directional(
        meshes: &[MeshRef],
        direction: V3,
        centre: V3,
        radius: f64,
        resolution: usize,
    ) -> Self {
        let rows = frame(direction);
        let f = rows[2];
        let origin = [
            centre[0] - f[0] * (radius + 1.0),
            centre[1] - f[1] * (radius + 1.0),
            centre[2] - f[2] * (radius + 1.0),
        ];
        let s = resolution as f64 / (2.0 * radius);
        let half = 0.5 * resolution as f64;
        let view = View {
            world_to_view: rigid(rows, origin),
            projection: Projection::Orthographic {
                sx: s,
                sy: s,
                cx: half,
                cy: half,
            },
            width: resolution,
            height: resolution,
            near: 0.0,
            far: 2.0 * radius + 2.0,
        };
        Self::Directional(DepthMapBox(DepthMap::new(meshes, view, 1.0 / s)))
    }

    /// A cube of six maps around a point light.
    pub fn point(meshes: &[MeshRef], position: V3, far: f64, resolution: usize) -> Self {
        let axes: [V3; 6] = [
            [1.0, 0.0, 0.0],
            [-1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, -1.0, 0.0],
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
        ];
        let half = 0.5 * resolution as f64;
        let faces = axes
            .iter()
            .map(|&axis| {
                let view = View {
                    world_to_view: rigid(frame(axis), position),
                    // 90° field of view, one texel of margin so neighbouring faces overlap.
                    projection: Projection::Perspective {
                        fx: half - 1.0,
                        fy: half - 1.0,
                        cx: half,
                        cy: half,
                    },
                    width: resolution,
                    height: resolution,
                    near: 1e-3,
                    far,
                };
                DepthMapBox(DepthMap::new(meshes, view, 1.0 / (half - 1.0)))
            })
            .collect();
        Self::Point { position, faces }
    }

    /// How lit the world point `p` is, in [0, 1].
    pub fn lit(&self, p: V3) -> f64 {
        match self {
            Self::Directional(map) => map.0.lit(map.0.view.to_view(p)),
            Self::Point { position, faces } => {
                let d = [p[0] - position[0], p[1] - position[1], p[2] - position[2]];
                let axis = (0..3)
                    .max_by(|&a, &b| d[a].abs().total_cmp(&d[b].abs()))
                    .expect("three axes");
                let face = 2 * axis + usize::from(d[axis] < 0.0);
                let map = &faces[face].0;
                map.lit(map.view.to_view(p))
            }
        }
    }
}
