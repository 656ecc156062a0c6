//! Training machinery shared by every `train-<method>` binary: Gaussian parameter sets and
//! their initialisation ([`gaussians`]), Adam ([`adam`]) and the 3DGS per-group optimiser ([`optimizer`]), image
//! losses and metrics ([`loss`]), INRIA-layout `.ply` files ([`ply`]).

pub mod adam;
pub mod gaussians;
pub mod loss;
pub mod optimizer;
pub mod ply;
