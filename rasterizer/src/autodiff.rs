//! The rasterizer's backward registered with Burn's autodiff: the forward runs on the inner
//! backend, the image is the tracked output, and the backward calls the inner backend's
//! `splat_backward` and hands each input its gradient.

use crate::backend::{SplatBackend, SplatForward, SplatInputGrads, SplatInputs, SplatSaved};
use crate::camera::RasterSettings;
use burn::backend::AutodiffBackend;
use burn::backend::Backend;
use burn::backend::autodiff::{
    Autodiff,
    checkpoint::{base::Checkpointer, strategy::CheckpointStrategy},
    grads::Gradients,
    ops::{Backward, Ops, OpsKind},
};
use burn::backend::tensor::FloatTensor;

#[derive(Debug)]
struct SplatBackward;

impl<B: SplatBackend> Backward<B, 7> for SplatBackward {
    type State = (SplatInputs<B>, SplatSaved<B>, RasterSettings);

    fn backward(self, ops: Ops<Self::State, 7>, grads: &mut Gradients, _: &mut Checkpointer) {
        let grad_image = grads.consume::<B>(&ops.node);
        let (inputs, saved, settings) = ops.state;
        let g = B::splat_backward(inputs, saved, grad_image, settings);
        let per_input = [
            g.means,
            g.quats,
            g.log_scales,
            g.opacity_logits,
            g.colors,
            g.background,
            g.screen_offsets,
        ];
        for (parent, grad) in ops.parents.into_iter().zip(per_input) {
            if let Some(node) = parent {
                grads.register::<B>(node.id, grad);
            }
        }
    }
}

/// Lifts an inner-backend tensor into autodiff as a constant (no gradient).
fn untracked<B: Backend, C: CheckpointStrategy>(
    tensor: FloatTensor<B>,
) -> FloatTensor<Autodiff<B, C>> {
    <Autodiff<B, C> as AutodiffBackend>::from_inner(tensor)
}

fn inner_inputs<B: Backend>(
    inputs: &SplatInputs<Autodiff<B, impl CheckpointStrategy>>,
) -> SplatInputs<B> {
    SplatInputs {
        means: inputs.means.primitive().clone(),
        quats: inputs.quats.primitive().clone(),
        log_scales: inputs.log_scales.primitive().clone(),
        opacity_logits: inputs.opacity_logits.primitive().clone(),
        colors: inputs.colors.primitive().clone(),
        background: inputs.background.primitive().clone(),
        screen_offsets: inputs.screen_offsets.primitive().clone(),
    }
}

impl<B: SplatBackend, C: CheckpointStrategy> SplatBackend for Autodiff<B, C> {
    fn splat_forward(inputs: SplatInputs<Self>, settings: RasterSettings) -> SplatForward<Self> {
        let inner = inner_inputs(&inputs);
        let nodes = [
            inputs.means.node(),
            inputs.quats.node(),
            inputs.log_scales.node(),
            inputs.opacity_logits.node(),
            inputs.colors.node(),
            inputs.background.node(),
            inputs.screen_offsets.node(),
        ];
        let out = B::splat_forward(inner.clone(), settings);
        let saved = out.saved.clone();
        let image = match SplatBackward.prepare::<C>(nodes).compute_bound().stateful() {
            OpsKind::Tracked(prep) => prep.finish((inner, out.saved.clone(), settings), out.image),
            OpsKind::UnTracked(prep) => prep.finish(out.image),
        };
        SplatForward {
            image,
            saved: SplatSaved {
                projected: untracked::<B, C>(saved.projected),
                final_transmittance: untracked::<B, C>(saved.final_transmittance),
                contributors: untracked::<B, C>(saved.contributors),
            },
        }
    }

    fn splat_backward(
        inputs: SplatInputs<Self>,
        saved: SplatSaved<Self>,
        grad_image: FloatTensor<Self>,
        settings: RasterSettings,
    ) -> SplatInputGrads<Self> {
        // Gradients of gradients are not supported: this runs the inner backward untracked.
        let g = B::splat_backward(
            inner_inputs(&inputs),
            SplatSaved {
                projected: saved.projected.into_primitive(),
                final_transmittance: saved.final_transmittance.into_primitive(),
                contributors: saved.contributors.into_primitive(),
            },
            grad_image.into_primitive(),
            settings,
        );
        SplatInputGrads {
            means: untracked::<B, C>(g.means),
            quats: untracked::<B, C>(g.quats),
            log_scales: untracked::<B, C>(g.log_scales),
            opacity_logits: untracked::<B, C>(g.opacity_logits),
            colors: untracked::<B, C>(g.colors),
            background: untracked::<B, C>(g.background),
            screen_offsets: untracked::<B, C>(g.screen_offsets),
        }
    }
}
