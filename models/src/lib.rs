//! Body models, skinning, Gaussian sets, networks and losses shared by the zoo's methods.
//!
//! So far: rotation representations as differentiable Burn ops ([`rotation`]) and the body-model
//! layer ([`body`]): the model data, forward kinematics and linear blend skinning.

pub mod anchor;
pub mod body;
pub mod networks;
pub mod pickle;
pub mod rotation;
pub mod rotation_scalar;
