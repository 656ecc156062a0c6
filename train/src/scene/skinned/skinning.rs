//! Linear blend skinning of Gaussians (SMPL's Eq. 4 applied to splats, as GauHuman and
//! 3DGS-Avatar do): each Gaussian's transform is its skinning weights times the joints'
//! canonical → posed transforms; the blended matrix moves the mean, and its orthonormalised
//! part (Gram–Schmidt) rotates the Gaussian. Scales, opacities and colours are kept.

use burn::tensor::{Tensor, TensorData};
use splatzoo_models::rotation::{
    matrix_to_quaternion, matrix_to_rotation_6d, rotation_6d_to_matrix,
};
use splatzoo_rasterizer::Splats;

/// Rigid transforms of the joints, `x ↦ R_j x + t_j`.
#[derive(Debug, Clone)]
pub struct JointTransforms {
    /// `[J, 3, 3]`.
    pub rotations: Tensor<3>,
    /// `[J, 3]`.
    pub translations: Tensor<2>,
}

impl JointTransforms {
    pub fn joints(&self) -> usize {
        self.rotations.dims()[0]
    }

    /// `self ∘ other⁻¹` for rigid `other`: the map from where `other` puts a point to where
    /// `self` puts it (canonical pose → target pose when both start from the rest pose).
    pub fn after_inverse_of(&self, other: &JointTransforms) -> JointTransforms {
        let j = self.joints();
        let rotations = self
            .rotations
            .clone()
            .matmul(other.rotations.clone().swap_dims(1, 2));
        let moved = rotations
            .clone()
            .matmul(other.translations.clone().reshape([j, 3, 1]))
            .reshape([j, 3]);
        JointTransforms {
            rotations,
            translations: self.translations.clone() - moved,
        }
    }

    /// `[J, 4, 4]` homogeneous matrices.
    pub fn homogeneous(&self) -> Tensor<3> {
        let j = self.joints();
        let device = self.rotations.device();
        let top = Tensor::cat(
            vec![
                self.rotations.clone(),
                self.translations.clone().reshape([j, 3, 1]),
            ],
            2,
        );
        let bottom = Tensor::<3>::from_data(
            TensorData::new(vec![0.0f32, 0.0, 0.0, 1.0], [1, 1, 4]),
            &device,
        )
        .expand([j, 1, 4]);
        Tensor::cat(vec![top, bottom], 1)
    }
}

/// Hamilton product of w-first quaternions `[N, 4]`.
pub fn quaternion_product(a: Tensor<2>, b: Tensor<2>) -> Tensor<2> {
    let n = a.dims()[0];
    let c = |t: &Tensor<2>, k: usize| t.clone().slice([0..n, k..k + 1]);
    let (aw, ax, ay, az) = (c(&a, 0), c(&a, 1), c(&a, 2), c(&a, 3));
    let (bw, bx, by, bz) = (c(&b, 0), c(&b, 1), c(&b, 2), c(&b, 3));
    Tensor::cat(
        vec![
            aw.clone() * bw.clone()
                - ax.clone() * bx.clone()
                - ay.clone() * by.clone()
                - az.clone() * bz.clone(),
            aw.clone() * bx.clone() + ax.clone() * bw.clone() + ay.clone() * bz.clone()
                - az.clone() * by.clone(),
            aw.clone() * by.clone() - ax.clone() * bz.clone()
                + ay.clone() * bw.clone()
                + az.clone() * bx.clone(),
            aw * bz + ax * by - ay * bx + az * bw,
        ],
        1,
    )
}

/// Unit quaternions `[N, 4]`; a zero quaternion (the rasterizer's identity) becomes (1, 0, 0, 0).
pub fn unit_quaternions(q: Tensor<2>) -> Tensor<2> {
    let n = q.dims()[0];
    let norm = q.clone().powi_scalar(2).sum_dim(1).sqrt(); // [N, 1]
    let zero = norm.clone().lower_equal_elem(1e-12);
    let identity = Tensor::<2>::from_data(
        TensorData::new(vec![1.0f32, 0.0, 0.0, 0.0], [1, 4]),
        &q.device(),
    )
    .expand([n, 4]);
    (q / norm.clamp_min(1e-12)).mask_where(zero.expand([n, 4]), identity)
}

/// Per-Gaussian blended transforms `[G, 3, 3]`, `[G, 3]` from weights `[G, J]`.
pub fn blend(weights: Tensor<2>, transforms: &JointTransforms) -> (Tensor<3>, Tensor<2>) {
    let g = weights.dims()[0];
    let j = transforms.joints();
    assert_eq!(weights.dims(), [g, j], "skinning weights must be [G, J]");
    let rotations = weights
        .clone()
        .matmul(transforms.rotations.clone().reshape([j, 9]))
        .reshape([g, 3, 3]);
    let translations = weights.matmul(transforms.translations.clone());
    (rotations, translations)
}

/// Gaussians carried by LBS: `μ' = A μ + b` with `(A, b) = Σ_j w_j T_j`, `q' = q(orth A) ⊗ q`.
pub fn skin_splats(splats: Splats, weights: Tensor<2>, transforms: &JointTransforms) -> Splats {
    let g = splats.len();
    let (blended, translations) = blend(weights, transforms);
    let means = blended
        .clone()
        .matmul(splats.means.reshape([g, 3, 1]))
        .reshape([g, 3])
        + translations;
    let rigid = rotation_6d_to_matrix(matrix_to_rotation_6d(blended));
    let quats = quaternion_product(matrix_to_quaternion(rigid), unit_quaternions(splats.quats));
    Splats {
        means,
        quats,
        log_scales: splats.log_scales,
        opacity_logits: splats.opacity_logits,
        colors: splats.colors,
    }
}
