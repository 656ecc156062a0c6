//! Forward kinematics and linear blend skinning as differentiable Burn ops (SMPL, Loper et al.
//! 2015, Eqs. 2–4): shape blend shapes, joint regression, pose correctives, the kinematic chain,
//! and per-vertex blended rigid transforms, batched over frames.

use super::model::BodyModel;
use crate::rotation::axis_angle_to_matrix;
use burn::tensor::{Device, Tensor, TensorData};

/// A body model's arrays as tensors on one device, laid out for batched matmuls.
#[derive(Debug, Clone)]
pub struct BodyTensors {
    /// `[V, 3]`.
    pub template: Tensor<2>,
    /// `[S, V·3]`.
    pub shape_dirs: Tensor<2>,
    /// `[E, V·3]`, if the model has expressions.
    pub expression_dirs: Option<Tensor<2>>,
    /// `[9 (J − 1), V·3]`, if the model has pose correctives.
    pub pose_dirs: Option<Tensor<2>>,
    /// `[J, V]`.
    pub joint_regressor: Tensor<2>,
    /// `[V, J]`.
    pub skin_weights: Tensor<2>,
    pub parents: Vec<Option<usize>>,
}

/// `[V, 3, K]` (row-major) → `[K, V·3]`.
fn dirs_matrix(values: &[f32], v: usize, device: &Device) -> Tensor<2> {
    let k = values.len() / (3 * v);
    Tensor::<2>::from_data(TensorData::new(values.to_vec(), [v * 3, k]), device).transpose()
}

impl BodyTensors {
    pub fn new(model: &BodyModel, device: &Device) -> Self {
        let v = model.vertex_count();
        let j = model.joint_count();
        let t2 = |values: &[f32], shape: [usize; 2]| {
            Tensor::<2>::from_data(TensorData::new(values.to_vec(), shape), device)
        };
        Self {
            template: t2(&model.template, [v, 3]),
            shape_dirs: dirs_matrix(&model.shape_dirs, v, device),
            expression_dirs: model
                .expression_dirs
                .as_ref()
                .map(|e| dirs_matrix(e, v, device)),
            pose_dirs: model.pose_dirs.as_ref().map(|p| dirs_matrix(p, v, device)),
            joint_regressor: t2(&model.joint_regressor, [j, v]),
            skin_weights: t2(&model.skin_weights, [v, j]),
            parents: model.parents.clone(),
        }
    }

    pub fn vertex_count(&self) -> usize {
        self.template.dims()[0]
    }

    pub fn joint_count(&self) -> usize {
        self.parents.len()
    }
}

/// One batch of body parameters.
#[derive(Debug, Clone)]
pub struct PoseInput {
    /// `[B, S']` shape coefficients, `S'` at most the model's; missing ones are 0.
    pub betas: Tensor<2>,
    /// `[B, J, 3, 3]` local joint rotations; joint 0 is the global orientation.
    pub joint_rotations: Tensor<4>,
    /// `[B, 3]` global translation.
    pub translation: Tensor<2>,
    /// `[B, E']` expression coefficients, for models with expression directions.
    pub expression: Option<Tensor<2>>,
}

impl PoseInput {
    /// From SMPL-style axis-angle poses `[B, 3 J]` (72-D for SMPL).
    pub fn from_axis_angle(betas: Tensor<2>, pose: Tensor<2>, translation: Tensor<2>) -> Self {
        let [b, p] = pose.dims();
        let j = p / 3;
        let rotations = axis_angle_to_matrix(pose.reshape([b * j, 3])).reshape([b, j, 3, 3]);
        Self {
            betas,
            joint_rotations: rotations,
            translation,
            expression: None,
        }
    }
}

/// A posed batch.
#[derive(Debug, Clone)]
pub struct Posed {
    /// `[B, V, 3]` world-space vertices.
    pub vertices: Tensor<3>,
    /// `[B, J, 3]` joint positions in world space.
    pub joints: Tensor<3>,
    /// `[B, J, 3, 3]` joint orientations in world space (accessories attach to these).
    pub joint_rotations: Tensor<4>,
    /// `[B, V, 3, 3]` and `[B, V, 3]`: each vertex's blended transform, rest → world
    /// (`x_world = R x_rest_posed + t`); it carries Gaussians anchored to the surface.
    pub vertex_rotations: Tensor<4>,
    pub vertex_translations: Tensor<3>,
    /// `[B, J, 3]`: with `joint_rotations`, each joint's rigid transform rest → world
    /// (`x_world = R_j x_rest + t_j`, global translation included); the vertex transforms are
    /// these blended by the skinning weights, and skinned Gaussians use them directly.
    pub skinning_translations: Tensor<3>,
    /// `[B, V, 3]` shaped (and expression-blended) rest vertices, before pose correctives.
    pub shaped: Tensor<3>,
}

