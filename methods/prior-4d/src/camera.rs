//! Rigid frames as Burn tensors, and camera refinement by moving splats rather than the camera.
//!
//! The rasterizer's [`Camera`] is host-side, so a learned camera pose cannot receive a gradient
//! there. Instead every splat is carried into the (refined) camera's frame with Burn ops —
//! centres `Rᵀ (x − c)`, rotations `q(Rᵀ) ⊗ q` — and rendered by a camera at the origin with
//! the same intrinsics ([`camera_at_origin`]). The refinement of acting camera `t` is
//! `R'_t = exp([ω_t]×) R_t`, `c'_t = c_t + τ_t` (spec §3, zero at the start).
//!
//! Whether a capture needs it is a data rule ([`refinement_choice`]): only where the acting
//! cameras are estimated (SfM) rather than calibrated.

use crate::data::CameraSource;
use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_models::rotation::{axis_angle_to_matrix, matrix_to_quaternion};
use splatzoo_rasterizer::{Camera, Splats};
use splatzoo_train::harness::ModuleChoice;
use splatzoo_train::scene::skinned::skinning::quaternion_product;

/// Stage D's camera refinement for a capture whose acting cameras come from `source`:
/// `forced` (`joint.camera_refinement`) wins; otherwise on for estimated cameras, off for
/// calibrated ones (there it has nothing to correct, yet costs its gradients and Adam steps
/// and can drift).
pub fn refinement_choice(forced: Option<bool>, source: CameraSource) -> ModuleChoice {
    let why = match source {
        CameraSource::Estimated => "the acting cameras are estimated (SfM): refined",
        CameraSource::Calibrated => "the acting cameras are calibrated: kept as given",
    };
    ModuleChoice::decide(
        "acting-camera refinement",
        "joint.camera_refinement",
        forced,
        source == CameraSource::Estimated,
        why,
    )
}

/// A camera-to-world rigid transform: `x_world = R x_local + c`.
#[derive(Debug, Clone)]
pub struct RigidFrame {
    /// `[3, 3]` rotation, local → world (its columns are the local axes in world space).
    pub rotation: Tensor<2>,
    /// `[3]` the frame's origin in world space (a camera's centre).
    pub centre: Tensor<1>,
}

impl RigidFrame {
    /// From a row-major rotation and a centre.
    pub fn from_host(rotation: [[f64; 3]; 3], centre: [f64; 3], device: &Device) -> Self {
        let r: Vec<f32> = rotation.iter().flatten().map(|&v| v as f32).collect();
        let c: Vec<f32> = centre.iter().map(|&v| v as f32).collect();
        Self {
            rotation: Tensor::<2>::from_data(TensorData::new(r, [3, 3]), device),
            centre: Tensor::<1>::from_data(TensorData::new(c, [3]), device),
        }
    }

    /// The camera-to-world pose of a host camera (the inverse of its `world_to_camera`).
    pub fn of_camera(camera: &Camera, device: &Device) -> Self {
        let (rotation, centre) = camera_to_world(camera);
        Self::from_host(rotation, centre, device)
    }

    /// `R' = exp([ω]×) R`, `c' = c + τ` for `ω`, `τ` `[3]` (axis-angle radians, world units).
    pub fn refined(&self, omega: Tensor<1>, tau: Tensor<1>) -> Self {
        let delta = axis_angle_to_matrix(omega.reshape([1, 3])).reshape([3, 3]);
        Self {
            rotation: delta.matmul(self.rotation.clone()),
            centre: self.centre.clone() + tau,
        }
    }

    /// Local points `[N, 3]` → world.
    pub fn to_world(&self, points: Tensor<2>) -> Tensor<2> {
        points.matmul(self.rotation.clone().transpose()) + self.centre.clone().reshape([1, 3])
    }

    /// World points `[N, 3]` → local.
    pub fn to_local(&self, points: Tensor<2>) -> Tensor<2> {
        (points - self.centre.clone().reshape([1, 3])).matmul(self.rotation.clone())
    }

    /// Local directions `[N, 3]` → world (rotation only).
    pub fn rotate_to_world(&self, vectors: Tensor<2>) -> Tensor<2> {
        vectors.matmul(self.rotation.clone().transpose())
    }

    /// World directions `[N, 3]` → local (rotation only).
    pub fn rotate_to_local(&self, vectors: Tensor<2>) -> Tensor<2> {
        vectors.matmul(self.rotation.clone())
    }

    /// `[1, 4]` the unit quaternion (w, x, y, z) of the local → world rotation.
    pub fn quaternion(&self) -> Tensor<2> {
        matrix_to_quaternion(self.rotation.clone().reshape([1, 3, 3]))
    }
}

/// Row-major camera-to-world rotation and centre of a host camera.
pub fn camera_to_world(camera: &Camera) -> ([[f64; 3]; 3], [f64; 3]) {
    let m = camera.world_to_camera;
    let r = |i: usize, j: usize| f64::from(m[i][j]);
    let t = [f64::from(m[0][3]), f64::from(m[1][3]), f64::from(m[2][3])];
    // world_to_camera = [Rw | t] → camera_to_world rotation Rwᵀ, centre −Rwᵀ t.
    let rotation = [
        [r(0, 0), r(1, 0), r(2, 0)],
        [r(0, 1), r(1, 1), r(2, 1)],
        [r(0, 2), r(1, 2), r(2, 2)],
    ];
    let centre = [0, 1, 2].map(|i| -(0..3).map(|k| rotation[i][k] * t[k]).sum::<f64>());
    (rotation, centre)
}

/// A host camera with `camera`'s intrinsics and clipping at the world origin, axes aligned:
/// it renders splats already expressed in a camera frame.
pub fn camera_at_origin(camera: &Camera) -> Camera {
    Camera {
        world_to_camera: [
            [1.0, 0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, 0.0],
        ],
        ..*camera
    }
}

/// Splats carried from the world into `frame` (centres and rotations; scales, opacity and
/// colours unchanged). Rotations must be non-zero quaternions: the rasterizer reads a zero
/// quaternion as the identity in whatever frame it is rendered, which no rotation can move.
pub fn splats_in_frame(splats: &Splats, frame: &RigidFrame) -> Splats {
    let n = splats.len();
    // The conjugate of the local → world quaternion is world → local.
    let conjugate = Tensor::<2>::from_floats([[1.0, -1.0, -1.0, -1.0]], &splats.means.device());
    let to_local = frame.quaternion() * conjugate;
    Splats {
        means: frame.to_local(splats.means.clone()),
        quats: quaternion_product(to_local.expand([n, 4]), splats.quats.clone()),
        ..splats.clone()
    }
}

/// Splats carried from `frame` into the world.
pub fn splats_to_world(splats: &Splats, frame: &RigidFrame) -> Splats {
    let n = splats.len();
    Splats {
        means: frame.to_world(splats.means.clone()),
        quats: quaternion_product(frame.quaternion().expand([n, 4]), splats.quats.clone()),
        ..splats.clone()
    }
}
