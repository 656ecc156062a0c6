//! The accessory node of APF-GS (§II-D, Eq. 8): a deformable Gaussian set that is a child of
//! one joint of its human, `T_acc(t) = T_parent(t) · ΔT_attach`.
//!
//! - `T_parent(t)` is the parent joint's world transform from the human node's output this
//!   frame (its refined forward kinematics, no residual: the paper's "skeletal joint
//!   transformation matrices"); the node must come after its human in the graph.
//! - `ΔT_attach ∈ SE(3)` is one time-constant learned transform (axis-angle `r`, translation
//!   `τ`), identity at the start, with its own Adam and learning rates.
//! - The canonical Gaussians live in the parent joint's frame; a "general deformable Gaussian
//!   model" adds `(δx, δq) = D_ψ(γ(x̄), γ(t), e_a)` before the attachment:
//!   `x_w = T_acc (x̄ + δx)`, `q_w = q_acc ⊗ n(q̄ + δq)` (no scale output, drivestudio's
//!   `deform_scale: False`).
//!
//! Gradients reach the parent's pose through `T_parent` unless `detach_parent` is set.

use crate::networks::{ACCESSORY_COLUMNS, AccessoryField};
use crate::residual::{bounding_box, encode_positions};
use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_models::networks::encoding::frequency_encoding;
use splatzoo_models::rotation::{axis_angle_to_matrix, matrix_to_quaternion};
use splatzoo_rasterizer::Splats;
use splatzoo_train::adam::{AdamConfig, AdamState};
use splatzoo_train::checkpoint::{Checkpoint, CheckpointError};
use splatzoo_train::densify::{DensifyConfig, DensifyReport};
use splatzoo_train::gaussians::GaussianSet;
use splatzoo_train::optimizer::LearningRates;
use splatzoo_train::scene::skinned::skinning::{quaternion_product, unit_quaternions};
use splatzoo_train::scene::{
    FrameContext, FrameQuery, GaussianNode, NodeOutput, SceneNode, StepEnd,
};

/// The accessory network for one step, with what conditions it.
pub struct AccessoryDeformation {
    pub field: AccessoryField,
    /// `[1, embedding]` this accessory's `e_a`.
    pub embedding: Tensor<2>,
    pub position_levels: usize,
    pub time_levels: usize,
    /// Sequence duration, seconds (`γ(t)` reads `t / duration`).
    pub duration: f64,
}

/// Learning rates of `ΔT_attach`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AttachRates {
    pub rotation: f64,
    pub translation: f64,
}

impl Default for AttachRates {
    /// The spec's 1e-4 (rotation) and 5e-4 (translation).
    fn default() -> Self {
        Self {
            rotation: 1e-4,
            translation: 5e-4,
        }
    }
}

struct Attach {
    /// `[1, 3]` axis-angle and `[1, 3]` translation (metres, parent frame).
    rotation: Tensor<2>,
    translation: Tensor<2>,
    rotation_adam: AdamState<2>,
    translation_adam: AdamState<2>,
    leaves: Option<(Tensor<2>, Tensor<2>)>,
}

pub struct AccessoryNode {
    set: GaussianNode,
    /// The human node it hangs from and the parent joint.
    pub parent: String,
    pub joint: usize,
    attach: Attach,
    rates: AttachRates,
    pub detach_parent: bool,
    /// The canonical bounding box (centre, half extent) `γ(x̄)` normalises to.
    centre: [f32; 3],
    half_extent: [f32; 3],
    in_step: bool,
}

/// Adam for the attachment (ε = 1e-8).
fn adam() -> AdamConfig {
    AdamConfig {
        epsilon: 1e-8,
        ..AdamConfig::default()
    }
}

/// The rigid part of `T_parent · ΔT_attach`: rotation `[3, 3]` and translation `[1, 3]`.
pub fn attached(
    parent_rotation: Tensor<2>,
    parent_position: Tensor<2>,
    attach_rotation: Tensor<2>,
    attach_translation: Tensor<2>,
) -> (Tensor<2>, Tensor<2>) {
    let delta = axis_angle_to_matrix(attach_rotation).reshape([3, 3]);
    let rotation = parent_rotation.clone().matmul(delta);
    let translation = attach_translation.matmul(parent_rotation.transpose()) + parent_position;
    (rotation, translation)
}

