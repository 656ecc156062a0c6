//! Illum: illumination-consistent human–scene reconstruction from a monocular video
//! (`../shared/papers/illum.txt`). A static 3DGS scene and a human of PBR Gaussians (albedo,
//! metallic, roughness, visibility) share one world-space **light volume**: a grid of probes,
//! each holding SH radiance and a latent feature. The human is shaded by Monte-Carlo
//! integration of the probes' light, and the scene is darkened where the human occludes it by a
//! decoder of the same latents, so human and scene are lit consistently and the human can be
//! relit or moved into another reconstructed scene.
//!
//! # Equation index
//!
//! | Eq. | what | implemented by |
//! |---|---|---|
//! | Eq. 1 | `v' = v + F_Δ(v)`, `c = F_c(v)`: hash-encoded refinement of the body mesh, Gaussians from its faces | [`human::RefinedBody`] (two [`splatzoo_models::networks::hash_mlp::HashMlp`] on fixed queries), [`human::pose_refined`]; L_mesh: [`splatzoo_models::laplacian::UniformLaplacian::energy`] |
//! | Eq. 2 | `{m, r} = F_m(v)` | [`splatzoo_models::networks::hash_mlp::HashMlp`] (two sigmoid outputs) |
//! | Eq. 3 | `vis = F_vis(v, θ, φ)`, φ the incident direction | [`visibility::VisibilityNet`], supervised by [`visibility::sample_labels`] (ray cast on [`splatzoo_models::raycast::TriangleBvh`]) with [`visibility::bce_with_logits`] |
//! | Eq. 4 | the rendering equation over the normal's hemisphere, per human Gaussian | estimated by Eq. 7 in [`lighting::shade_gaussians`]; normals and materials from the mesh by [`lighting::KnnTransfer`] |
//! | Eq. 5 | `f_s = D F G / (4 (n·ω_i)(n·ω_o))` (the 4 restored), `f_d = (1 − m) b/π` | [`brdf::specular`], [`brdf::diffuse`]; f64: [`brdf::brdf_reference`] |
//! | Eq. 6 | `L_i(x, ω) = Σ w_k L_k(ω) / Σ w_k` over the cell's 8 probes (trilinear) | [`light_volume::LightVolume::interpolate`] (coefficients interpolated, then evaluated) |
//! | Eq. 6 (sampling) | Fibonacci directions about the normal | [`sampling::fibonacci_hemisphere`] |
//! | Eq. 7 | `c' = Σ_j (f_d + f_s) V L (ω_j·n) Δω`, `Δω = 2π/N_l` | [`pbr::shade`]; f64: [`pbr::shade_reference`]; sRGB: [`pbr::linear_to_srgb`] |
//! | Eq. 8 | `ao = F_ao(γ(r), γ(δ), z)` for scene Gaussians in the padded human box | [`shadow::ShadowDecoder`], [`shadow::scene_occlusion`], [`shadow::ShadowBox`] |
//! | Eq. 9 | `SH' = ao · SH`, read as `ao · max(SH(d) + 0.5, 0)` | [`shadow::shadowed_colour`], in the joint render [`render::render_joint`]; as an SH edit: [`shadow::sh_equivalent`] |
//! | Eq. 11 | edge-aware material smoothness | [`smoothness::materials_smoothness`] |
//! | Eq. 12 | ao smoothness over scene neighbours | [`smoothness::shadow_smoothness`] |
//! | Eq. 13 | probe smoothness over grid face-neighbours | [`light_volume::LightVolume::probe_smoothness`] |
//!
//! Stage 1's objective (L_human of Eq. 10, L_mesh, L_scale) is [`stage1::stage1_terms`];
//! stage 2 starts from it with [`stage2::PbrHuman::from_stage1`]; the
//! joint Eq. 10, 14 and 15 and the two training schedules come with the trainer; the crate's `README.md` lists what is built so far and every choice the
//! paper leaves open.

pub mod brdf;
pub mod config;
pub mod data;
pub mod disk;
pub mod environment;
mod error;
pub mod eval;
pub mod export;
pub mod human;
pub mod light_volume;
pub mod lighting;
pub mod method;
pub mod needs;
pub mod onnx;
pub mod pbr;
pub mod probe_scores;
pub mod render;
pub mod sampling;
pub mod shadow;
pub mod smoothness;
pub mod stage1;
pub mod stage2;
pub mod steps;
pub mod trainer;
pub mod visibility;

pub use error::IllumError;
