//! APF-GS's objective (Eq. 6–7) beside the image terms:
//!
//! `L_total = L_photo + λ_pose L_pose + Σ_h [σ_{h,t} λ_sparse L_sparse^h
//!            + (1 − σ_{h,t}) λ_kine L_kine^h]`,  `L_kine = λ_bone L_bone + λ_limit L_limit`.
//!
//! σ is not detached in these weights (the "competitive interplay" that supervises it).
//! `L_bone` is computed on joints regressed from the *deformed* human (LBS ⊕ Δ): under pure
//! forward kinematics with one shape the bone lengths do not depend on θ, so the term would be
//! a constant. Bone lengths are invariant to the rigid `T_h`, so regressing from world-space
//! Gaussians equals regressing before `T_h`. Lengths are relative to those of the same frame's
//! LBS-only regressed joints, so the term reads only what Δ stretches.
//! `L_limit` is the squared excess of the refined local axis-angles beyond the AAOS ranges
//! (`splatzoo_models::body::priors`). `L_pose` is the skinned node's temporal smoothness.

use burn::tensor::Tensor;
use splatzoo_models::body::priors::{SMPL_ANGLE_LIMITS_DEG, angle_limit_loss, bone_lengths};
use splatzoo_models::rotation::matrix_to_axis_angle;

/// `L_bone` (relative): `mean_k ((‖J̃_k − J̃_par(k)‖ − ℓ_k) / ℓ_k)²` for joints `[J, 3]` and
/// reference lengths `[J − 1]` (joint order, root skipped).
pub fn relative_bone_loss(
    joints: Tensor<2>,
    parents: &[Option<usize>],
    reference: Tensor<1>,
) -> Tensor<1> {
    let [j, _] = joints.dims();
    let lengths = bone_lengths(joints.reshape([1, j, 3]), parents);
    let [_, n] = lengths.dims();
    let reference = reference.reshape([1, n]);
    ((lengths - reference.clone()) / reference.clamp_min(1e-6))
        .powi_scalar(2)
        .mean()
}

/// `L_limit` on local joint rotations `[1, J, 3, 3]` (the first 24 joints, SMPL's).
pub fn limit_loss(rotations: Tensor<4>) -> Tensor<1> {
    let [_, j, _, _] = rotations.dims();
    let k = j.min(SMPL_ANGLE_LIMITS_DEG.len());
    let axis_angles = matrix_to_axis_angle(rotations.reshape([j, 3, 3])).slice([0..k, 0..3]);
    angle_limit_loss(axis_angles.reshape([1, 3 * k]), &SMPL_ANGLE_LIMITS_DEG[..k])
}

/// One person's Eq. 6 regulariser: `σ λ_sparse L_sparse + (1 − σ) λ_kine (λ_bone L_bone +
/// λ_limit L_limit)`, σ kept in the graph. With one σ per person-frame, `sigma` is `[1, 1]` and
/// `sparsity` `[1]` (`L_sparse`); with a per-Gaussian gate, `sigma` is `[G, 1]` and `sparsity`
/// `[G]` (each Gaussian's row), so the sparse term is `mean_i σ_i s_i` and the kinematic weight
/// `1 − mean_i σ_i` (the body's kinematics are one term).
pub struct PersonTerms {
    pub sigma: Tensor<2>,
    pub sparsity: Tensor<1>,
    pub bone: Tensor<1>,
    pub limit: Tensor<1>,
}

/// The weights of [`PersonTerms::total`]; `sigma_reads_limit = false` detaches σ in the
/// `L_limit` product only (`loss.sigma_reads_limit`); `sigma_prior` is `λ_σ` of
/// `λ_σ mean_i (σ_i − σ₀)²` with `σ₀ = sigma_start` (`loss.sigma_prior`, off at 0).
pub struct TermWeights {
    pub sparse: f64,
    pub kine: f64,
    pub bone: f64,
    pub limit: f64,
    pub sigma_reads_limit: bool,
    pub sigma_prior: f64,
    pub sigma_start: f64,
}

impl PersonTerms {
    pub fn total(&self, w: &TermWeights) -> Tensor<1> {
        let [rows, _] = self.sigma.dims();
        let (sparse, sigma) = if rows == 1 {
            let sigma = self.sigma.clone().reshape([1]);
            (sigma.clone() * self.sparsity.clone(), sigma)
        } else {
            let sigma = self.sigma.clone().reshape([rows]);
            ((sigma.clone() * self.sparsity.clone()).mean(), sigma.mean())
        };
        let one_minus = |s: Tensor<1>| s * -1.0 + 1.0;
        let bone = self.bone.clone() * w.bone;
        let limit = self.limit.clone() * w.limit;
        let kine = if w.sigma_reads_limit {
            one_minus(sigma) * (bone + limit)
        } else {
            one_minus(sigma.clone()) * bone + one_minus(sigma.detach()) * limit
        };
        let total = sparse * w.sparse + kine * w.kine;
        if w.sigma_prior == 0.0 {
            return total;
        }
        let prior = (self.sigma.clone() - w.sigma_start).powi_scalar(2).mean();
        total + prior * w.sigma_prior
    }
}

/// Binary cross-entropy of an alpha map `[H, W]` against a target `[H, W]`, averaged with
/// per-pixel weights `[H, W]` (0 ignores a pixel).
pub fn weighted_bce(alpha: Tensor<2>, target: Tensor<2>, weight: Tensor<2>) -> Tensor<1> {
    let a = alpha.clamp(1e-4, 1.0 - 1e-4);
    let per_pixel =
        -(target.clone() * a.clone().log() + (target * -1.0 + 1.0) * (a * -1.0 + 1.0).log());
    let total = weight.clone().sum().clamp_min(1.0);
    (per_pixel * weight).sum() / total
}

/// L1 between rendered depth `[H, W]` and sparse depth (NaN-free values `[H, W]` with a 0/1
/// validity map), where the render is mostly opaque.
pub fn sparse_depth_l1(
    depth: Tensor<2>,
    alpha: Tensor<2>,
    target: Tensor<2>,
    valid: Tensor<2>,
) -> Tensor<1> {
    let weight = valid * alpha.detach().greater_elem(0.5).float();
    let total = weight.clone().sum().clamp_min(1.0);
    ((depth - target).abs() * weight).sum() / total
}
