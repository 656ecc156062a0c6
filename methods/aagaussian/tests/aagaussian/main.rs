//! AAGaussian's integration tests, one binary: the noise schedule's constants, SDS under the
//! point-mass oracle against its closed form, v- and ε-prediction agreeing, and the clipping.

mod sds;
