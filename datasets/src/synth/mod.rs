//! The synthetic scene generator: the embedded default data of every method. So far: motion
//! ([`motion`]) and procedural identities ([`identity`]).

pub mod identity;
pub mod motion;
