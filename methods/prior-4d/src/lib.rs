//! Prior-4D: monocular 4D human + scene reconstruction from priors
//! (`../shared/papers/prior-4d.txt`). A static scene prior (3DGS on a scene scan) and an avatar
//! prior (opaque isotropic Gaussians on a subdivided body, fitted on a human scan) are refined
//! jointly on a hand-held acting video: the acting cameras, the body motion, one global scale σ
//! placing the camera-space avatar in the scene, the avatar's colours, radii and offsets, and the
//! scene's SH only (its geometry frozen), under photometric, normal, contact and Huber prior
//! terms.
//!
//! # Equation index
//!
//! | Eq. | what | implemented by |
//! |---|---|---|
//! | Eq. 1 | `Σ = R S Sᵀ Rᵀ` of the scene's Gaussians | [`splatzoo_rasterizer::rasterize`] unchanged |
//! | Eq. 2 | `V̄ = V_h + ΔV_expr + ΔV_cloth + ΔV_pose(θ)`, radii likewise (log units) | the skinned node's canonical Gaussians (`ΔV_cloth`) and [`offsets::PoseOffsets`], a canonical-space field applied before skinning |
//! | Eq. 3 | `V_cam = LBS(V̄, θ, W)`, root translation `P_c` in the acting camera's frame | [`splatzoo_train::scene::SkinnedGaussianNode`] (one Gaussian per vertex) |
//! | Eq. 3′ | `V_world = E^t · σ · V_cam`, radii `× σ` | [`locate::place`], [`locate::solid_spheres`] |
//! | Eq. 4 | front-to-back compositing of scene and avatar | [`render::render_layers`] (one call, seven feature channels) |
//! | Eq. 5 | alpha-blended avatar normals from the posed mesh | [`splatzoo_models::normals::vertex_normals`], [`render::render_layers`] |
//! | Eq. 6 | `‖N̂ − N‖₁ + ‖1 − N̂ᵀN‖₁` | [`loss::normal_loss`] |
//! | Eq. 7 | `Σ max(0, |nᵀV + d| − Δ_c)` over the `N_c` foot vertices nearest π, read in metres (÷ σ) | [`contact::contact_loss`], [`contact::foot_vertices`] |
//! | §4.2 | the body model fitted to 2-D keypoints (refining the regressor's prior) | [`body_fit::refine_on_keypoints`] over [`splatzoo_models::body::fit::fit_body`] |
//! | §4.2 | RANSAC floor plane π; initial σ₀ (derived: the paper gives no procedure) | [`plane::ransac_plane`], [`plane::initial_scale`] |
//! | §4.4.4 | Huber prior on colour and scale (no formula in the paper) | [`loss::huber_prior`] |
//! | §4 camera refinement | `R' = exp(ω) R`, `c' = c + τ` by moving splats | [`camera::RigidFrame::refined`], [`camera::splats_in_frame`] |
//!
//! The crate's `README.md` lists what is built so far and every choice the paper leaves open.

pub mod avatar;
pub mod avatar_stage;
pub mod body_fit;
pub mod camera;
pub mod config;
pub mod contact;
pub mod data;
mod error;
pub mod eval;
mod export;
pub mod init;
pub mod joint;
pub mod locate;
pub mod loss;
mod method;
pub mod offsets;
pub mod onnx;
pub mod plane;
pub mod render;
pub mod scene_stage;
pub mod sources;

pub use error::Prior4dError;
pub use method::{Prior4d, Prior4dArgs, Stage};
