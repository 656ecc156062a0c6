//! Network blocks shared by the methods, as Burn modules: ResNet-18/34/50 encoders in
//! torchvision's layout ([`resnet`]), a feature pyramid over them fused to one resolution
//! ([`fpn`]), NeRF's frequency encoding ([`encoding`]), instant-NGP's multi-resolution hash
//! encoding ([`hash_grid`]) and a hash-encoded MLP field ([`hash_mlp`]), the skip-connected
//! deformation MLP ([`mlp`]), and safetensors weight files: torchvision-named loading, checkpoints of any module
//! by parameter path ([`weights`]).

pub mod encoding;
pub mod fpn;
pub mod hash_grid;
pub mod hash_mlp;
pub mod mlp;
pub mod resnet;
pub mod weights;
