//! A CPU triangle-mesh renderer, independent of the splat rasterizer, so no method is graded by
//! its own renderer: z-buffer visibility with perspective-correct attributes ([`visibility`]),
//! per-vertex colours or textures, Lambert shading with an ambient term and one directional or
//! point light with shadow maps ([`shadow`]), supersampled anti-aliasing. Besides colour it
//! returns the ground truth the methods train and test against: depth, world normals, per-pixel
//! object labels (masks), coverage, and the same image without shadows.

pub mod shadow;
pub mod texture;
pub mod visibility;

pub use texture::Texture;
pub use visibility::{Hit, MeshRef, Projection, View};

use rayon::prelude::*;
use shadow::ShadowMap;
use splatzoo_rasterizer::Camera;
use splatzoo_rasterizer::sh::{irradiance_f64, sh_basis_f64};
use visibility::V3;

/// How a mesh is coloured.
#[derive(Debug, Clone, Copy)]
pub enum Albedo<'a> {
    Uniform([f32; 3]),
    /// One linear-RGB colour per vertex.
    PerVertex(&'a [[f32; 3]]),
    /// Texture coordinates per face corner (`[T, 2]` and `[F, 3]` indices) and the texture.
    Textured {
        coords: &'a [[f32; 2]],
        corners: &'a [[u32; 3]],
        texture: &'a Texture,
    },
}

/// A mesh placed in the world.
#[derive(Debug, Clone, Copy)]
pub struct MeshInstance<'a> {
    pub positions: &'a [[f32; 3]],
    pub faces: &'a [[u32; 3]],
    pub albedo: Albedo<'a>,
    /// Written to the label image where this mesh is visible (0 is the background).
    pub label: u8,
    /// Interpolate vertex normals (curved surfaces) rather than use face normals (boxes).
    pub smooth: bool,
}

/// The one light besides the ambient term.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Light {
    /// Parallel light travelling along `direction`.
    Directional {
        direction: [f32; 3],
        color: [f32; 3],
    },
    /// A point light with inverse-square falloff normalised to `color` at 1 m.
    Point { position: [f32; 3], color: [f32; 3] },
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lighting {
    /// Uniform radiance from every direction (a Lambertian surface sends out `b · ambient`).
    pub ambient: [f32; 3],
    /// An SH radiance environment of degree 2 (INRIA basis, no +0.5 offset), unshadowed like
    /// the ambient term: a Lambertian surface sends out `b · E(n) / π` with `E` its irradiance
    /// ([`splatzoo_rasterizer::sh::irradiance_f64`]).
    pub environment: Option<[[f32; 3]; 9]>,
    pub light: Option<Light>,
    /// Shadow-map resolution (per cube face for point lights); `None` renders without shadows.
    pub shadow_resolution: Option<usize>,
}

impl Default for Lighting {
    fn default() -> Self {
        Self {
            ambient: [0.35; 3],
            environment: None,
            light: Some(Light::Directional {
                direction: [0.3, -1.0, -0.4],
                color: [0.75; 3],
            }),
            shadow_resolution: Some(1024),
        }
    }
}

