//! The skinned-Gaussian node: canonical Gaussians on a body (its own [`GaussianNode`] with
//! optimiser and density control), carried to each frame by linear blend skinning with the
//! frame's refined pose ([`PoseTable`]), an optional learned correction of the skinning
//! weights, and an optional method-owned non-rigid residual ([`NonRigidField`]).

use super::SkinnedConfig;
use super::canonical::{self, Placement, joint_regressor, skinning_weights, vertex_anchors};
use super::non_rigid::{NonRigidField, ResidualInput, ResidualSpace};
use super::pose_table::{FramePose, PoseTable, Refinement, adam};
use super::skinning::{JointTransforms, skin_splats};
use crate::adam::AdamState;
use crate::checkpoint::{Checkpoint, CheckpointError};
use crate::densify::{DensifyConfig, DensifyReport};
use crate::error::TrainError;
use crate::gaussians::GaussianSet;
use crate::host_f32;
use crate::optimizer::{GaussianOptimizer, LearningRates};
use crate::scene::{FrameContext, FrameQuery, GaussianNode, NodeOutput, SceneNode, StepEnd};
use burn::tensor::activation::softmax;
use burn::tensor::{Device, Int, Tensor, TensorData};
use splatzoo_datasets::pose_sequence::PoseSequence;
use splatzoo_models::anchor::MeshAnchors;
use splatzoo_models::body::BodyModel;
use splatzoo_models::body::lbs::{BodyTensors, PoseInput, pose};
use splatzoo_rasterizer::Splats;

/// The learned correction of the skinning weights: logits added to `log w`, re-normalised by a
/// softmax over joints (zero logits reproduce the mesh's weights).
struct SkinCorrection {
    logits: Tensor<2>,
    adam: AdamState<2>,
    leaf: Option<Tensor<2>>,
}

/// The avatar at one frame.
pub struct PosedAvatar {
    pub splats: Splats,
    /// The frame's body parameters (refined or interpolated).
    pub pose: FramePose,
    /// Each joint's world frame (rotation and position).
    pub joints: JointTransforms,
}

pub struct SkinnedGaussianNode {
    canonical: GaussianNode,
    model: BodyModel,
    body: BodyTensors,
    /// `[1, S]` the avatar's shape (the prior's mean shape at the start, refined with
    /// `refine_shape`), its step leaf and Adam state.
    betas: Tensor<2>,
    betas_leaf: Option<Tensor<2>>,
    betas_adam: AdamState<2>,
    /// `[1, 3 J]` the canonical pose.
    canonical_pose: Tensor<2>,
    /// Rest → canonical-pose transforms of the joints at the initial shape.
    canonical_joints: JointTransforms,
    anchors: MeshAnchors,
    /// `[G, J]` skinning weights from the anchors.
    weights: Tensor<2>,
    /// `[J, G]` the body's joint regressor carried onto the Gaussians.
    regressor: Tensor<2>,
    correction: Option<SkinCorrection>,
    pub poses: PoseTable,
    non_rigid: Option<Box<dyn NonRigidField>>,
    config: SkinnedConfig,
    in_step: bool,
}

fn lift_body(body: &BodyTensors) -> BodyTensors {
    BodyTensors {
        template: body.template.clone().autodiff(),
        shape_dirs: body.shape_dirs.clone().autodiff(),
        expression_dirs: body.expression_dirs.clone().map(|t| t.autodiff()),
        pose_dirs: body.pose_dirs.clone().map(|t| t.autodiff()),
        joint_regressor: body.joint_regressor.clone().autodiff(),
        skin_weights: body.skin_weights.clone().autodiff(),
        parents: body.parents.clone(),
    }
}

/// Rest → canonical-pose transforms of the joints of `body` at shape `betas` `[1, S]`.
fn canonical_transforms(
    body: &BodyTensors,
    betas: Tensor<2>,
    canonical_pose: Tensor<2>,
) -> JointTransforms {
    let j = body.joint_count();
    let device = betas.device();
    let rest = pose(
        body,
        &PoseInput::from_axis_angle(betas, canonical_pose, Tensor::zeros([1, 3], &device)),
    );
    JointTransforms {
        rotations: rest.joint_rotations.reshape([j, 3, 3]),
        translations: rest.skinning_translations.reshape([j, 3]),
    }
}

