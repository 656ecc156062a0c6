//! Host-side description of one render: the pinhole camera and the rasterizer's settings.
//!
//! These are plain values (not tensors) so they can travel as ordinary arguments of the backend
//! extension op. Camera refinement happens upstream, by transforming splats with Burn ops.

use crate::error::RasterError;

/// A pinhole camera in the OpenCV convention (+x right, +y down, +z forward).
///
/// Pixel `(i, j)` (column, row) has its centre at `(i + 0.5, j + 0.5)` in the same coordinates as
/// `cx`, `cy`; a point `(x, y, z)` in camera space projects to `(fx x / z + cx, fy y / z + cy)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    pub fx: f32,
    pub fy: f32,
    pub cx: f32,
    pub cy: f32,
    pub width: u32,
    pub height: u32,
    /// Splats with camera-space depth `z <= near` or `z > far` are culled.
    pub near: f32,
    pub far: f32,
    /// World-to-camera rigid transform as rows `[R | t]` (x_cam = R x_world + t).
    pub world_to_camera: [[f32; 4]; 3],
}

impl Camera {
    /// A camera at `position` looking at `target`, with the OpenCV axes (`up` points to -y).
    pub fn look_at(
        position: [f32; 3],
        target: [f32; 3],
        up: [f32; 3],
        fov_x_degrees: f32,
        width: u32,
        height: u32,
    ) -> Self {
        let sub = |a: [f32; 3], b: [f32; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
        let cross = |a: [f32; 3], b: [f32; 3]| {
            [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ]
        };
        let normalize = |a: [f32; 3]| {
            let n = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt().max(1e-20);
            [a[0] / n, a[1] / n, a[2] / n]
        };
        let forward = normalize(sub(target, position));
        let right = normalize(cross(forward, up));
        let down = cross(forward, right);
        let rows = [right, down, forward];
        let mut world_to_camera = [[0.0; 4]; 3];
        for (r, row) in rows.iter().enumerate() {
            world_to_camera[r][..3].copy_from_slice(row);
            world_to_camera[r][3] =
                -(row[0] * position[0] + row[1] * position[1] + row[2] * position[2]);
        }
        let fx = 0.5 * width as f32 / (0.5 * fov_x_degrees.to_radians()).tan();
        Self {
            fx,
            fy: fx,
            cx: 0.5 * width as f32,
            cy: 0.5 * height as f32,
            width,
            height,
            near: 0.01,
            far: 1e4,
            world_to_camera,
        }
    }

    /// The camera centre in world space, `-Rᵀ t`.
    pub fn position(&self) -> [f32; 3] {
        let m = &self.world_to_camera;
        let mut p = [0.0; 3];
        for (c, value) in p.iter_mut().enumerate() {
            *value = -(m[0][c] * m[0][3] + m[1][c] * m[1][3] + m[2][c] * m[2][3]);
        }
        p
    }

    /// Checks that every field is usable; errors name the field.
    pub fn validate(&self) -> Result<(), RasterError> {
        let finite = [
            ("fx", self.fx),
            ("fy", self.fy),
            ("cx", self.cx),
            ("cy", self.cy),
            ("near", self.near),
            ("far", self.far),
        ];
        for (name, value) in finite {
            if !value.is_finite() {
                return Err(RasterError::Camera(format!(
                    "{name} = {value} is not finite"
                )));
            }
        }
        if self.fx <= 0.0 || self.fy <= 0.0 {
            return Err(RasterError::Camera(format!(
                "focal lengths must be positive, got fx = {}, fy = {}",
                self.fx, self.fy
            )));
        }
        if self.width == 0 || self.height == 0 {
            return Err(RasterError::Camera(format!(
                "image size must be at least 1x1, got {}x{}",
                self.width, self.height
            )));
        }
        if self.width > 1 << 15 || self.height > 1 << 15 {
            return Err(RasterError::Camera(format!(
                "image size {}x{} exceeds 32768 on a side",
                self.width, self.height
            )));
        }
        if !(self.near >= 0.0 && self.far > self.near) {
            return Err(RasterError::Camera(format!(
                "need 0 <= near < far, got near = {}, far = {}",
                self.near, self.far
            )));
        }
        if self
            .world_to_camera
            .iter()
            .flatten()
            .any(|v| !v.is_finite())
        {
            return Err(RasterError::Camera(
                "world_to_camera holds a non-finite value".into(),
            ));
        }
        Ok(())
    }
}

/// Classic 3DGS footprints, or the anti-aliased variant.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RasterMode {
    /// The 2D covariance is dilated by `eps2d · I` (INRIA 3DGS, gsplat "classic").
    #[default]
    Classic,
    /// The dilation is a low-pass filter and opacity is scaled by
    /// `sqrt(det Σ / det(Σ + eps2d · I))` (Mip-Splatting; gsplat "antialiased").
    AntiAliased,
}

/// How the per-splat colour tensor `[N, K, C]` is turned into a colour.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ColorMode {
    /// Real spherical harmonics of degree `0..=3` on the view direction, RGB (`C = 3`), with
    /// `K >= (degree + 1)²` coefficients stored; colour = `max(Σ_k Y_k(d) c_k + 0.5, 0)` as INRIA.
    Sh { degree: u32 },
    /// Free features `[N, 1, C]` rendered as they are (normals, albedo, latent features).
    Features,
}

/// Everything besides tensors that one render needs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RasterSettings {
    pub camera: Camera,
    pub mode: RasterMode,
    pub color: ColorMode,
    /// A splat reaches pixels within this many standard deviations (Mahalanobis distance); its
    /// screen radius is `ceil(clip_sigmas · sqrt(λ_max))`. 3 as in INRIA 3DGS.
    pub clip_sigmas: f32,
    /// Contributions with alpha below this are skipped (1/255 as in INRIA 3DGS). Tests set 0 to
    /// make the image a smooth function of the inputs.
    pub alpha_min: f32,
    /// Screen-space dilation added to every 2D covariance, in pixels² (0.3 as INRIA and gsplat).
    pub eps2d: f32,
}

impl RasterSettings {
    /// INRIA defaults: classic mode, 3 σ, alpha ≥ 1/255, dilation 0.3.
    pub fn new(camera: Camera, color: ColorMode) -> Self {
        Self {
            camera,
            mode: RasterMode::Classic,
            color,
            clip_sigmas: 3.0,
            alpha_min: 1.0 / 255.0,
            eps2d: 0.3,
        }
    }

    pub fn validate(&self) -> Result<(), RasterError> {
        self.camera.validate()?;
        if let ColorMode::Sh { degree } = self.color
            && degree > 3
        {
            return Err(RasterError::Settings(format!(
                "SH degree must be 0..=3, got {degree}"
            )));
        }
        if !(self.clip_sigmas.is_finite() && self.clip_sigmas > 0.0) {
            return Err(RasterError::Settings(format!(
                "clip_sigmas must be positive and finite, got {}",
                self.clip_sigmas
            )));
        }
        if !(0.0..1.0).contains(&self.alpha_min) {
            return Err(RasterError::Settings(format!(
                "alpha_min must be in [0, 1), got {}",
                self.alpha_min
            )));
        }
        if !(self.eps2d.is_finite() && self.eps2d >= 0.0) {
            return Err(RasterError::Settings(format!(
                "eps2d must be finite and >= 0, got {}",
                self.eps2d
            )));
        }
        Ok(())
    }
}
