//! APF-GS: pedestrians in driving scenes (`../shared/papers/apf-gs.txt`). A scene graph of a
//! static background, one skinned human per tracked pedestrian and one deformable accessory
//! per detected accessory, linked to a joint of its human; the human's LBS is corrected by a
//! residual field whose amplitude and regularisation a learned reliability gate trades off; the
//! coarse human masks are split into human and accessory supervision by the initial prior's
//! silhouette.
//!
//! # Equation index
//!
//! | Eq. | what | implemented by |
//! |---|---|---|
//! | Eq. 1 | 3DGS compositing (the trailing σ_t is a typo: standard compositing) | [`splatzoo_rasterizer::rasterize`] unchanged |
//! | Eq. 2 | SMPL `V + B_S(β) + B_P(θ)`, LBS | [`splatzoo_models::body::lbs::pose`] through [`splatzoo_train::scene::SkinnedGaussianNode`] |
//! | Eq. 3 | `M_acc = M_coarse \ M_kine`, per instance, with the cleanup | [`decouple::decouple_view`], node decision [`decouple::wants_accessory`]; `M_kine` optionally refreshed from refined poses, [`refresh`] |
//! | Eq. 4 | `g_i(t) = T_h(t) ⊗ (LBS(ḡ_i, θ(t)) ⊕ Δ_i)`, the gate `a(σ)` | [`residual::GatedResidual`], [`residual::world_residual`], [`gate::GateConfig::amplitude`] |
//! | Eq. 5 | `Δ_i = F_φ(γ(μ̄_i), c_t)`; `(c_t, σ_t) = C(f_img, e_h, t)` | [`networks::ResidualField`], [`networks::Guidance`], [`networks::ImageEncoder`], [`guide::guide`] |
//! | Eq. 6 | `L_photo + λ_pose L_pose + σ λ_sparse L_sparse + (1 − σ) λ_kine L_kine` | [`loss::PersonTerms::total`], [`trainer::ApfTrainer::train_step`] |
//! | Eq. 7 | `L_kine = λ_bone L_bone + λ_limit L_limit` | [`loss::relative_bone_loss`] (on the deformed human), [`loss::limit_loss`] |
//! | Eq. 8 | `T_acc(t) = T_parent(t) · ΔT_attach`, plus `D_ψ` | [`accessory::AccessoryNode`], [`accessory::attached`], [`networks::AccessoryField`]; parent selection [`parent::select_parent`] |
//!
//! The trainer is a [`splatzoo_train::harness::Method`] ([`trainer::ApfTrainer`],
//! configuration [`config::ApfConfig`]); the synthetic driving capture is [`data`], a
//! drivestudio processed-Waymo scene on disk [`drivestudio`]; scores are
//! [`eval`]; the ONNX export of `C`, `F_φ` and `D_ψ` is [`onnx`]. The crate's `README.md` lists every choice the paper leaves open, with its knob.

pub mod accessory;
pub mod boxes;
pub mod config;
pub mod data;
pub mod decouple;
pub mod drivestudio;
mod error;
pub mod eval;
pub mod gate;
pub mod guide;
pub mod loss;
mod method;
pub mod networks;
pub mod onnx;
pub mod parent;
pub mod refresh;
pub mod repose;
pub mod residual;
pub mod scene;
pub mod trainer;

pub use error::ApfError;
