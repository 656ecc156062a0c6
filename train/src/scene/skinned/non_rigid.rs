//! The hook for a method's non-rigid term: a per-Gaussian residual (offsets of means, rotations,
//! log-scales, opacity) from a network or table the method owns and trains, applied to the
//! canonical Gaussians before skinning or to the posed ones after it. The node only applies it;
//! the method updates the field's parameters from the step's gradients.

use burn::tensor::Tensor;
use splatzoo_rasterizer::Splats;

/// Where a residual is added.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ResidualSpace {
    /// To the canonical Gaussians, before skinning (3DGS-Avatar's non-rigid MLP).
    Canonical,
    /// To the posed Gaussians, after skinning (APF-GS's residual field).
    Posed,
}

/// What a field sees for one frame.
pub struct ResidualInput<'a> {
    /// The Gaussians in the residual's space.
    pub splats: &'a Splats,
    /// The canonical Gaussians they came from (the same rows; a posed-space field conditions
    /// on canonical positions, APF-GS's `γ(μ̄)`).
    pub canonical: &'a Splats,
    pub frame: usize,
    /// `[1, J, 3, 3]` the frame's refined local joint rotations (a pose condition).
    pub pose: &'a Tensor<4>,
}

/// Per-Gaussian additive offsets; `None` leaves a parameter as it is.
#[derive(Default)]
pub struct Residual {
    /// `[G, 3]` metres.
    pub means: Option<Tensor<2>>,
    /// `[G, 4]` added to the (unnormalised) quaternions.
    pub quats: Option<Tensor<2>>,
    /// `[G, 3]`.
    pub log_scales: Option<Tensor<2>>,
    /// `[G]` added to the opacity logits.
    pub opacity_logits: Option<Tensor<1>>,
}

impl Residual {
    /// `splats` with the offsets added (shapes asserted).
    pub fn apply(self, splats: Splats) -> Splats {
        let n = splats.len();
        let add2 = |base: Tensor<2>, offset: Option<Tensor<2>>, name: &str| match offset {
            Some(o) => {
                assert_eq!(o.dims(), base.dims(), "residual {name} must match [{n}, …]");
                base + o
            }
            None => base,
        };
        let opacity_logits = match self.opacity_logits {
            Some(o) => {
                assert_eq!(o.dims(), [n], "residual opacity must be [{n}]");
                splats.opacity_logits + o
            }
            None => splats.opacity_logits,
        };
        Splats {
            means: add2(splats.means, self.means, "means"),
            quats: add2(splats.quats, self.quats, "quats"),
            log_scales: add2(splats.log_scales, self.log_scales, "log_scales"),
            opacity_logits,
            colors: splats.colors,
        }
    }
}

/// A method's non-rigid field. Set on the node for each step with the field's current
/// (autodiff) parameters; the node calls it once per rendered frame.
pub trait NonRigidField {
    fn space(&self) -> ResidualSpace;
    fn residual(&self, input: &ResidualInput) -> Residual;
}