/// The mean shape of a track, cut or zero-padded to `count` coefficients.
fn mean_betas(track: &PoseSequence, count: usize) -> Vec<f32> {
    let frames = track.frames().max(1);
    (0..count)
        .map(|k| {
            if k >= track.shape_count {
                return 0.0;
            }
            let sum: f64 = (0..track.frames()).map(|t| track.frame_betas(t)[k]).sum();
            (sum / frames as f64) as f32
        })
        .collect()
}

impl SkinnedGaussianNode {
    /// An avatar of `model` following the prior track `prior` (one row per frame, the model's
    /// joint count), refining the frames where `trained` is true. `extent` scales the position
    /// learning rate (metres); `seed` seeds surface sampling and density control.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        name: &str,
        model: &BodyModel,
        prior: &PoseSequence,
        trained: Vec<bool>,
        config: &SkinnedConfig,
        rates: LearningRates,
        densify: &DensifyConfig,
        extent: f64,
        seed: u64,
        device: &Device,
    ) -> Result<Self, TrainError> {
        config.validate()?;
        let j = model.joint_count();
        if prior.joints != j {
            return Err(TrainError::Config(format!(
                "node `{name}`: the pose track has {} joints per frame but the body model has {j}",
                prior.joints
            )));
        }
        if trained.len() != prior.frames() {
            return Err(TrainError::Config(format!(
                "node `{name}`: {} frames flagged for training, the pose track has {}",
                trained.len(),
                prior.frames()
            )));
        }
        let body = BodyTensors::new(model, device);
        let s = model.shape_count();
        let betas = Tensor::<2>::from_data(TensorData::new(mean_betas(prior, s), [1, s]), device);
        let canonical_pose = Tensor::<2>::from_data(
            TensorData::new(
                config
                    .canonical_pose
                    .axis_angles(j)
                    .into_iter()
                    .map(|v| v as f32)
                    .collect::<Vec<_>>(),
                [1, 3 * j],
            ),
            device,
        );
        let rest = pose(
            &body,
            &PoseInput::from_axis_angle(
                betas.clone(),
                canonical_pose.clone(),
                Tensor::zeros([1, 3], device),
            ),
        );
        let vertices = host_f32(&rest.vertices);
        let anchors = match config.placement {
            Placement::Vertices => vertex_anchors(model),
            Placement::PerFace => MeshAnchors::per_face(model.face_count(), config.per_face),
            Placement::Surface => {
                MeshAnchors::sample_surface(&vertices, &model.faces, config.surface_samples, seed)
            }
        };
        let mut set = canonical::canonical_set(&vertices, &model.faces, &anchors, device);
        let o = config.initial_opacity;
        set.opacity_logits = Tensor::full([set.len()], (o / (1.0 - o)).ln(), device);
        let canonical_joints = JointTransforms {
            rotations: rest.joint_rotations.reshape([j, 3, 3]),
            translations: rest.skinning_translations.reshape([j, 3]),
        };
        let refine = Refinement {
            rotations: config.refine_rotations,
            translation: config.refine_translation,
            sequence_offset: config.refine_sequence_offset,
        };
        let g = anchors.len();
        let mut node = Self {
            canonical: GaussianNode::new(name, set, rates, densify, extent, seed ^ 0x5C1A_0001),
            body,
            betas_adam: AdamState::new(&betas),
            betas_leaf: None,
            betas,
            canonical_pose,
            canonical_joints,
            weights: Tensor::zeros([g, j], device),
            regressor: Tensor::zeros([j, g], device),
            anchors,
            correction: None,
            poses: PoseTable::new(prior, trained, refine, device),
            non_rigid: None,
            config: config.clone(),
            model: model.clone(),
            in_step: false,
        };
        node.refresh_per_row(device);
        if config.learn_skinning {
            let logits = Tensor::<2>::zeros([g, j], device);
            node.correction = Some(SkinCorrection {
                adam: AdamState::new(&logits),
                logits,
                leaf: None,
            });
        }
        Ok(node)
    }

    /// Recomputes the skinning weights and the joint regressor from the anchors.
    fn refresh_per_row(&mut self, device: &Device) {
        let (g, j) = (self.anchors.len(), self.model.joint_count());
        self.weights = canonical::matrix(
            skinning_weights(&self.model, &self.anchors, self.config.skinning),
            g,
            j,
            device,
        );
        self.regressor =
            canonical::matrix(joint_regressor(&self.model, &self.anchors), j, g, device);
    }

    /// The canonical Gaussians (plain tensors).
    pub fn canonical_set(&self) -> &GaussianSet {
        &self.canonical.set
    }

    /// Replaces the canonical Gaussians by `set` row for row (a saved avatar's, read from its
    /// `.ply`): the anchors, skinning weights and joint regressor stay, the optimiser's moments
    /// start afresh. `what` names the source in the error when the row counts differ.
    pub fn replace_canonical(&mut self, set: GaussianSet, what: &str) -> Result<(), TrainError> {
        let rows = self.canonical.set.len();
        if set.len() != rows {
            return Err(TrainError::Config(format!(
                "{what}: {} Gaussians, but the avatar `{}` has {rows} (one per anchor)",
                set.len(),
                self.canonical.name()
            )));
        }
        let optimizer = &self.canonical.optimizer;
        self.canonical.optimizer = GaussianOptimizer::new(&set, optimizer.rates, optimizer.extent);
        self.canonical.set = set;
        Ok(())
    }

    /// `[1, S]` the avatar's shape coefficients.
    pub fn betas(&self) -> &Tensor<2> {
        &self.betas
    }

    /// This step's autodiff leaves of the canonical Gaussians (inside a step).
    pub fn canonical_leaves(&self) -> Option<&GaussianSet> {
        self.canonical.leaves()
    }

    /// `[J, 3]` the body's joints at `frame` under the refined (or interpolated) pose.
    pub fn joint_positions(&self, frame: usize) -> Tensor<2> {
        let j = self.model.joint_count();
        let frame_pose = self.poses.frame(frame, false);
        // Plain values, outside any step's graph.
        let posed = pose(
            &self.body,
            &PoseInput {
                betas: self.betas.clone(),
                joint_rotations: frame_pose.rotations,
                translation: frame_pose.translation,
                expression: None,
            },
        );
        posed.joints.reshape([j, 3])
    }

    pub fn anchors(&self) -> &MeshAnchors {
        &self.anchors
    }

    pub fn model(&self) -> &BodyModel {
        &self.model
    }

    /// Sets (or clears) the method's non-rigid field for the coming renders.
    pub fn set_non_rigid(&mut self, field: Option<Box<dyn NonRigidField>>) {
        self.non_rigid = field;
    }

    fn lift<const D: usize>(&self, t: Tensor<D>) -> Tensor<D> {
        if self.in_step { t.autodiff() } else { t }
    }

    /// `[G, J]` the skinning weights in use (with the learned correction, if any).
    pub fn skinning_weights(&self) -> Tensor<2> {
        let base = self.lift(self.weights.clone());
        match &self.correction {
            None => base,
            Some(c) => {
                let logits = c
                    .leaf
                    .clone()
                    .unwrap_or_else(|| self.lift(c.logits.clone()));
                softmax((base + 1e-8).log() + logits, 1)
            }
        }
    }

    /// Joints `[J, 3]` regressed from Gaussian centres `[G, 3]` (posed or canonical).
    pub fn regress_joints(&self, means: Tensor<2>) -> Tensor<2> {
        self.lift(self.regressor.clone()).matmul(means)
    }

    /// The canonical splats carried to `frame`: the step's leaves inside a step.
    pub fn posed(&self, canonical: Splats, frame: usize) -> PosedAvatar {
        let j = self.model.joint_count();
        let frame_pose = self.poses.frame(frame, self.in_step);
        let body = if self.in_step {
            lift_body(&self.body)
        } else {
            self.body.clone()
        };
        let betas = self
            .betas_leaf
            .clone()
            .unwrap_or_else(|| self.lift(self.betas.clone()));
        let posed_body = pose(
            &body,
            &PoseInput {
                betas: betas.clone(),
                joint_rotations: frame_pose.rotations.clone(),
                translation: frame_pose.translation.clone(),
                expression: None,
            },
        );
        let target = JointTransforms {
            rotations: posed_body.joint_rotations.reshape([j, 3, 3]),
            translations: posed_body.skinning_translations.reshape([j, 3]),
        };
        let canonical_joints = if self.config.refine_shape {
            // The skeleton follows the shape: canonical transforms at the current shape.
            canonical_transforms(&body, betas, self.lift(self.canonical_pose.clone()))
        } else {
            JointTransforms {
                rotations: self.lift(self.canonical_joints.rotations.clone()),
                translations: self.lift(self.canonical_joints.translations.clone()),
            }
        };
        let transforms = target.after_inverse_of(&canonical_joints);
        let residual =
            |splats: Splats, canonical: &Splats, space: ResidualSpace| match &self.non_rigid {
                Some(field) if field.space() == space => field
                    .residual(&ResidualInput {
                        splats: &splats,
                        canonical,
                        frame,
                        pose: &frame_pose.rotations,
                    })
                    .apply(splats),
                _ => splats,
            };
        let canonical = residual(canonical.clone(), &canonical, ResidualSpace::Canonical);
        let splats = skin_splats(canonical.clone(), self.skinning_weights(), &transforms);
        let splats = residual(splats, &canonical, ResidualSpace::Posed);
        let joints = JointTransforms {
            rotations: target.rotations,
            translations: posed_body.joints.reshape([j, 3]),
        };
        PosedAvatar {
            splats,
            pose: frame_pose,
            joints,
        }
    }

    /// Restores the avatar itself (canonical Gaussians with their optimiser state, anchors,
    /// shape, skinning correction) but not the pose table, so a trained avatar can be driven by
    /// another motion (a node built with that motion as its prior).
    pub fn load_avatar(
        &mut self,
        checkpoint: &Checkpoint,
        prefix: &str,
        device: &Device,
    ) -> Result<(), CheckpointError> {
        self.canonical.load(checkpoint, prefix, device)?;
        let g = self.canonical.gaussians();
        let face_count = self.model.face_count();
        let faces: Tensor<1> =
            checkpoint.tensor(&format!("{prefix}.anchors.face"), [Some(g)], device)?;
        let bary: Tensor<2> = checkpoint.tensor(
            &format!("{prefix}.anchors.barycentric"),
            [Some(g), Some(3)],
            device,
        )?;
        let faces = host_f32(&faces);
        if let Some(bad) = faces
            .iter()
            .find(|&&f| f < 0.0 || f.fract() != 0.0 || f as usize >= face_count)
        {
            return Err(CheckpointError::Entry {
                file: checkpoint.origin.clone(),
                name: format!("{prefix}.anchors.face"),
                problem: format!("face {bad} is not one of the body model's {face_count} faces"),
            });
        }
        let bary = host_f32(&bary);
        self.anchors = MeshAnchors {
            face_from_gaussian: faces.iter().map(|&f| f as u32).collect(),
            barycentric: bary.chunks(3).map(|b| [b[0], b[1], b[2]]).collect(),
        };
        self.refresh_per_row(device);
        let s = self.betas.dims()[1];
        self.betas = checkpoint.tensor(&format!("{prefix}.betas"), [Some(1), Some(s)], device)?;
        self.betas_adam = AdamState::load(checkpoint, &format!("{prefix}.betas"), &self.betas)?;
        self.betas_leaf = None;
        // The skeleton of the loaded shape (a node built on another prior had another).
        self.canonical_joints =
            canonical_transforms(&self.body, self.betas.clone(), self.canonical_pose.clone());
        if let Some(c) = &mut self.correction {
            let j = self.model.joint_count();
            c.logits = checkpoint.tensor(
                &format!("{prefix}.skinning.logits"),
                [Some(g), Some(j)],
                device,
            )?;
            c.adam = AdamState::load(checkpoint, &format!("{prefix}.skinning.logits"), &c.logits)?;
            c.leaf = None;
        }
        self.in_step = false;
        Ok(())
    }

    /// Follows a density edit: every per-row array takes the rows of `old_from_new`.
    fn follow_lineage(&mut self, old_from_new: &[usize]) {
        let device = self.weights.device();
        self.anchors = MeshAnchors {
            face_from_gaussian: old_from_new
                .iter()
                .map(|&o| self.anchors.face_from_gaussian[o])
                .collect(),
            barycentric: old_from_new
                .iter()
                .map(|&o| self.anchors.barycentric[o])
                .collect(),
        };
        self.refresh_per_row(&device);
        if let Some(c) = &mut self.correction {
            let index: Vec<i64> = old_from_new.iter().map(|&o| o as i64).collect();
            let index =
                Tensor::<1, Int>::from_data(TensorData::new(index, [old_from_new.len()]), &device);
            c.logits = c.logits.clone().select(0, index.clone());
            c.adam.select(index);
            // Copies start with fresh moments, as the Gaussian optimiser's new rows do: the
            // first row taken from an old row keeps its moments, later ones restart.
            let mut seen = vec![false; old_from_new.iter().max().map_or(0, |&m| m + 1)];
            let keep: Vec<f32> = old_from_new
                .iter()
                .map(|&o| f32::from(!std::mem::replace(&mut seen[o], true)))
                .collect();
            c.adam.scale_rows(Tensor::from_data(
                TensorData::new(keep, [old_from_new.len()]),
                &device,
            ));
        }
    }
}