impl Lighting {
    /// The SH radiance (degree 2, INRIA basis, no +0.5, `[9]` of RGB) arriving at `point` with
    /// no occluder: the uniform ambient `a` as `a √(4π)` on the DC term, the environment as is,
    /// and the light as a delta of strength `π I` (directional) or `π I / d²` (point) towards it,
    /// `L_lm = π I Y_lm(ω_light)`. Its irradiance ([`splatzoo_rasterizer::sh::irradiance_f64`])
    /// is exactly this renderer's `ambient + environment` terms and the band-limited (l ≤ 2)
    /// version of its `I cos θ / d²` term: the ground truth a light probe at `point` should learn.
    pub fn radiance_sh(&self, point: [f64; 3]) -> [[f64; 3]; 9] {
        let mut sh = [[0.0f64; 3]; 9];
        let dc = (4.0 * std::f64::consts::PI).sqrt();
        for (c, a) in self.ambient.iter().enumerate() {
            sh[0][c] += f64::from(*a) * dc;
        }
        if let Some(environment) = &self.environment {
            for (k, row) in environment.iter().enumerate() {
                for c in 0..3 {
                    sh[k][c] += f64::from(row[c]);
                }
            }
        }
        let delta = match self.light {
            None => None,
            Some(Light::Directional { direction, color }) => {
                Some((direction.map(|x| -f64::from(x)), color.map(f64::from)))
            }
            Some(Light::Point { position, color }) => {
                let d = sub(position.map(f64::from), point);
                let r2 = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).max(1e-6);
                Some((d, color.map(|c| f64::from(c) / r2)))
            }
        };
        if let Some((towards, strength)) = delta {
            let basis = sh_basis_f64(2, towards);
            for (k, y) in basis.iter().enumerate() {
                for c in 0..3 {
                    sh[k][c] += std::f64::consts::PI * strength[c] * y;
                }
            }
        }
        sh
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderSettings {
    pub background: [f32; 3],
    /// Samples per pixel along each axis (colour and coverage are averaged over them; depth,
    /// normals and labels come from the sample nearest the pixel centre).
    pub supersample: usize,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            background: [0.0; 3],
            supersample: 2,
        }
    }
}

/// One rendered view. Images are row-major `[H, W]`.
#[derive(Debug, Clone)]
pub struct MeshRender {
    pub width: usize,
    pub height: usize,
    /// Linear RGB, background included.
    pub color: Vec<[f32; 3]>,
    /// The same without shadows (equal to `color` when shadows are off).
    pub color_unshadowed: Vec<[f32; 3]>,
    /// Linear albedo of what each sample sees (0 on the background), averaged like `color`.
    pub albedo: Vec<[f32; 3]>,
    /// Camera-space depth (+z); infinite on the background.
    pub depth: Vec<f32>,
    /// World-space unit normals facing the camera; zero on the background.
    pub normal: Vec<[f32; 3]>,
    /// Label of the visible mesh; 0 on the background.
    pub label: Vec<u8>,
    /// Fraction of samples covered by any mesh.
    pub coverage: Vec<f32>,
}

/// Area-weighted vertex normals.
pub fn vertex_normals(positions: &[[f32; 3]], faces: &[[u32; 3]]) -> Vec<[f32; 3]> {
    let mut n = vec![[0.0f64; 3]; positions.len()];
    for f in faces {
        let p = f.map(|i| positions[i as usize].map(f64::from));
        let fn_ = face_normal(p);
        for &i in f {
            for k in 0..3 {
                n[i as usize][k] += fn_[k];
            }
        }
    }
    n.into_iter()
        .map(|v| {
            let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            if l > 0.0 {
                [(v[0] / l) as f32, (v[1] / l) as f32, (v[2] / l) as f32]
            } else {
                [0.0; 3]
            }
        })
        .collect()
}

fn face_normal(p: [V3; 3]) -> V3 {
    let (u, v) = (sub(p[1], p[0]), sub(p[2], p[0]));
    [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ]
}

fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn normalize(a: V3) -> V3 {
    let l = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    if l > 0.0 {
        [a[0] / l, a[1] / l, a[2] / l]
    } else {
        a
    }
}

/// The view of a project camera at `supersample`× resolution.
pub fn camera_view(camera: &Camera, supersample: usize) -> View {
    let s = supersample as f64;
    View {
        world_to_view: camera.world_to_camera.map(|r| r.map(f64::from)),
        projection: Projection::Perspective {
            fx: camera.fx as f64 * s,
            fy: camera.fy as f64 * s,
            cx: camera.cx as f64 * s,
            cy: camera.cy as f64 * s,
        },
        width: camera.width as usize * supersample,
        height: camera.height as usize * supersample,
        near: camera.near as f64,
        far: camera.far as f64,
    }
}

/// Centre and radius of a sphere around every vertex.
fn bounding_sphere(meshes: &[MeshInstance]) -> (V3, f64) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for m in meshes {
        for p in m.positions {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k] as f64);
                hi[k] = hi[k].max(p[k] as f64);
            }
        }
    }
    let c = [
        0.5 * (lo[0] + hi[0]),
        0.5 * (lo[1] + hi[1]),
        0.5 * (lo[2] + hi[2]),
    ];
    let r = (0.5 * norm(sub(hi, lo))).max(1e-3);
    (c, r)
}

