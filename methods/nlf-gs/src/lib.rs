//! NLF-GS: feed-forward, drivable Gaussian avatars from three views
//! (`../shared/papers/nlf-gs.txt`). Gaussians anchored on the body mesh are queried in every
//! input view's ResNet-FPN feature map, fused across views with geometry-aware weights and
//! decoded into pose-independent attributes; driving re-anchors them on a newly posed mesh.
//!
//! # Equation index
//!
//! | Eq. | what | implemented by |
//! |---|---|---|
//! | Eq. 1 (§3.4) | Gaussian centre = barycentric point of its face + offset in the face frame | [`splatzoo_models::anchor::anchored_positions`], anchors from [`splatzoo_models::anchor::MeshAnchors::per_face`]; offsets applied by [`network::Avatar::drive`] |
//! | Eq. 2 (§3.5) | projection into view v, `ũ = K_v (R_v x + t_v)` | [`query::project`] |
//! | Eq. 3 (§3.5) | bilinear feature sampling `q = GridSample(F_v, u)` | [`query::sample`] (by indexed rows; [`query::sample_by_grid`] is the `grid_sample_2d` reference) |
//! | Eq. 4 (§3.6) | orientation × occlusion fusion weights and the weighted sum over views | [`query::weights`], [`query::sample_and_fuse`]; the Table 6 variants are [`query::Fusion`] |
//! | Eq. 5 (§3.7) | `L = λ_rec L_rec + λ_sil L_sil + λ_reg L_reg` | [`loss::nlf_loss`], weights [`loss::NlfLossWeights`] |
//! | Eq. 6 | `L_rec = λ_l1 L1 + λ_ssim L_ssim + λ_perc L_perc` | [`loss::nlf_loss`]; `L_perc` is [`loss::intensity_gradient`]; L1 and SSIM from [`splatzoo_train::loss`] |
//! | Eq. 7 | `L_reg = λ_scale L_scale + λ_Δx L_Δx + λ_α L_α` | [`loss::nlf_loss`] |
//! | Eq. 8 (Supp. A) | FPN over ResNet stages C2–C5, levels fused to stride 4 | [`splatzoo_models::networks::fpn::ResNetFpn`] over [`splatzoo_models::networks::resnet::ResNet`] |
//!
//! The attribute decoder of §3.6 (offset, rotation, scale, opacity, colour with bounded
//! activations) is [`decoder::Decoder`]; the whole generator and driver is
//! [`network::NlfGs`]. Training (§3.7, §4) is [`trainer::NlfTrainer`], a
//! [`splatzoo_train::harness::Method`] with its configuration in [`config::NlfTrainConfig`];
//! the avatar renders through the engine's scene graph as a [`node::GeneratedAvatar`]. The
//! synthetic stand-in for THuman2.0 is [`data`]; the mean-colour baseline is [`baseline`]; the
//! ONNX export of encoder and decoder is [`onnx`].
//!
//! Protocol: inputs at 0°/120°/240°, supervision at the same views (the paper's "training
//! views", §4.2; [`config::Supervision`]), held-out identities scored at the novel views
//! 60°/180°/300° (Table 3) and at the input views (the convention of Tables 5–7, §4.1).
//! Binaries: `train-nlf`, `drive-nlf`; bench: `nlf`. The crate's `README.md` has the measured
//! figures and every choice the paper leaves open.

pub mod baseline;
pub mod capture;
pub mod config;
pub mod data;
pub mod decoder;
mod error;
pub mod loss;
pub mod network;
pub mod node;
pub mod onnx;
pub mod query;
pub mod trainer;

pub use error::NlfError;
