//! Scene graphs: a frame is rendered from a list of nodes ([`SceneNode`]: a static background,
//! later skinned humans, deformable accessories, rigid objects), each producing its posed
//! Gaussians for a camera and time. The nodes' Gaussians are concatenated and rendered in one
//! call of the rasterizer op, so they occlude each other correctly and share one backward pass.
//! A training step runs every node's lifecycle (begin, render, regularise, end) through the
//! graph; a scene holds only the nodes it needs (`train-3dgs` is the one-node case).

mod gaussian_node;
mod node;
pub mod skinned;

pub use gaussian_node::GaussianNode;
pub use node::{Bounds, FrameContext, FrameQuery, NodeOutput, SceneNode, StepEnd};
pub use skinned::SkinnedGaussianNode;

use crate::checkpoint::{Checkpoint, CheckpointError};
use crate::densify::DensifyReport;
use burn::tensor::{Device, Gradients, Tensor};
use splatzoo_rasterizer::{RasterError, RasterSettings, Render, Splats, rasterize};
use std::ops::Range;

/// A render of a whole graph, with each node's rows in the concatenated splat list (for
/// per-node statistics such as density control).
pub struct GraphRender {
    pub render: Render,
    /// `rows[k]`: node k's rows in `render.radii` and `render.screen_offsets`.
    pub rows: Vec<Range<usize>>,
}

#[derive(Default)]
pub struct SceneGraph {
    pub nodes: Vec<Box<dyn SceneNode>>,
}

impl SceneGraph {
    pub fn new() -> Self {
        Self::default()
    }

    pub fn with(mut self, node: impl SceneNode + 'static) -> Self {
        self.nodes.push(Box::new(node));
        self
    }

    /// Gaussians over every node.
    pub fn gaussians(&self) -> usize {
        self.nodes.iter().map(|n| n.gaussians()).sum()
    }

    /// Fresh autodiff leaves in every node.
    pub fn begin_step(&mut self) {
        for node in &mut self.nodes {
            node.begin_step();
        }
    }

    /// Every node's Gaussians for `query`, in graph order (each node sees the ones before it).
    pub fn outputs(&self, query: &FrameQuery) -> Vec<(String, NodeOutput)> {
        let mut outputs: Vec<(String, NodeOutput)> = Vec::with_capacity(self.nodes.len());
        for node in &self.nodes {
            let output = node.render(query, &FrameContext { outputs: &outputs });
            outputs.push((node.name().to_owned(), output));
        }
        outputs
    }

    /// Renders every node for `query` in one rasterizer call over `background`.
    pub fn render(
        &self,
        query: &FrameQuery,
        background: Tensor<1>,
        settings: &RasterSettings,
    ) -> Result<GraphRender, RasterError> {
        let parts: Vec<Splats> = self
            .outputs(query)
            .into_iter()
            .map(|(_, o)| o.splats)
            .collect();
        let mut rows = Vec::with_capacity(parts.len());
        let mut start = 0;
        for p in &parts {
            rows.push(start..start + p.len());
            start += p.len();
        }
        let splats = concatenate(parts);
        Ok(GraphRender {
            render: rasterize(&splats, background, settings)?,
            rows,
        })
    }

    /// The sum of the nodes' regularisers on this step's leaves (`None` when no node has one).
    pub fn regularisers(&self) -> Option<Tensor<1>> {
        self.nodes
            .iter()
            .filter_map(|n| n.regulariser())
            .reduce(|a, b| a + b)
    }

    /// Every node's optimiser and density control, from the step's gradients and renders;
    /// returns the density reports by node name.
    pub fn end_step(
        &mut self,
        grads: &Gradients,
        renders: &[GraphRender],
        step: usize,
        progress: f64,
    ) -> Vec<(String, DensifyReport)> {
        let mut reports = Vec::new();
        for (k, node) in self.nodes.iter_mut().enumerate() {
            let end = StepEnd {
                grads,
                renders: renders
                    .iter()
                    .map(|r| (&r.render, r.rows[k].clone()))
                    .collect(),
                step,
                progress,
            };
            if let Some(report) = node.end_step(&end) {
                reports.push((node.name().to_owned(), report));
            }
        }
        reports
    }

    /// Every node's state under its name.
    pub fn save(&self, checkpoint: &mut Checkpoint) {
        for node in &self.nodes {
            node.save(checkpoint, node.name());
        }
    }

    pub fn load(
        &mut self,
        checkpoint: &Checkpoint,
        device: &Device,
    ) -> Result<(), CheckpointError> {
        for node in &mut self.nodes {
            let prefix = node.name().to_owned();
            node.load(checkpoint, &prefix, device)?;
        }
        Ok(())
    }
}

/// Concatenates splat lists; colour tables with fewer coefficients (say, a DC-only human next
/// to a degree-3 background) are padded with zero coefficients, which leaves their colour
/// unchanged.
pub fn concatenate(mut parts: Vec<Splats>) -> Splats {
    assert!(!parts.is_empty(), "a scene graph needs at least one node");
    if parts.len() == 1 {
        return parts.pop().expect("one part");
    }
    let coefficients = parts
        .iter()
        .map(|p| p.colors.dims()[1])
        .max()
        .expect("non-empty");
    let channels = parts[0].colors.dims()[2];
    let colors = parts
        .iter()
        .map(|p| {
            let [n, k, c] = p.colors.dims();
            assert_eq!(c, channels, "every node renders the same colour channels");
            if k == coefficients {
                p.colors.clone()
            } else {
                let pad = Tensor::<3>::zeros([n, coefficients - k, c], &p.colors.device());
                Tensor::cat(vec![p.colors.clone(), pad], 1)
            }
        })
        .collect();
    Splats {
        means: Tensor::cat(parts.iter().map(|p| p.means.clone()).collect(), 0),
        quats: Tensor::cat(parts.iter().map(|p| p.quats.clone()).collect(), 0),
        log_scales: Tensor::cat(parts.iter().map(|p| p.log_scales.clone()).collect(), 0),
        opacity_logits: Tensor::cat(parts.iter().map(|p| p.opacity_logits.clone()).collect(), 0),
        colors: Tensor::cat(colors, 0),
    }
}