impl AccessoryNode {
    /// An accessory named `name` on joint `joint` of node `parent`, its Gaussians `set` in that
    /// joint's frame.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        name: &str,
        parent: &str,
        joint: usize,
        set: GaussianSet,
        rates: LearningRates,
        attach_rates: AttachRates,
        densify: &DensifyConfig,
        seed: u64,
    ) -> Self {
        let device = set.means.device();
        let (centre, half_extent) = bounding_box(&splatzoo_train::host_f32(&set.means), 0.05);
        let zeros = Tensor::<2>::zeros([1, 3], &device);
        Self {
            set: GaussianNode::new(name, set, rates, densify, 1.0, seed),
            parent: parent.to_owned(),
            joint,
            attach: Attach {
                rotation_adam: AdamState::new(&zeros),
                translation_adam: AdamState::new(&zeros),
                rotation: zeros.clone(),
                translation: zeros,
                leaves: None,
            },
            rates: attach_rates,
            detach_parent: false,
            centre,
            half_extent,
            in_step: false,
        }
    }

    /// The canonical Gaussians (parent-joint frame).
    pub fn canonical_set(&self) -> &GaussianSet {
        &self.set.set
    }

    /// `ΔT_attach` as (axis-angle, translation), plain values.
    pub fn attachment(&self) -> ([f32; 3], [f32; 3]) {
        let v = |t: &Tensor<2>| {
            let h = splatzoo_train::host_f32(t);
            [h[0], h[1], h[2]]
        };
        (v(&self.attach.rotation), v(&self.attach.translation))
    }

    fn attach_tensors(&self) -> (Tensor<2>, Tensor<2>) {
        match &self.attach.leaves {
            Some((r, t)) => (r.clone(), t.clone()),
            None if self.in_step => (
                self.attach.rotation.clone().autodiff(),
                self.attach.translation.clone().autodiff(),
            ),
            None => (
                self.attach.rotation.clone(),
                self.attach.translation.clone(),
            ),
        }
    }

    /// The accessory in the parent frame at `time` seconds (canonical plus `D_ψ`'s offsets).
    fn deformed(
        &self,
        canonical: Splats,
        time: f64,
        deformation: Option<&AccessoryDeformation>,
    ) -> Splats {
        let Some(d) = deformation else {
            return canonical;
        };
        let g = canonical.len();
        if g == 0 {
            return canonical;
        }
        let device = canonical.means.device();
        let positions = encode_positions(
            canonical.means.clone(),
            self.centre,
            self.half_extent,
            d.position_levels,
        );
        let t = (time / d.duration.max(1e-9)) as f32;
        let mut times = frequency_encoding(
            Tensor::<2>::from_data(TensorData::new(vec![t], [1, 1]), &device),
            d.time_levels,
        );
        let embedding = d.embedding.clone();
        if self.in_step {
            times = times.autodiff();
        }
        let [_, tw] = times.dims();
        let [_, ew] = embedding.dims();
        let input = Tensor::cat(
            vec![positions, times.expand([g, tw]), embedding.expand([g, ew])],
            1,
        );
        let raw = d.field.forward(input);
        debug_assert_eq!(raw.dims(), [g, ACCESSORY_COLUMNS]);
        Splats {
            means: canonical.means + raw.clone().slice([0..g, 0..3]),
            quats: unit_quaternions(canonical.quats + raw.slice([0..g, 3..7])),
            ..canonical
        }
    }
}

