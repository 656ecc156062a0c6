//! Stage 2's human (§3.2): the stage-1 face Gaussians freed in canonical space, each with a
//! learnable linear albedo `b`, posed by linear blend skinning.
//!
//! At the hand-over ([`PbrHuman::from_stage1`]) each face's Gaussian is placed at the
//! barycentre of the canonical refined mesh (the shaped rest body plus F_Δ's offsets), turned
//! by the canonical face frame and its in-plane angle, with stage 1's scales and opacity, and
//! `b = sRGB⁻¹(c)` for its stage-1 colour `c` (Eq. 7 returns `b` under the volume's initial unit
//! light with no occlusion and no specular, so the first stage-2 render matches the last
//! stage-1 render; tested per Gaussian and per image). Its skinning weights are the mean of its
//! face's vertices' weights, and its [`KnnTransfer`] starts at the face's three vertices with
//! weight ⅓ each (after density control it is rebuilt from the nearest vertices).
//!
//! Posing uses the engine's LBS of Gaussians ([`skin_splats`]): the blended joint transform
//! moves the mean and its orthonormal part turns the Gaussian.

use crate::human::{BodyMesh, RefinedBody};
use crate::lighting::KnnTransfer;
use crate::pbr::srgb_to_linear;
use burn::module::{Module, Param};
use burn::tensor::{Int, Tensor, TensorData};
use splatzoo_models::networks::hash_grid::HashQueries;
use splatzoo_models::normals::vertex_normals;
use splatzoo_rasterizer::Splats;
use splatzoo_train::scene::skinned::JointTransforms;
use splatzoo_train::scene::skinned::skinning::skin_splats;

/// The human's Gaussians in canonical space with their albedo.
#[derive(Module, Debug)]
pub struct PbrHuman {
    /// `[N, 3]` canonical centres.
    pub means: Param<Tensor<2>>,
    /// `[N, 4]` canonical rotations (w-first quaternions).
    pub quats: Param<Tensor<2>>,
    /// `[N, 3]` log standard deviations.
    pub log_scales: Param<Tensor<2>>,
    /// `[N]` opacity logits.
    pub opacity_logits: Param<Tensor<1>>,
    /// `[N, 3]` linear albedo `b` (read through [`PbrHuman::albedo`], clamped to [0, 1]).
    pub albedo: Param<Tensor<2>>,
}

/// What ties each Gaussian to the body: LBS weights `[N, J]` and the vertices its normal and
/// materials come from.
#[derive(Debug, Clone)]
pub struct Binding {
    pub skin_weights: Tensor<2>,
    pub transfer: KnnTransfer,
}

impl PbrHuman {
    /// Stage 2's start from stage 1: `shaped` `[V, 3]` is the shaped rest body of the subdivided
    /// model `mesh` was built on (`Posed::shaped` of the person's shape).
    pub fn from_stage1(
        body: &RefinedBody,
        mesh: &BodyMesh,
        queries: &HashQueries,
        shaped: Tensor<2>,
    ) -> (Self, Binding) {
        let v = mesh.vertex_count();
        let f = mesh.face_count();
        let device = shaped.device();
        assert_eq!(shaped.dims(), [v, 3], "shaped vertices must be [{v}, 3]");
        let canonical = (shaped + body.offsets(queries)).detach();
        let colours = body.vertex_colours(queries).detach();
        let splats = body.face_splats(mesh, canonical, colours);
        let albedo = srgb_to_linear(splats.colors.clone().reshape([f, 3]));
        let corners: Vec<i64> = mesh.model.faces.iter().map(|&i| i64::from(i)).collect();
        let transfer = KnnTransfer {
            indices: Tensor::<2, Int>::from_data(TensorData::new(corners, [f, 3]), &device),
            weights: Tensor::<2>::full([f, 3], 1.0 / 3.0, &device),
        };
        let joints = mesh.model.joint_count();
        let vertex_weights = Tensor::<2>::from_data(
            TensorData::new(mesh.model.skin_weights.clone(), [v, joints]),
            &device,
        );
        let binding = Binding {
            skin_weights: transfer.apply(vertex_weights),
            transfer,
        };
        let human = Self {
            means: Param::from_tensor(splats.means.detach()),
            quats: Param::from_tensor(splats.quats.detach()),
            log_scales: Param::from_tensor(splats.log_scales.detach()),
            opacity_logits: Param::from_tensor(splats.opacity_logits.detach()),
            albedo: Param::from_tensor(albedo.detach()),
        };
        (human, binding)
    }

    pub fn len(&self) -> usize {
        self.means.dims()[0]
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// `[N, 3]` albedo in [0, 1].
    pub fn albedo(&self) -> Tensor<2> {
        self.albedo.val().clamp(0.0, 1.0)
    }

    /// The Gaussians posed by `transforms` (each joint's rest → world map), carrying `colours`
    /// `[N, C]` as single-coefficient features.
    pub fn posed_splats(
        &self,
        binding: &Binding,
        transforms: &JointTransforms,
        colours: Tensor<2>,
    ) -> Splats {
        let n = self.len();
        let [rows, c] = colours.dims();
        assert_eq!(rows, n, "colours must be [{n}, C]");
        let canonical = Splats {
            means: self.means.val(),
            quats: self.quats.val(),
            log_scales: self.log_scales.val(),
            opacity_logits: self.opacity_logits.val(),
            colors: colours.reshape([n, 1, c]),
        };
        skin_splats(canonical, binding.skin_weights.clone(), transforms)
    }
}

/// World normals `[N, 3]` of the Gaussians: their vertices' normals of the posed refined mesh
/// `[V, 3]` blended by the binding and normalised.
pub fn posed_normals(binding: &Binding, mesh: &BodyMesh, posed: Tensor<2>) -> Tensor<2> {
    let v = mesh.vertex_count();
    let normals = vertex_normals(posed.reshape([1, v, 3]), &mesh.model.faces).reshape([v, 3]);
    let blended = binding.transfer.apply(normals);
    let length = (blended.clone().powi_scalar(2).sum_dim(1) + 1e-24).sqrt();
    blended / length
}