/// Blend directions `[K, V·3]` weighted by coefficients `[B, K']` (`K' <= K`) → `[B, V, 3]`.
fn blend(coeffs: Tensor<2>, dirs: &Tensor<2>, v: usize) -> Tensor<3> {
    let [b, k] = coeffs.dims();
    let available = dirs.dims()[0];
    assert!(
        k <= available,
        "{k} coefficients for {available} blend directions"
    );
    let dirs = dirs.clone().slice([0..k, 0..v * 3]);
    coeffs.matmul(dirs).reshape([b, v, 3])
}

/// Eqs. 2–4 of SMPL: shape, correctives, kinematic chain, skinning.
pub fn pose(body: &BodyTensors, input: &PoseInput) -> Posed {
    let v = body.vertex_count();
    let j = body.joint_count();
    let [b, _] = input.betas.dims();
    assert_eq!(
        input.joint_rotations.dims(),
        [b, j, 3, 3],
        "joint_rotations must be [B, J, 3, 3]"
    );
    assert_eq!(
        input.translation.dims(),
        [b, 3],
        "translation must be [B, 3]"
    );
    let device = input.betas.device();

    let mut shaped =
        body.template.clone().reshape([1, v, 3]) + blend(input.betas.clone(), &body.shape_dirs, v);
    if let (Some(expr), Some(dirs)) = (&input.expression, &body.expression_dirs) {
        shaped = shaped + blend(expr.clone(), dirs, v);
    }
    // Joints from the shaped rest mesh.
    let regressor = body
        .joint_regressor
        .clone()
        .reshape([1, j, v])
        .expand([b, j, v]);
    let rest_joints = regressor.matmul(shaped.clone()); // [B, J, 3]

    let rotations = input.joint_rotations.clone();
    let mut posed_rest = shaped.clone();
    if let Some(dirs) = &body.pose_dirs {
        let eye = Tensor::<2>::eye(3, &device).reshape([1, 1, 3, 3]);
        let feature =
            (rotations.clone().slice([0..b, 1..j, 0..3, 0..3]) - eye).reshape([b, (j - 1) * 9]);
        posed_rest = posed_rest + blend(feature, dirs, v);
    }

    // Kinematic chain: G_j = G_parent · [R_j | J_j − J_parent].
    let joint_rot = |k: usize| {
        rotations
            .clone()
            .slice([0..b, k..k + 1, 0..3, 0..3])
            .reshape([b, 3, 3])
    };
    let joint_pos = |k: usize| {
        rest_joints
            .clone()
            .slice([0..b, k..k + 1, 0..3])
            .reshape([b, 3, 1])
    };
    let mut world_rot: Vec<Tensor<3>> = Vec::with_capacity(j);
    let mut world_pos: Vec<Tensor<3>> = Vec::with_capacity(j);
    for k in 0..j {
        let (rot, pos) = match body.parents[k] {
            None => (joint_rot(k), joint_pos(k)),
            Some(p) => {
                let offset = joint_pos(k) - joint_pos(p);
                (
                    world_rot[p].clone().matmul(joint_rot(k)),
                    world_rot[p].clone().matmul(offset) + world_pos[p].clone(),
                )
            }
        };
        world_rot.push(rot);
        world_pos.push(pos);
    }
    // Rest-relative transforms: x ↦ R_j (x − J_j) + G_j(t).
    let rel_trans: Vec<Tensor<3>> = (0..j)
        .map(|k| world_pos[k].clone() - world_rot[k].clone().matmul(joint_pos(k)))
        .collect();
    let rots = Tensor::stack::<4>(world_rot, 1); // [B, J, 3, 3]
    let trans = Tensor::cat(rel_trans, 2).swap_dims(1, 2); // [B, J, 3]
    let joints = Tensor::cat(world_pos, 2).swap_dims(1, 2); // [B, J, 3]

    // Skinning: T_v = Σ_j w_vj G'_j.
    let weights = body
        .skin_weights
        .clone()
        .reshape([1, v, j])
        .expand([b, v, j]);
    let vertex_rotations = weights
        .clone()
        .matmul(rots.clone().reshape([b, j, 9]))
        .reshape([b, v, 3, 3]);
    let translation = input.translation.clone().reshape([b, 1, 3]);
    let skinning_translations = trans.clone() + translation.clone();
    let vertex_translations = weights.matmul(trans) + translation.clone();
    let rotated = vertex_rotations
        .clone()
        .matmul(posed_rest.reshape([b, v, 3, 1]))
        .reshape([b, v, 3]);
    Posed {
        vertices: rotated + vertex_translations.clone(),
        joints: joints + translation,
        joint_rotations: rots,
        vertex_rotations,
        vertex_translations,
        skinning_translations,
        shaped,
    }
}
