//! Networks shared by the methods, as Burn modules: ResNet-18/34/50 encoders in torchvision's
//! layout ([`resnet`]), a feature pyramid over them fused to one resolution ([`fpn`]), and the
//! loading of torchvision-named safetensors weights ([`weights`]).

pub mod fpn;
pub mod resnet;
pub mod weights;
