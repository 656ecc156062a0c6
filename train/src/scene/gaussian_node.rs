//! Gaussians that do not move (a static background, the scene prior of later methods), with
//! their own 3DGS optimiser (per-group Adam, [`GaussianOptimizer`]), density-control strategy
//! ([`DensityStrategy`]) and random state. Checkpoint names under the node's prefix:
//! `{prefix}.splats.*` (gsplat's names), `{prefix}.optimizer.*`, `{prefix}.densify.*` and the
//! metadata `{prefix}.rng`.

use super::node::{FrameContext, FrameQuery, NodeOutput, SceneNode, StepEnd};
use crate::checkpoint::{Checkpoint, CheckpointError};
use crate::densify::strategy::{DensityStrategy, RowEdit, strategy};
use crate::densify::{DensifyConfig, DensifyReport};
use crate::gaussians::GaussianSet;
use crate::optimizer::{GaussianOptimizer, LearningRates};
use burn::tensor::{Device, Tensor};
use splatzoo_datasets::synth::rng::Rng;

pub struct GaussianNode {
    name: String,
    pub set: GaussianSet,
    /// This step's autodiff leaves (between `begin_step` and `end_step`).
    leaves: Option<GaussianSet>,
    pub optimizer: GaussianOptimizer,
    density: Box<dyn DensityStrategy>,
    rng: Rng,
    /// Where each row came from in the last step's density edit (`None` when there was none;
    /// empty when it removed every row).
    old_from_new: Option<Vec<usize>>,
}

impl GaussianNode {
    /// A node over `set` trained with `rates` (positions scaled by the scene `extent`) and the
    /// density control of `densify`; `seed` seeds its randomness (splits, noise, relocation).
    pub fn new(
        name: &str,
        set: GaussianSet,
        rates: LearningRates,
        densify: &DensifyConfig,
        extent: f64,
        seed: u64,
    ) -> Self {
        let device = set.means.device();
        Self {
            name: name.to_owned(),
            optimizer: GaussianOptimizer::new(&set, rates, extent),
            density: strategy(densify, set.len(), extent, &device),
            leaves: None,
            set,
            rng: Rng(seed),
            old_from_new: None,
        }
    }

    /// The lineage of the last [`SceneNode::end_step`]'s density edit: for every row now, the
    /// row it was copied from; `None` when no row moved. Nodes that keep per-row data beside
    /// the set (a skinned node's weights and anchors) follow it.
    pub fn take_lineage(&mut self) -> Option<Vec<usize>> {
        self.old_from_new.take()
    }

    /// This step's autodiff leaves (between `begin_step` and `end_step`).
    pub fn leaves(&self) -> Option<&GaussianSet> {
        self.leaves.as_ref()
    }

    pub fn density(&self) -> &dyn DensityStrategy {
        self.density.as_ref()
    }

    /// The node with another density strategy in place of the one its config named (a strategy
    /// that needs what only the node's owner has, such as KL density control's mesh for
    /// [`crate::densify::kl::SurfacePrune`]); before the first step.
    pub fn with_density(mut self, density: Box<dyn DensityStrategy>) -> Self {
        self.density = density;
        self
    }
}

impl SceneNode for GaussianNode {
    fn name(&self) -> &str {
        &self.name
    }

    fn gaussians(&self) -> usize {
        self.set.len()
    }

    fn begin_step(&mut self) {
        self.leaves = Some(self.set.leaves());
    }

    fn render(&self, _query: &FrameQuery, _context: &FrameContext) -> NodeOutput {
        NodeOutput::splats(self.leaves.as_ref().unwrap_or(&self.set).splats())
    }

    fn regulariser(&self) -> Option<Tensor<1>> {
        self.density.regulariser(self.leaves.as_ref()?)
    }

    fn end_step(&mut self, end: &StepEnd) -> Option<DensifyReport> {
        let leaves = self
            .leaves
            .take()
            .expect("end_step follows begin_step on the same node");
        for (render, rows) in &end.renders {
            self.density.observe(render, end.grads, rows.clone());
        }
        self.optimizer
            .step(&mut self.set, &leaves, end.grads, end.progress);
        let rows = self.set.len();
        let mut old_from_new = Vec::new();
        let report = self.density.after_step(RowEdit {
            set: &mut self.set,
            optimizer: &mut self.optimizer,
            rng: &mut self.rng,
            step: end.step + 1,
            progress: end.progress,
            old_from_new: &mut old_from_new,
        });
        // A decision that moved no row leaves the lineage untouched (and so empty).
        let moved = !old_from_new.is_empty() || self.set.len() != rows;
        self.old_from_new = moved.then_some(old_from_new);
        report
    }

    fn save(&self, checkpoint: &mut Checkpoint, prefix: &str) {
        self.set.save(checkpoint, &format!("{prefix}.splats"));
        self.optimizer
            .save(checkpoint, &format!("{prefix}.optimizer"));
        self.density.save(checkpoint, &format!("{prefix}.densify"));
        checkpoint.put_meta(&format!("{prefix}.rng"), self.rng.0);
    }

    fn load(
        &mut self,
        checkpoint: &Checkpoint,
        prefix: &str,
        device: &Device,
    ) -> Result<(), CheckpointError> {
        self.set = GaussianSet::load(checkpoint, &format!("{prefix}.splats"), device)?;
        self.optimizer = GaussianOptimizer::load(
            checkpoint,
            &format!("{prefix}.optimizer"),
            &self.set,
            self.optimizer.rates,
            self.optimizer.extent,
        )?;
        self.density.load(
            checkpoint,
            &format!("{prefix}.densify"),
            self.set.len(),
            device,
        )?;
        self.rng = Rng(checkpoint.meta_parsed(&format!("{prefix}.rng"))?);
        self.leaves = None;
        self.old_from_new = None;
        Ok(())
    }
}