impl SceneNode for SkinnedGaussianNode {
    fn name(&self) -> &str {
        self.canonical.name()
    }

    fn gaussians(&self) -> usize {
        self.canonical.gaussians()
    }

    fn begin_step(&mut self) {
        self.canonical.begin_step();
        self.poses.begin_step();
        if let Some(c) = &mut self.correction {
            c.leaf = Some(c.logits.clone().autodiff().require_grad());
        }
        if self.config.refine_shape {
            self.betas_leaf = Some(self.betas.clone().autodiff().require_grad());
        }
        self.in_step = true;
    }

    fn render(&self, query: &FrameQuery, context: &FrameContext) -> NodeOutput {
        let canonical = self.canonical.render(query, context).splats;
        let posed = self.posed(canonical, query.frame);
        NodeOutput {
            splats: posed.splats,
            joints: Some(posed.joints.homogeneous()),
            bounds: None,
        }
    }

    fn regulariser(&self) -> Option<Tensor<1>> {
        let smooth = self
            .poses
            .smoothness()
            .map(|s| s * self.config.smoothness_weight);
        let anchored = (self.config.pose_prior_weight > 0.0)
            .then(|| self.poses.prior_distance())
            .flatten()
            .map(|d| d * self.config.pose_prior_weight);
        let smooth = match (smooth, anchored) {
            (Some(a), Some(b)) => Some(a + b),
            (a, b) => a.or(b),
        };
        match (self.canonical.regulariser(), smooth) {
            (Some(a), Some(b)) => Some(a + b),
            (a, b) => a.or(b),
        }
    }