fn norm(a: V3) -> f64 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

fn mesh_refs<'a>(meshes: &[MeshInstance<'a>]) -> Vec<MeshRef<'a>> {
    meshes
        .iter()
        .map(|m| MeshRef {
            positions: m.positions,
            faces: m.faces,
        })
        .collect()
}

/// The shadow map of `lighting`'s light over `meshes` (`None` without a light, shadows or
/// meshes). It depends only on the geometry and the light: compute it once and pass it to
/// [`render_with_shadows`] for every camera of a frame.
pub fn shadow_map(meshes: &[MeshInstance], lighting: &Lighting) -> Option<ShadowMap> {
    let refs = mesh_refs(meshes);
    match (lighting.light, lighting.shadow_resolution) {
        (Some(light), Some(res)) if !meshes.is_empty() => {
            let (centre, radius) = bounding_sphere(meshes);
            Some(match light {
                Light::Directional { direction, .. } => {
                    ShadowMap::directional(&refs, direction.map(f64::from), centre, radius, res)
                }
                Light::Point { position, .. } => {
                    let p = position.map(f64::from);
                    ShadowMap::point(&refs, p, norm(sub(p, centre)) + 2.0 * radius, res)
                }
            })
        }
        _ => None,
    }
}

/// Renders `meshes` from `camera`.
pub fn render(
    meshes: &[MeshInstance],
    camera: &Camera,
    lighting: &Lighting,
    settings: &RenderSettings,
) -> MeshRender {
    let shadows = shadow_map(meshes, lighting);
    render_with_shadows(meshes, camera, lighting, settings, shadows.as_ref())
}

