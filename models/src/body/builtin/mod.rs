//! The project's own body, the embedded default where no SMPL file is given: procedural,
//! watertight, about 7k vertices, with SMPL's 24 joints (names, order, tree, and rest positions
//! close to SMPL's), so a 72-D SMPL pose vector drives it unchanged.
//!
//! How it is made, deterministically, in about a second:
//! 1. [`solids`]: the mean body as a smooth union of ellipsoids and round cones.
//! 2. [`mesher`]: marching tetrahedra on a 5 mm lattice (closed and manifold by construction).
//! 3. [`remesh`]: edge collapse to the vertex budget against per-region edge lengths (finer on
//!    the face and hands), and tangential relaxation, every vertex kept on the surface.
//! 4. [`rig`]: bone labels, skinning weights diffused over the mesh, the surface bound to the
//!    bones so the twelve shape components of [`proportions`] are exact blend shapes, and a joint
//!    regressor that reproduces the skeleton for every shape.
//! 5. [`uv`]: one texture chart per bone.
//!
//! It has no pose correctives and no expressions. It is not SMPL: shape coefficients mean
//! different things (listed in [`SHAPE_COMPONENTS`]), and vertex indices do not correspond.

pub mod mesher;
pub mod proportions;
pub mod remesh;
pub mod rig;
pub mod sdf;
pub mod solids;
pub mod uv;

pub use proportions::{SHAPE_COMPONENTS, SHAPE_COUNT};
pub use uv::UvMap;

use super::model::{BodyKind, BodyModel};
use super::skeleton::{SMPL_JOINT_NAMES, SMPL_PARENTS};
use proportions::{JOINTS, Skeleton};
use sdf::{V3, norm, sub};
use std::sync::OnceLock;

/// Lattice spacing of the marching step, metres.
const LATTICE: f64 = 0.005;
/// Vertices of the final mesh.
const VERTEX_BUDGET: usize = 7000;
const RELAX_ROUNDS: usize = 4;

/// The built-in body: the model, and what the synthetic scenes and face losses need besides.
#[derive(Debug, Clone)]
pub struct BuiltinBody {
    pub model: BodyModel,
    pub uv: UvMap,
    /// The joint whose bone owns each vertex (clothing and skin regions are painted from it).
    pub part_of_vertex: Vec<u8>,
    /// Vertices of the face (front of the head between chin and brow).
    pub face_region: Vec<bool>,
    /// Named surface points as vertex indices: `nose_tip`, `left_eye`, `right_eye`, `mouth`,
    /// `chin`, `left_ear`, `right_ear`, `head_top`, `left_fingertip`, `right_fingertip`,
    /// `left_toe`, `right_toe`, `left_heel`, `right_heel`.
    pub landmarks: Vec<(&'static str, u32)>,
}

impl BuiltinBody {
    /// The vertex of a named landmark.
    pub fn landmark(&self, name: &str) -> Option<u32> {
        self.landmarks
            .iter()
            .find(|(n, _)| *n == name)
            .map(|(_, v)| *v)
    }
}

/// The built-in body, generated on first use and shared.
pub fn builtin_body() -> &'static BuiltinBody {
    static BODY: OnceLock<BuiltinBody> = OnceLock::new();
    BODY.get_or_init(generate)
}

/// Generates the built-in body from scratch (deterministic; prefer [`builtin_body`]).
pub fn generate() -> BuiltinBody {
    let body = solids::mean_body();
    let dense = mesher::march(&body, LATTICE);
    let mesh = remesh::simplify(&body, &dense, VERTEX_BUDGET, RELAX_ROUNDS);
    let mean = Skeleton::mean();
    let labels = rig::bone_labels(&body, &mesh, &mean);
    let neighbours = rig::vertex_neighbours(&mesh);
    let weights = rig::skinning_weights(&labels, &neighbours);
    let binding = rig::SurfaceBinding::new(&mesh, &weights, &mean);
    let shape_dirs = rig::shape_directions(&binding, &mesh.vertices);
    let regressor = rig::joint_regressor(&mesh.vertices, &shape_dirs, &mean);
    let uv = uv::unwrap(&mesh, &labels, &mean);

    let face_region = mesh
        .vertices
        .iter()
        .zip(&labels)
        .map(|(p, &l)| l == 15 && p[2] > 0.05 && p[1] > 0.315 && p[1] < 0.475 && p[0].abs() < 0.07)
        .collect();
    let landmarks = landmarks(&mesh.vertices, &labels);

    let to_f32 = |x: &[f64]| x.iter().map(|&v| v as f32).collect::<Vec<f32>>();
    let model = BodyModel {
        kind: BodyKind::Builtin,
        template: mesh.vertices.iter().flatten().map(|&v| v as f32).collect(),
        faces: mesh.faces.iter().flatten().copied().collect(),
        joint_regressor: to_f32(&regressor),
        parents: SMPL_PARENTS.to_vec(),
        skin_weights: to_f32(&weights),
        shape_dirs: to_f32(&shape_dirs),
        pose_dirs: None,
        expression_dirs: None,
        joint_names: SMPL_JOINT_NAMES.iter().map(|s| s.to_string()).collect(),
        face_landmarks: None,
    };
    debug_assert_eq!(model.joint_count(), JOINTS);
    BuiltinBody {
        model,
        uv,
        part_of_vertex: labels,
        face_region,
        landmarks,
    }
}

/// Landmarks as the vertices nearest to points on the mean body (restricted to the right bone).
fn landmarks(vertices: &[V3], labels: &[u8]) -> Vec<(&'static str, u32)> {
    let nearest = |target: V3, joints: &[u8]| -> u32 {
        let mut best = (f64::INFINITY, 0u32);
        for (i, (p, l)) in vertices.iter().zip(labels).enumerate() {
            if joints.contains(l) {
                let d = norm(sub(*p, target));
                if d < best.0 {
                    best = (d, i as u32);
                }
            }
        }
        best.1
    };
    vec![
        ("nose_tip", nearest([0.0, 0.41, 0.16], &[15])),
        ("left_eye", nearest([0.032, 0.445, 0.11], &[15])),
        ("right_eye", nearest([-0.032, 0.445, 0.11], &[15])),
        ("mouth", nearest([0.0, 0.372, 0.12], &[15])),
        ("chin", nearest([0.0, 0.32, 0.09], &[15])),
        ("left_ear", nearest([0.095, 0.425, 0.008], &[15])),
        ("right_ear", nearest([-0.095, 0.425, 0.008], &[15])),
        ("head_top", nearest([0.0, 0.55, 0.02], &[15])),
        ("left_fingertip", nearest([0.95, 0.222, -0.058], &[22])),
        ("right_fingertip", nearest([-0.95, 0.222, -0.058], &[23])),
        ("left_toe", nearest([0.102, -1.14, 0.16], &[7, 10])),
        ("right_toe", nearest([-0.102, -1.14, 0.16], &[8, 11])),
        ("left_heel", nearest([0.102, -1.15, -0.09], &[7, 10])),
        ("right_heel", nearest([-0.102, -1.15, -0.09], &[8, 11])),
    ]
}
