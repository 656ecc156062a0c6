//! Network blocks shared by the methods, as Burn modules: ResNet-18/34/50 encoders in
//! torchvision's layout ([`resnet`]), a feature pyramid over them fused to one resolution
//! ([`fpn`]), and safetensors weight files: torchvision-named loading, checkpoints of any module
//! by parameter path ([`weights`]).

pub mod fpn;
pub mod resnet;
pub mod weights;