impl AccessoryNode {
    /// [`SceneNode::render`] with the accessory network `D_ψ` (`None`: rigid).
    pub fn render_with(
        &self,
        query: &FrameQuery,
        context: &FrameContext,
        deformation: Option<&AccessoryDeformation>,
    ) -> NodeOutput {
        let joints = context
            .node(&self.parent)
            .and_then(|o| o.joints.clone())
            .unwrap_or_else(|| {
                panic!(
                    "accessory `{}` needs its parent `{}` (with joints) earlier in the graph",
                    self.name(),
                    self.parent
                )
            });
        let k = self.joint;
        let mut parent = joints.slice([k..k + 1, 0..3, 0..4]).reshape([3, 4]);
        if self.detach_parent {
            parent = parent.detach();
        }
        let parent_rotation = parent.clone().slice([0..3, 0..3]);
        let parent_position = parent.slice([0..3, 3..4]).reshape([1, 3]);
        let (r, t) = self.attach_tensors();
        let (rotation, translation) = attached(parent_rotation, parent_position, r, t);
        let canonical = self.set.render(query, context).splats;
        let local = self.deformed(canonical, query.time, deformation);
        let g = local.len();
        let means = local.means.matmul(rotation.clone().transpose()) + translation.expand([g, 3]);
        let q = matrix_to_quaternion(rotation.reshape([1, 3, 3])).expand([g, 4]);
        let quats = quaternion_product(q, unit_quaternions(local.quats));
        NodeOutput::splats(Splats {
            means,
            quats,
            ..local
        })
    }
}

impl SceneNode for AccessoryNode {
    fn name(&self) -> &str {
        self.set.name()
    }

    fn gaussians(&self) -> usize {
        self.set.gaussians()
    }

    fn begin_step(&mut self) {
        self.set.begin_step();
        self.attach.leaves = Some((
            self.attach.rotation.clone().autodiff().require_grad(),
            self.attach.translation.clone().autodiff().require_grad(),
        ));
        self.in_step = true;
    }

    fn render(&self, query: &FrameQuery, context: &FrameContext) -> NodeOutput {
        // As a plain graph node the accessory is rigid; the trainer renders it with `D_ψ`
        // through [`AccessoryNode::render_with`].
        self.render_with(query, context, None)
    }

    fn regulariser(&self) -> Option<Tensor<1>> {
        self.set.regulariser()
    }

    fn end_step(&mut self, end: &StepEnd) -> Option<DensifyReport> {
        let report = self.set.end_step(end);
        if let Some((r, t)) = self.attach.leaves.take() {
            if let Some(g) = r.grad(end.grads) {
                self.attach.rotation = self.attach.rotation_adam.step(
                    self.attach.rotation.clone(),
                    g,
                    self.rates.rotation,
                    &adam(),
                );
            }
            if let Some(g) = t.grad(end.grads) {
                self.attach.translation = self.attach.translation_adam.step(
                    self.attach.translation.clone(),
                    g,
                    self.rates.translation,
                    &adam(),
                );
            }
        }
        self.set.take_lineage();
        self.in_step = false;
        report
    }

    fn save(&self, checkpoint: &mut Checkpoint, prefix: &str) {
        self.set.save(checkpoint, prefix);
        checkpoint.put(&format!("{prefix}.attach.rotation"), &self.attach.rotation);
        checkpoint.put(
            &format!("{prefix}.attach.translation"),
            &self.attach.translation,
        );
        self.attach
            .rotation_adam
            .save(checkpoint, &format!("{prefix}.attach.rotation"));
        self.attach
            .translation_adam
            .save(checkpoint, &format!("{prefix}.attach.translation"));
    }

    fn load(
        &mut self,
        checkpoint: &Checkpoint,
        prefix: &str,
        device: &Device,
    ) -> Result<(), CheckpointError> {
        self.set.load(checkpoint, prefix, device)?;
        let shape = [Some(1), Some(3)];
        self.attach.rotation =
            checkpoint.tensor(&format!("{prefix}.attach.rotation"), shape, device)?;
        self.attach.translation =
            checkpoint.tensor(&format!("{prefix}.attach.translation"), shape, device)?;
        self.attach.rotation_adam = AdamState::load(
            checkpoint,
            &format!("{prefix}.attach.rotation"),
            &self.attach.rotation,
        )?;
        self.attach.translation_adam = AdamState::load(
            checkpoint,
            &format!("{prefix}.attach.translation"),
            &self.attach.translation,
        )?;
        self.attach.leaves = None;
        self.in_step = false;
        Ok(())
    }
}
