//! AAGaussian: animatable avatars from a portrait and a prompt (`../shared/papers/aagaussian.txt`).
//! Gaussians sampled on a body prior are optimised in canonical space by dual-branch score
//! distillation (RGB and depth) from a texture-structure joint diffusion model, with a facial
//! rendering loss against the user's face crop and a sparsity term; the result is re-posed
//! zero-shot by a motion.
//!
//! # Equation index
//!
//! | Eq. | what | implemented by |
//! |---|---|---|
//! | Eq. 1 | SMPL-X `M(β, θ, ψ)` | [`splatzoo_models::body::lbs::pose`] (the built-in body, or a user's SMPL-family file with its marks: [`body_prior::AvatarBody`]; [`data::CanonicalPose`] is the canonical pose); β fitted from the portrait's keypoints by [`splatzoo_models::body::fit`] ([`portrait_fit`]; a user's photo: [`photo::Photo::fit`]) |
//! | Eq. 2 | 3DGS rendering | [`splatzoo_rasterizer::rasterize`] unchanged, SH degree 0, black background ([`trainer::render_views`]) |
//! | Eq. 3 | `∇L_SDS = E[w_t (ε_φ(x_t; y) − ε) ∂x/∂θ]`, `x_t = α_t x + σ_t ε` | [`sds::SdsConfig::guidance`], [`sds::surrogate`], [`schedule::NoiseSchedule`] |
//! | Eq. 4 | accumulated depth `d(p) = Σ d_i σ_i Π(1 − σ_j)`, normalised | [`loss::depth_branch`], [`loss::normalise_depth`] |
//! | Eq. 5 | dual-branch SDS, λ₁ RGB and λ₂ depth, one t per item | [`sds::SdsConfig::guidance`] over [`score::ScoreModel`] with two branches |
//! | Eq. 6 | `λ₁ L_SDS1 + λ₂ L_SDS2 + λ₃ L_f + λ₄ L_s` | [`trainer::AagTrainer::train_step`] |
//! | U1 | ANPG / CFG / HumanGaussian guidance | [`sds::Guidance`] |
//! | U2 | v → ε | [`score::epsilon_from`] |
//! | U3 | per-pixel clip, clamp ramp, surrogate | [`sds::clip_pixel_norm`], [`sds::SdsConfig::clamp_at`], [`sds::surrogate`] |
//! | U4 | sparsity | [`loss::sparsity`] |
//! | U5 | centre-weighted face colour term | [`face::face_colour_loss`], [`face::centre_weights`] |
//! | U6 | line-of-sight distance to the body | [`face::LineOfSight::loss`] |
//! | U7 | fixed face camera | [`data::PortraitCapture::build`] |
//! | U8 | face crop from a portrait: 2-D similarity of the face points, resampling | [`face_align::umeyama_2d`], [`face_align::crop_from_portrait`]; a user's photo and its OpenPose JSON: [`photo::Photo`] |
//! | U9 | animation binding: nearest face, barycentrics, normal offset; re-posing | [`binding::bind`], [`binding::SurfaceBinding::pose`], [`animate::animate`] |
//! | T3 | guidance fixed points under point masses (every run's `metrics.json`) | [`fixed_points::check`] |
//! | S1/S2 | point-mass and mixture oracles | [`oracle::MixtureOracle`], [`oracle::posterior`] |
//!
//! The crate's `README.md` lists what is built so far and every choice the paper leaves open.

pub mod animate;
pub mod binding;
pub mod body_prior;
pub mod cameras;
pub mod config;
pub mod data;
mod error;
pub mod eval;
mod export;
pub mod face;
pub mod face_align;
pub mod fixed_points;
pub mod identities;
pub mod init;
pub mod loss;
mod method;
pub mod onnx_score;
pub mod oracle;
pub mod photo;
pub mod portrait_fit;
pub mod prompts;
pub mod schedule;
pub mod score;
pub mod sds;
pub mod synthetic_photo;
pub mod tiny_unet;
pub mod trainer;
pub mod video_poses;

pub use error::AagError;
pub use method::{Aag, AagArgs};
