//! Network blocks shared by the methods, as Burn modules: ResNet-18/34/50 encoders in
//! torchvision's layout ([`resnet`]), a feature pyramid over them fused to one resolution
//! ([`fpn`]), NeRF's frequency encoding ([`encoding`]), instant-NGP's multi-resolution hash
//! encoding ([`hash_grid`]) and a hash-encoded MLP field ([`hash_mlp`]), the skip-connected
//! deformation MLP ([`mlp`]), Stable Diffusion's VAE encoder by diffusers' names ([`vae`]), and safetensors weight files: torchvision-named loading, checkpoints of any module
//! by parameter path ([`weights`]).

pub mod encoding;
pub mod fpn;
pub mod hash_grid;
pub mod hash_mlp;
pub mod mlp;
pub mod resnet;
pub mod vae;
pub mod weights;

use burn::module::{Module, ModuleMapper, Param};
use burn::tensor::Tensor;

/// `module` with every parameter initialised now, in the module's field order.
///
/// Burn draws a layer's initial weights lazily, at the parameter's first use, from the
/// process-wide generator; the draws then follow the order in which a run first touches its
/// networks, which differs between a run that checkpoints early and one that does not.
/// Initialising at construction makes a seeded run's weights depend only on the seed and the
/// construction order.
pub fn initialised<M: Module>(module: M) -> M {
    struct Touch;
    impl ModuleMapper for Touch {
        fn map_float<const D: usize>(&mut self, param: Param<Tensor<D>>) -> Param<Tensor<D>> {
            let _ = param.val();
            param
        }
    }
    module.map(&mut Touch)
}
