//! The scene-node interface (drivestudio's node lifecycle, typed). A node is one part of a scene
//! (a static background, a rigid object, a skinned human, a deformable accessory) that owns its
//! learnable rows and how they are trained:
//!
//! 1. [`SceneNode::begin_step`]: take fresh autodiff leaves of its parameters;
//! 2. [`SceneNode::render`]: its Gaussians in world space for a frame query, given what the
//!    nodes before it produced this frame ([`FrameContext`]: a child reads its parent's posed
//!    joints, a node can see another's bounding box);
//! 3. [`SceneNode::regulariser`]: its loss terms on this step's leaves;
//! 4. [`SceneNode::end_step`]: its own optimiser and density-control strategy on its rows,
//!    from the step's gradients and its rows in each render;
//! 5. [`SceneNode::save`] / [`SceneNode::load`]: its whole state under its own checkpoint
//!    prefix (its name).
//!
//! Scene-level learnables (camera refinement, a global scale, a light volume, a guidance or
//! generator network) belong to the method, not to a node.

use crate::checkpoint::{Checkpoint, CheckpointError};
use crate::densify::DensifyReport;
use burn::tensor::{Device, Gradients, Tensor};
use splatzoo_rasterizer::{Camera, Render, Splats};
use std::ops::Range;

/// What a node is asked for: the view and the moment.
#[derive(Debug, Clone, Copy)]
pub struct FrameQuery<'a> {
    pub camera: &'a Camera,
    /// Frame index in the sequence (0 for static scenes).
    pub frame: usize,
    /// Seconds since the start of the sequence.
    pub time: f64,
}

/// Axis-aligned bounds in world space, metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bounds {
    pub min: [f32; 3],
    pub max: [f32; 3],
}

/// What one node produced for a frame.
pub struct NodeOutput {
    /// Its Gaussians in world space (autodiff tensors while training).
    pub splats: Splats,
    /// `[J, 4, 4]` world transforms of its joints, for nodes with a skeleton (children attach
    /// to them).
    pub joints: Option<Tensor<3>>,
    /// Where it is, for nodes that others query (shadows, occlusion tests).
    pub bounds: Option<Bounds>,
}

impl NodeOutput {
    /// Gaussians only.
    pub fn splats(splats: Splats) -> Self {
        Self {
            splats,
            joints: None,
            bounds: None,
        }
    }
}

/// The outputs of the nodes rendered before the current one, this frame.
pub struct FrameContext<'a> {
    pub outputs: &'a [(String, NodeOutput)],
}

impl FrameContext<'_> {
    /// The output of node `name`, if it came earlier in the graph.
    pub fn node(&self, name: &str) -> Option<&NodeOutput> {
        self.outputs.iter().find(|(n, _)| n == name).map(|(_, o)| o)
    }
}

/// The end of a training step as one node sees it.
pub struct StepEnd<'a> {
    pub grads: &'a Gradients,
    /// Every render of this step, with this node's rows in it.
    pub renders: Vec<(&'a Render, Range<usize>)>,
    /// Optimiser steps taken before this one.
    pub step: usize,
    /// Training progress in [0, 1] before this step.
    pub progress: f64,
}

pub trait SceneNode {
    fn name(&self) -> &str;
    /// Number of Gaussians the node renders now.
    fn gaussians(&self) -> usize;
    /// Start a training step: fresh autodiff leaves of the node's parameters. Nodes without
    /// parameters of their own do nothing.
    fn begin_step(&mut self) {}
    /// The node's Gaussians for `query`: the step's leaves between [`Self::begin_step`] and
    /// [`Self::end_step`], plain tensors otherwise.
    fn render(&self, query: &FrameQuery, context: &FrameContext) -> NodeOutput;
    /// The node's loss terms on the step's leaves.
    fn regulariser(&self) -> Option<Tensor<1>> {
        None
    }
    /// Apply the node's optimiser and density control; returns what density control did.
    fn end_step(&mut self, _end: &StepEnd) -> Option<DensifyReport> {
        None
    }
    /// Its state, every name under `prefix.`.
    fn save(&self, _checkpoint: &mut Checkpoint, _prefix: &str) {}
    /// Restores what [`Self::save`] wrote.
    fn load(
        &mut self,
        _checkpoint: &Checkpoint,
        _prefix: &str,
        _device: &Device,
    ) -> Result<(), CheckpointError> {
        Ok(())
    }
}
