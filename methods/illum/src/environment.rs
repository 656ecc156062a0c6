//! Environment lighting for relighting (spec §5(a)): an equirectangular radiance map (a
//! user's Radiance `.hdr`, or a procedural sky) projected onto real SH of degree ≤ 3 in the
//! probes' convention, an optional sun added as an exact delta, and a rotation about the
//! world's up axis.
//!
//! - Layout: `+y` up (the synthetic worlds' and SMPL's); texel `(row, col)` looks along
//!   `θ = π (row + ½)/H` from `+y` and `φ = 2π (col + ½)/W` from `+z` towards `+x`.
//! - Projection: `c_k = Σ L(ω) Y_k(ω) ΔΩ` with each texel's exact solid angle
//!   `ΔΩ = (2π/W)(cos θ₀ − cos θ₁)`, so a constant map `L` gives `c_0 = L √(4π)` (the
//!   probes' unit radiance) to rounding, and nothing in the higher bands.
//! - The sun: radiance `E δ(ω − s)` of irradiance `E` at normal incidence, projected
//!   exactly as `E Y_k(s)`.

use crate::IllumError;
use splatzoo_rasterizer::sh::sh_basis_f64;
use std::path::Path;

/// A linear-radiance map over the sphere, row-major `[H, W]`.
#[derive(Debug, Clone, PartialEq)]
pub struct EquirectMap {
    pub width: usize,
    pub height: usize,
    pub texels: Vec<[f32; 3]>,
}

/// A procedural sky: a vertical gradient from the horizon colour to the zenith colour, a
/// darker ground below the horizon, and a sun.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sky {
    pub zenith: [f32; 3],
    pub horizon: [f32; 3],
    pub ground: [f32; 3],
    /// Degrees above the horizon and around `+y` (from `+z` towards `+x`).
    pub sun_elevation: f64,
    pub sun_azimuth: f64,
    /// Irradiance of the sun at normal incidence, per channel.
    pub sun: [f32; 3],
}

impl Default for Sky {
    fn default() -> Self {
        Self {
            zenith: [0.35, 0.5, 0.9],
            horizon: [0.9, 0.9, 0.95],
            ground: [0.25, 0.22, 0.2],
            sun_elevation: 40.0,
            sun_azimuth: 60.0,
            sun: [2.6, 2.4, 2.1],
        }
    }
}

/// The unit direction of elevation `elevation` and azimuth `azimuth` (degrees).
pub fn direction_of(elevation: f64, azimuth: f64) -> [f64; 3] {
    let (e, a) = (elevation.to_radians(), azimuth.to_radians());
    [e.cos() * a.sin(), e.sin(), e.cos() * a.cos()]
}

/// `[x, y, z]` turned by `degrees` about `+y` (positive: from `+z` towards `+x`).
pub fn rotate_about_up(d: [f64; 3], degrees: f64) -> [f64; 3] {
    let (s, c) = degrees.to_radians().sin_cos();
    [c * d[0] + s * d[2], d[1], -s * d[0] + c * d[2]]
}

impl EquirectMap {
    /// Reads a Radiance `.hdr` file (linear RGB). Errors name the file.
    pub fn read_hdr(path: &Path) -> Result<Self, IllumError> {
        let bad = |problem: String| IllumError::input(path.display().to_string(), problem);
        let file = std::fs::File::open(path).map_err(|e| bad(format!("cannot open ({e})")))?;
        let reader =
            image::ImageReader::with_format(std::io::BufReader::new(file), image::ImageFormat::Hdr);
        let decoded = reader
            .decode()
            .map_err(|e| bad(format!("not a Radiance .hdr image ({e})")))?
            .into_rgb32f();
        let (width, height) = (decoded.width() as usize, decoded.height() as usize);
        if width < 2 || height < 1 {
            return Err(bad(format!(
                "an environment map needs at least 2×1 texels, got {width}×{height}"
            )));
        }
        let texels: Vec<[f32; 3]> = decoded.pixels().map(|p| p.0).collect();
        if let Some(i) = texels
            .iter()
            .position(|t| t.iter().any(|v| !v.is_finite() || *v < 0.0))
        {
            return Err(bad(format!(
                "texel ({}, {}) holds {:?}: radiance must be finite and ≥ 0",
                i / width,
                i % width,
                texels[i]
            )));
        }
        Ok(Self {
            width,
            height,
            texels,
        })
    }

    /// The sky's gradient and ground (the sun is added by [`Sky::project`], exactly).
    pub fn sky(sky: &Sky, width: usize, height: usize) -> Self {
        let mut texels = Vec::with_capacity(width * height);
        for row in 0..height {
            let theta = std::f64::consts::PI * (row as f64 + 0.5) / height as f64;
            let up = theta.cos();
            let texel = if up >= 0.0 {
                let t = up.sqrt() as f32;
                [0, 1, 2].map(|c| sky.horizon[c] * (1.0 - t) + sky.zenith[c] * t)
            } else {
                sky.ground
            };
            texels.extend(std::iter::repeat_n(texel, width));
        }
        Self {
            width,
            height,
            texels,
        }
    }

    /// The direction texel `(row, col)` looks along.
    pub fn direction(&self, row: usize, col: usize) -> [f64; 3] {
        let theta = std::f64::consts::PI * (row as f64 + 0.5) / self.height as f64;
        let phi = std::f64::consts::TAU * (col as f64 + 0.5) / self.width as f64;
        [
            theta.sin() * phi.sin(),
            theta.cos(),
            theta.sin() * phi.cos(),
        ]
    }

    /// The map's radiance SH `[K][3]` of `degree`, the map turned by `rotation` degrees about
    /// `+y`.
    pub fn project(&self, degree: u32, rotation: f64) -> Vec<[f64; 3]> {
        let k = ((degree + 1) * (degree + 1)) as usize;
        let mut sh = vec![[0.0f64; 3]; k];
        let dphi = std::f64::consts::TAU / self.width as f64;
        for row in 0..self.height {
            let t0 = std::f64::consts::PI * row as f64 / self.height as f64;
            let t1 = std::f64::consts::PI * (row + 1) as f64 / self.height as f64;
            let solid = dphi * (t0.cos() - t1.cos());
            for col in 0..self.width {
                let d = rotate_about_up(self.direction(row, col), rotation);
                let basis = sh_basis_f64(degree, d);
                let texel = self.texels[row * self.width + col];
                for (j, y) in basis.iter().enumerate() {
                    for c in 0..3 {
                        sh[j][c] += f64::from(texel[c]) * y * solid;
                    }
                }
            }
        }
        sh
    }
}

impl Sky {
    /// The sky's radiance SH of `degree`, sun included, turned by `rotation` degrees about
    /// `+y`; the gradient is sampled on a `128 × 64` map.
    pub fn project(&self, degree: u32, rotation: f64) -> Vec<[f64; 3]> {
        let mut sh = EquirectMap::sky(self, 128, 64).project(degree, rotation);
        let sun = rotate_about_up(direction_of(self.sun_elevation, self.sun_azimuth), rotation);
        for (coefficient, y) in sh.iter_mut().zip(sh_basis_f64(degree, sun)) {
            for (value, sun) in coefficient.iter_mut().zip(self.sun) {
                *value += f64::from(sun) * y;
            }
        }
        sh
    }
}
