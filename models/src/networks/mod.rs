//! Networks shared by the methods, as Burn modules: ResNet-18/34/50 encoders in torchvision's
//! layout ([`resnet`]), a feature pyramid over them fused to one resolution ([`fpn`]), and the
//! loading of torchvision-named safetensors weights ([`weights`]), NLF-GS's feature query and
//! cross-view fusion ([`query`]), its attribute decoder ([`decoder`]), and the whole NLF-GS
//! generator and driver ([`nlf`]).

pub mod decoder;
pub mod fpn;
pub mod nlf;
pub mod query;
pub mod resnet;
pub mod weights;