/// Renders `meshes` from `camera` with a precomputed [`shadow_map`] of the same meshes and
/// light (`None`: no shadows).
pub fn render_with_shadows(
    meshes: &[MeshInstance],
    camera: &Camera,
    lighting: &Lighting,
    settings: &RenderSettings,
    shadows: Option<&ShadowMap>,
) -> MeshRender {
    let s = settings.supersample.max(1);
    let view = camera_view(camera, s);
    let refs = mesh_refs(meshes);
    let hits = visibility::rasterize(&refs, &view);
    let normals: Vec<Option<Vec<[f32; 3]>>> = meshes
        .iter()
        .map(|m| m.smooth.then(|| vertex_normals(m.positions, m.faces)))
        .collect();
    let camera_position = camera.position().map(f64::from);

    let environment = lighting
        .environment
        .map(|e| e.map(|row| row.map(f64::from)));
    // Shade every sample: (colour, unshadowed colour, world normal, albedo).
    let shade = |hit: &Hit| -> ([f64; 3], [f64; 3], V3, V3) {
        let mesh = &meshes[hit.mesh as usize];
        let face = mesh.faces[hit.face as usize];
        let corner = |k: usize| mesh.positions[face[k] as usize].map(f64::from);
        let mut p = [0.0; 3];
        for (k, bk) in hit.bary.iter().enumerate() {
            let x = corner(k);
            for (pc, xc) in p.iter_mut().zip(x) {
                *pc += bk * xc;
            }
        }
        let mut n = match &normals[hit.mesh as usize] {
            Some(vn) => {
                let mut n = [0.0; 3];
                for k in 0..3 {
                    let v = vn[face[k] as usize];
                    for c in 0..3 {
                        n[c] += hit.bary[k] * v[c] as f64;
                    }
                }
                normalize(n)
            }
            None => normalize(face_normal([corner(0), corner(1), corner(2)])),
        };
        let to_eye = sub(camera_position, p);
        if n[0] * to_eye[0] + n[1] * to_eye[1] + n[2] * to_eye[2] < 0.0 {
            n = [-n[0], -n[1], -n[2]];
        }
        let albedo: V3 = match mesh.albedo {
            Albedo::Uniform(c) => c.map(f64::from),
            Albedo::PerVertex(colors) => {
                let mut a = [0.0; 3];
                for k in 0..3 {
                    let v = colors[face[k] as usize];
                    for c in 0..3 {
                        a[c] += hit.bary[k] * v[c] as f64;
                    }
                }
                a
            }
            Albedo::Textured {
                coords,
                corners,
                texture,
            } => {
                let t = corners[hit.face as usize];
                let (mut u, mut v) = (0.0, 0.0);
                for k in 0..3 {
                    u += hit.bary[k] * coords[t[k] as usize][0] as f64;
                    v += hit.bary[k] * coords[t[k] as usize][1] as f64;
                }
                texture.sample(u as f32, v as f32).map(f64::from)
            }
        };
        let mut ambient = lighting.ambient.map(f64::from);
        if let Some(environment) = &environment {
            let irradiance = irradiance_f64(environment, 2, n);
            for c in 0..3 {
                ambient[c] += irradiance[c] / std::f64::consts::PI;
            }
        }
        let (direct, lit) = match lighting.light {
            None => ([0.0; 3], 1.0),
            Some(Light::Directional { direction, color }) => {
                let l = normalize(direction.map(|x| -x as f64));
                let cos = (n[0] * l[0] + n[1] * l[1] + n[2] * l[2]).max(0.0);
                let lit = shadows.map_or(1.0, |s| s.lit(p));
                (color.map(|c| c as f64 * cos), lit)
            }
            Some(Light::Point { position, color }) => {
                let d = sub(position.map(f64::from), p);
                let r2 = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).max(1e-6);
                let l = normalize(d);
                let cos = (n[0] * l[0] + n[1] * l[1] + n[2] * l[2]).max(0.0);
                let lit = shadows.map_or(1.0, |s| s.lit(p));
                (color.map(|c| c as f64 * cos / r2), lit)
            }
        };
        let color = std::array::from_fn(|c| albedo[c] * (ambient[c] + lit * direct[c]));
        let unshadowed = std::array::from_fn(|c| albedo[c] * (ambient[c] + direct[c]));
        (color, unshadowed, n, albedo)
    };

    let (w, h) = (camera.width as usize, camera.height as usize);
    let centre_sample = s / 2;
    let background = settings.background.map(f64::from);
    let pixels: Vec<_> = (0..w * h)
        .into_par_iter()
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let mut color = [0.0; 3];
            let mut unshadowed = [0.0; 3];
            let mut albedo = [0.0; 3];
            let mut covered = 0usize;
            let mut centre = None;
            for sy in 0..s {
                for sx in 0..s {
                    let hit = hits[(y * s + sy) * view.width + x * s + sx];
                    let (c, u, n, a) = match &hit {
                        Some(hit) => {
                            covered += 1;
                            shade(hit)
                        }
                        None => (background, background, [0.0; 3], [0.0; 3]),
                    };
                    for k in 0..3 {
                        color[k] += c[k];
                        unshadowed[k] += u[k];
                        albedo[k] += a[k];
                    }
                    if sx == centre_sample && sy == centre_sample {
                        centre = hit.map(|hit| (hit, n));
                    }
                }
            }
            let inv = 1.0 / (s * s) as f64;
            let (depth, normal, label) = match centre {
                Some((hit, n)) => (
                    hit.depth as f32,
                    n.map(|x| x as f32),
                    meshes[hit.mesh as usize].label,
                ),
                None => (f32::INFINITY, [0.0; 3], 0),
            };
            (
                color.map(|c| (c * inv) as f32),
                unshadowed.map(|c| (c * inv) as f32),
                depth,
                normal,
                label,
                (covered as f64 * inv) as f32,
                albedo.map(|c| (c * inv) as f32),
            )
        })
        .collect();
    MeshRender {
        width: w,
        height: h,
        color: pixels.iter().map(|p| p.0).collect(),
        color_unshadowed: pixels.iter().map(|p| p.1).collect(),
        depth: pixels.iter().map(|p| p.2).collect(),
        normal: pixels.iter().map(|p| p.3).collect(),
        label: pixels.iter().map(|p| p.4).collect(),
        coverage: pixels.iter().map(|p| p.5).collect(),
        albedo: pixels.iter().map(|p| p.6).collect(),
    }
}