    fn end_step(&mut self, end: &StepEnd) -> Option<DensifyReport> {
        let report = self.canonical.end_step(end);
        self.poses.end_step(
            end.grads,
            self.config.rotation_rate,
            self.config.translation_rate,
        );
        if let Some(c) = &mut self.correction
            && let Some(leaf) = c.leaf.take()
            && let Some(g) = leaf.grad(end.grads)
        {
            c.logits = c
                .adam
                .step(c.logits.clone(), g, self.config.skinning_rate, &adam());
        }
        if let Some(leaf) = self.betas_leaf.take()
            && let Some(g) = leaf.grad(end.grads)
        {
            self.betas =
                self.betas_adam
                    .step(self.betas.clone(), g, self.config.shape_rate, &adam());
        }
        if let Some(lineage) = self.canonical.take_lineage() {
            self.follow_lineage(&lineage);
        }
        self.in_step = false;
        report
    }

    fn save(&self, checkpoint: &mut Checkpoint, prefix: &str) {
        self.canonical.save(checkpoint, prefix);
        let device = self.weights.device();
        let g = self.anchors.len();
        let faces: Vec<f32> = self
            .anchors
            .face_from_gaussian
            .iter()
            .map(|&f| f as f32)
            .collect();
        let bary: Vec<f32> = self.anchors.barycentric.iter().flatten().copied().collect();
        checkpoint.put(
            &format!("{prefix}.anchors.face"),
            &Tensor::<1>::from_data(TensorData::new(faces, [g]), &device),
        );
        checkpoint.put(
            &format!("{prefix}.anchors.barycentric"),
            &Tensor::<2>::from_data(TensorData::new(bary, [g, 3]), &device),
        );
        self.poses.save(checkpoint, &format!("{prefix}.poses"));
        checkpoint.put(&format!("{prefix}.betas"), &self.betas);
        self.betas_adam.save(checkpoint, &format!("{prefix}.betas"));
        if let Some(c) = &self.correction {
            checkpoint.put(&format!("{prefix}.skinning.logits"), &c.logits);
            c.adam
                .save(checkpoint, &format!("{prefix}.skinning.logits"));
        }
    }

    fn load(
        &mut self,
        checkpoint: &Checkpoint,
        prefix: &str,
        device: &Device,
    ) -> Result<(), CheckpointError> {
        self.load_avatar(checkpoint, prefix, device)?;
        self.poses.load(checkpoint, &format!("{prefix}.poses"))
    }
}
