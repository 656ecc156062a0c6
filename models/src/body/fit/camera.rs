//! The calibrated pinhole camera the body fit projects through.

/// A calibrated pinhole camera: `x_cam = R x_world + t` (rows `[R | t]`), +z forward,
/// `u = f_x x / z + c_x`, `v = f_y y / z + c_y` (image y down when the camera's y is down).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PinholeCamera {
    pub fx: f64,
    pub fy: f64,
    pub cx: f64,
    pub cy: f64,
    pub world_to_camera: [[f64; 4]; 3],
}

impl PinholeCamera {
    /// The pixel of a world point, `None` behind the camera.
    pub fn project(&self, p: [f64; 3]) -> Option<[f64; 2]> {
        let c = self.camera_point(p);
        (c[2] > 1e-9).then(|| {
            [
                self.fx * c[0] / c[2] + self.cx,
                self.fy * c[1] / c[2] + self.cy,
            ]
        })
    }

    fn camera_point(&self, p: [f64; 3]) -> [f64; 3] {
        let m = &self.world_to_camera;
        std::array::from_fn(|r| m[r][0] * p[0] + m[r][1] * p[1] + m[r][2] * p[2] + m[r][3])
    }

    /// The world point at pixel `(u, v)` and camera depth `z`.
    pub(super) fn unproject(&self, [u, v]: [f64; 2], z: f64) -> [f64; 3] {
        let c = [(u - self.cx) * z / self.fx, (v - self.cy) * z / self.fy, z];
        let m = &self.world_to_camera;
        let d: [f64; 3] = std::array::from_fn(|r| c[r] - m[r][3]);
        std::array::from_fn(|k| (0..3).map(|r| m[r][k] * d[r]).sum())
    }

    pub(super) fn centre(&self) -> [f64; 3] {
        let m = &self.world_to_camera;
        std::array::from_fn(|k| -(0..3).map(|r| m[r][k] * m[r][3]).sum::<f64>())
    }
}
