//! Training machinery shared by every `train-<method>` binary: Gaussian parameter sets and
//! their initialisation ([`gaussians`]), Adam with per-group learning rates ([`adam`]), image
//! losses and metrics ([`loss`]), INRIA-layout `.ply` files ([`ply`]).

pub mod adam;
pub mod gaussians;
pub mod loss;
pub mod ply;
