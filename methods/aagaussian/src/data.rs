//! The embedded default (spec §7, preset `portrait`): K synthetic identities on the built-in
//! body in the canonical A-pose, rendered by the independent CPU mesh renderer — never by the
//! splat rasterizer — as the mixture oracle's data ([`IdentityBank`]), the face crop of the
//! face-loss identity from the fixed face camera (U7) with its face mask, the body's depth from
//! that camera (D_m of U6), and the held-out views the avatar is scored on.
//!
//! The avatar's body is the body prior: the avatar's body model ([`AvatarBody`]: the built-in
//! body, or a user's SMPL-family file) with the shape fitted to the portrait's keypoints
//! ([`crate::portrait_fit`]); its face region places the face camera and masks the face. Units: its canonical mesh is normalised as
//! HumanGaussian does (bounding box centred at the origin, longest side 0.6 · 1.1¹⁰ = 1.5562);
//! every identity shares that transform, and `metres_per_unit` returns to metres.

use crate::body_prior::AvatarBody;
use crate::cameras::orbit_camera;
use crate::error::AagError;
use crate::face_align::{ALIGNMENT_LANDMARKS, PortraitCrop, crop_from_portrait};
use crate::oracle::Targets;
use crate::portrait_fit::{
    PORTRAIT_EYE, PORTRAIT_FOVY_DEGREES, PORTRAIT_TARGET, PortraitFit, fit_portrait,
};
use burn::tensor::Device;
use serde::{Deserialize, Serialize};
use splatzoo_datasets::render::{
    Albedo, Light, Lighting, MeshInstance, MeshRender, RenderSettings, Texture, render,
};
use splatzoo_datasets::synth::identity::Identity;
use splatzoo_datasets::synth::keypoints::pinhole;
use splatzoo_datasets::synth::rng::Rng;
use splatzoo_datasets::synth::scene::posed_once;
use splatzoo_models::body::builtin_body;
use splatzoo_rasterizer::Camera;
use std::path::PathBuf;

/// Longest side of the normalised body (HumanGaussian: 0.6 · 1.1¹⁰).
pub const BODY_EXTENT: f64 = 1.556_245_1;
/// Texture size of each identity.
const TEXTURE_SIZE: usize = 512;
/// SMPL joint index of the head.
const HEAD_JOINT: usize = 15;

/// The canonical pose of the avatar (A10 of the spec).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum CanonicalPose {
    /// HumanGaussian's A-pose: hips (0, ±0.2, ±0.1), shoulders (0, 0, ∓π/4).
    APose,
    /// The rest pose (the paper's Fig. 2 stage (c)).
    TPose,
}

impl CanonicalPose {
    /// The 72-D SMPL axis-angle pose.
    pub fn axis_angle(self) -> [f64; 72] {
        let mut pose = [0.0; 72];
        if self == CanonicalPose::APose {
            let mut set =
                |joint: usize, v: [f64; 3]| pose[3 * joint..3 * joint + 3].copy_from_slice(&v);
            set(1, [0.0, 0.2, 0.1]);
            set(2, [0.0, -0.2, -0.1]);
            set(16, [0.0, 0.0, -std::f64::consts::FRAC_PI_4]);
            set(17, [0.0, 0.0, std::f64::consts::FRAC_PI_4]);
        }
        pose
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PortraitConfig {
    /// Identities in the oracle's data set (K).
    pub identities: usize,
    /// Seed of the identities.
    pub seed: u64,
    /// The prompted identity (the prompt's label).
    pub prompt: usize,
    /// The negative prompt's identity.
    pub negative: usize,
    /// Whose face the face crop shows (the prompted identity unless a face swap is wanted,
    /// the spec's T7).
    pub face_identity: usize,
    pub canonical: CanonicalPose,
    /// Side of the face crop and of the face view, pixels.
    pub face_size: u32,
    /// Distance of the face camera from the face centroid (d_f, normalised units).
    pub face_distance: f64,
    pub face_fovy_degrees: f64,
    /// Held-out views: this many azimuths at each of `eval_elevations`.
    pub eval_azimuths: usize,
    pub eval_elevations: Vec<f64>,
    pub eval_distance: f64,
    pub eval_fovy_degrees: f64,
    pub eval_size: u32,
    /// Fit the body prior's shape from the portrait's keypoints (\[P\]); false: the
    /// prompted identity's true shape (tests of everything downstream of the fit).
    pub body_fit: bool,
    /// Pixel noise of the portrait's keypoints, and the portrait's side.
    pub keypoint_noise_px: f64,
    pub portrait_size: u32,
    /// The oracle shows the prompted identity with another skin and hair tone from each side
    /// (the spec's `view_variants`; held-out scores use the identity as it is).
    pub view_variants: bool,
    /// The avatar's body model: a user's SMPL / SMPL-H / SMPL-X `.npz` or `.pkl` (none: the
    /// built-in body). The identities stay on the built-in body; this one is fitted to them.
    pub body_model: Option<PathBuf>,
    /// Surface marks of `body_model` (landmarks and optionally the face vertices, JSON; see
    /// `splatzoo_models::body::marks`), for a mesh outside the SMPL-family tables.
    pub body_marks: Option<PathBuf>,
    /// Where the face crop comes from (U8).
    pub face_crop: FaceCropSource,
}

/// The face crop's source.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FaceCropSource {
    /// The face identity rendered from the face camera (exact: the face loss's optimum is known).
    Render,
    /// Cut from the portrait photo by U8's alignment of its face keypoints (what a user's photo
    /// gets: [`crate::face_align`]).
    Portrait,
}

impl Default for PortraitConfig {
    fn default() -> Self {
        Self {
            identities: 4,
            seed: 7,
            prompt: 0,
            negative: 1,
            face_identity: 0,
            canonical: CanonicalPose::APose,
            face_size: 64,
            face_distance: 0.5,
            face_fovy_degrees: 40.0,
            eval_azimuths: 16,
            eval_elevations: vec![-15.0, 0.0, 20.0],
            eval_distance: 1.8,
            eval_fovy_degrees: 50.0,
            eval_size: 96,
            body_fit: true,
            keypoint_noise_px: 2.0,
            portrait_size: 512,
            view_variants: false,
            body_model: None,
            body_marks: None,
            face_crop: FaceCropSource::Render,
        }
    }
}

impl PortraitConfig {
    pub fn validate(&self) -> Result<(), String> {
        let k = self.identities;
        if k == 0 || self.prompt >= k || self.negative >= k || self.face_identity >= k {
            return Err(format!(
                "data: prompt {}, negative {} and face_identity {} must be below identities {k} (> 0)",
                self.prompt, self.negative, self.face_identity
            ));
        }
        if self.face_size < 8 || self.eval_size < 8 {
            return Err("data: face_size and eval_size must be at least 8 pixels".into());
        }
        if !(self.keypoint_noise_px.is_finite() && self.keypoint_noise_px >= 0.0)
            || self.portrait_size < 64
        {
            return Err(
                "data: keypoint_noise_px must be finite and >= 0, portrait_size >= 64".into(),
            );
        }
        if self.eval_azimuths == 0 || self.eval_elevations.is_empty() {
            return Err("data: at least one held-out azimuth and elevation".into());
        }
        if self.body_model.is_some() && !self.body_fit {
            return Err(
                "data: body_fit = false takes the identity's true built-in shape, which a user's \
                 body_model does not have: keep body_fit = true"
                    .into(),
            );
        }
        Ok(())
    }
}

/// One identity's canonical mesh and texture, in normalised units.
#[derive(Debug, Clone)]
pub struct IdentityMesh {
    pub identity: Identity,
    /// `[V]` normalised canonical vertices.
    pub vertices: Vec<[f32; 3]>,
    pub texture: Texture,
    /// With `view_variants`: the textures the oracle shows from the body's left and right
    /// sides (skin lighter and darker, hair recoloured); empty otherwise.
    pub side_textures: Vec<Texture>,
}

/// The identities seen from any camera: the oracle's [`Targets`].
#[derive(Debug, Clone)]
pub struct IdentityBank {
    pub identities: Vec<IdentityMesh>,
    pub faces: Vec<[u32; 3]>,
    pub uv_coords: Vec<[f32; 2]>,
    pub uv_faces: Vec<[u32; 3]>,
    pub lighting: Lighting,
    pub settings: RenderSettings,
}

/// The light every identity is photographed under: ambient plus a frontal key light, no
/// shadows (a studio portrait).
pub fn studio_lighting() -> Lighting {
    Lighting {
        ambient: [0.55; 3],
        environment: None,
        light: Some(Light::Directional {
            direction: [-0.3, -0.5, -1.0],
            color: [0.5; 3],
        }),
        shadow_resolution: None,
    }
}

impl IdentityBank {
    pub fn render(&self, label: usize, camera: &Camera) -> MeshRender {
        self.render_posed(label, &self.identities[label].vertices, camera)
    }

    /// Identity `label`'s textured mesh with its vertices moved to `vertices` (a pose).
    pub fn render_posed(&self, label: usize, vertices: &[[f32; 3]], camera: &Camera) -> MeshRender {
        self.render_textured(vertices, &self.identities[label].texture, camera)
    }

    /// What the oracle sees of identity `label` from `camera`: its own texture, or with
    /// `view_variants` a side variant when the camera is on the body's left or right
    /// (45° < |azimuth| < 135°, the azimuth measured from the body's front, +z).
    pub fn oracle_render(&self, label: usize, camera: &Camera) -> MeshRender {
        let mesh = &self.identities[label];
        let texture = match mesh.side_textures.as_slice() {
            [left, right] => {
                let m = &camera.world_to_camera;
                let centre: [f32; 3] =
                    std::array::from_fn(|k| -(0..3).map(|r| m[r][k] * m[r][3]).sum::<f32>());
                let azimuth = f64::from(centre[0])
                    .atan2(f64::from(centre[2]))
                    .to_degrees();
                if (45.0..135.0).contains(&azimuth) {
                    left
                } else if (-135.0..-45.0).contains(&azimuth) {
                    right
                } else {
                    &mesh.texture
                }
            }
            _ => &mesh.texture,
        };
        self.render_textured(&mesh.vertices, texture, camera)
    }

    fn render_textured(
        &self,
        vertices: &[[f32; 3]],
        texture: &Texture,
        camera: &Camera,
    ) -> MeshRender {
        let instance = MeshInstance {
            positions: vertices,
            faces: &self.faces,
            albedo: Albedo::Textured {
                coords: &self.uv_coords,
                corners: &self.uv_faces,
                texture,
            },
            label: 1,
            smooth: true,
        };
        render(&[instance], camera, &self.lighting, &self.settings)
    }
}

/// A mesh render as the model's two branches, `[3, H, W]` RGB and `[1, H, W]` depth, each
/// mapped from [0, 1] to [−1, 1]; depth is camera z on the body (0 on the background)
/// normalised by its image's min and max (Eq. 4 as HumanGaussian feeds it).
pub fn render_to_branches(r: &MeshRender) -> Vec<Vec<f32>> {
    let n = r.width * r.height;
    let mut rgb = vec![0.0f32; 3 * n];
    for (p, c) in r.color.iter().enumerate() {
        for k in 0..3 {
            rgb[k * n + p] = 2.0 * c[k].clamp(0.0, 1.0) - 1.0;
        }
    }
    let depth: Vec<f32> = r
        .depth
        .iter()
        .zip(&r.coverage)
        .map(|(d, c)| if d.is_finite() { d * c } else { 0.0 })
        .collect();
    vec![
        rgb,
        normalised_depth(&depth)
            .iter()
            .map(|d| 2.0 * d - 1.0)
            .collect(),
    ]
}

/// `(d − min) / (max − min)` over one image (0 where the image is flat).
pub fn normalised_depth(depth: &[f32]) -> Vec<f32> {
    let lo = depth.iter().copied().fold(f32::INFINITY, f32::min);
    let hi = depth.iter().copied().fold(f32::NEG_INFINITY, f32::max);
    let range = hi - lo;
    depth
        .iter()
        .map(|d| if range > 1e-8 { (d - lo) / range } else { 0.0 })
        .collect()
}

impl Targets for IdentityBank {
    fn count(&self) -> usize {
        self.identities.len()
    }

    fn target(&self, label: usize, camera: &Camera) -> Vec<Vec<f32>> {
        render_to_branches(&self.oracle_render(label, camera))
    }
}

/// The whole synthetic portrait capture.
#[derive(Debug, Clone)]
pub struct PortraitCapture {
    pub config: PortraitConfig,
    pub bank: IdentityBank,
    /// The avatar's body model and its marks.
    pub body: AvatarBody,
    /// The avatar's canonical mesh (the body prior, normalised): `[V, 3]`, faces `body.faces`.
    pub canonical: Vec<[f32; 3]>,
    /// `metres = units × metres_per_unit` (plus the centre).
    pub metres_per_unit: f64,
    /// The body-space point that normalisation moves to the origin (metres).
    pub centre: [f32; 3],
    /// The body prior's shape (fitted, or the identity's own without `body_fit`).
    pub body_betas: Vec<f64>,
    pub body_fit: Option<PortraitFit>,
    /// The head joint's height in normalised units (A13).
    pub head_height: f64,
    pub face_camera: Camera,
    /// `[3, S, S]` face crop in [0, 1] (background black) and `[S, S]` face mask.
    pub face_crop: Vec<f32>,
    /// With `face_crop = "portrait"`: the alignment's RMS residual, crop pixels.
    pub face_alignment_px: Option<f64>,
    pub face_mask: Vec<bool>,
    /// `[S, S]` the canonical body's depth from the face camera (∞ off the body): D_m of U6.
    pub face_depth: Vec<f32>,
    /// Held-out cameras and the prompted identity's renders there (`[H, W]` of RGB).
    pub eval_cameras: Vec<Camera>,
    /// `[identity][view]` held-out renders in [0, 1], `[3, H, W]`.
    pub eval_targets: Vec<Vec<Vec<f32>>>,
}

/// `[3, H, W]` in [0, 1] from a render's colours.
pub fn planar_rgb(r: &MeshRender) -> Vec<f32> {
    let n = r.width * r.height;
    let mut out = vec![0.0; 3 * n];
    for (p, c) in r.color.iter().enumerate() {
        for k in 0..3 {
            out[k * n + p] = c[k].clamp(0.0, 1.0);
        }
    }
    out
}

/// The spec's `view_variants`: the identity as the oracle shows it from its left (skin 40 %
/// lighter, hair a warm brown) and from its right (skin 40 % darker, hair a pale blond) — an
/// honest prior that disagrees with itself across views, as the paper's fragmented and
/// asymmetric faces suggest a real one does.
fn side_variants(identity: &Identity) -> [Identity; 2] {
    let scaled = |c: [f32; 3], f: f32| c.map(|v| (v * f).clamp(0.0, 1.0));
    [
        Identity {
            skin: scaled(identity.skin, 1.4),
            hair: [0.45, 0.25, 0.1],
            ..identity.clone()
        },
        Identity {
            skin: scaled(identity.skin, 0.6),
            hair: [0.85, 0.75, 0.5],
            ..identity.clone()
        },
    ]
}

impl PortraitCapture {
    /// Identity `label`'s mesh posed by the 72-D SMPL `pose` (no translation), in the
    /// capture's normalised units.
    pub fn posed_vertices(&self, label: usize, pose: &[f64; 72], device: &Device) -> Vec<[f32; 3]> {
        let betas = &self.bank.identities[label].identity.betas;
        self.normalised(&posed_once(betas, pose, device).vertices)
    }

    /// The body prior's mesh (the avatar's body, faces `body.faces`) posed by `pose`, normalised.
    pub fn posed_body(&self, pose: &[f64; 72], device: &Device) -> Vec<[f32; 3]> {
        self.normalised(&self.body.posed(&self.body_betas, pose, device).vertices)
    }

    fn normalised(&self, vertices: &[[f32; 3]]) -> Vec<[f32; 3]> {
        let scale = (1.0 / self.metres_per_unit) as f32;
        vertices
            .iter()
            .map(|p| [0, 1, 2].map(|c| (p[c] - self.centre[c]) * scale))
            .collect()
    }

    pub fn build(config: &PortraitConfig, device: &Device) -> Result<Self, AagError> {
        let body = builtin_body();
        let pose = config.canonical.axis_angle();
        let identities: Vec<Identity> = (0..config.identities)
            .map(|k| Identity::sample(config.seed.wrapping_mul(1000).wrapping_add(k as u64)))
            .collect();
        let posed: Vec<Vec<[f32; 3]>> = identities
            .iter()
            .map(|id| posed_once(&id.betas, &pose, device).vertices)
            .collect();
        // The body prior: fitted from the portrait's keypoints, or the truth.
        let avatar = AvatarBody::load(config.body_model.as_deref(), config.body_marks.as_deref())?;
        let truth = &identities[config.prompt].betas;
        let body_fit = if config.body_fit {
            Some(fit_portrait(
                &avatar,
                truth,
                &pose,
                config.portrait_size,
                config.keypoint_noise_px,
                config.seed ^ 0xF17,
                device,
            )?)
        } else {
            None
        };
        let body_betas = body_fit
            .as_ref()
            .map_or_else(|| truth.clone(), |f| f.betas.clone());
        let prior = avatar.posed(&body_betas, &pose, device);
        // HumanGaussian's normalisation, from the body prior's mesh.
        let (reference, head) = (&prior.vertices, &prior.joints[HEAD_JOINT]);
        let mut lo = [f32::INFINITY; 3];
        let mut hi = [f32::NEG_INFINITY; 3];
        for p in reference {
            for c in 0..3 {
                lo[c] = lo[c].min(p[c]);
                hi[c] = hi[c].max(p[c]);
            }
        }
        let centre = [0, 1, 2].map(|c| 0.5 * (lo[c] + hi[c]));
        let longest = (0..3).map(|c| hi[c] - lo[c]).fold(0.0f32, f32::max);
        let scale = BODY_EXTENT as f32 / longest;
        let normalise = |p: &[f32; 3]| [0, 1, 2].map(|c| (p[c] - centre[c]) * scale);
        let head_height = f64::from(normalise(head)[1]);
        let faces: Vec<[u32; 3]> = body
            .model
            .faces
            .chunks(3)
            .map(|f| [f[0], f[1], f[2]])
            .collect();
        let bank = IdentityBank {
            identities: identities
                .iter()
                .zip(&posed)
                .enumerate()
                .map(|(k, (identity, vertices))| IdentityMesh {
                    texture: identity.bake_texture(body, TEXTURE_SIZE),
                    side_textures: if config.view_variants && k == config.prompt {
                        side_variants(identity)
                            .iter()
                            .map(|v| v.bake_texture(body, TEXTURE_SIZE))
                            .collect()
                    } else {
                        Vec::new()
                    },
                    identity: identity.clone(),
                    vertices: vertices.iter().map(normalise).collect(),
                })
                .collect(),
            faces,
            uv_coords: body.uv.coords.chunks(2).map(|c| [c[0], c[1]]).collect(),
            uv_faces: body
                .uv
                .faces
                .chunks(3)
                .map(|f| [f[0], f[1], f[2]])
                .collect(),
            lighting: studio_lighting(),
            settings: RenderSettings {
                background: [0.0; 3],
                supersample: 1,
            },
        };
        let canonical: Vec<[f32; 3]> = prior.vertices.iter().map(normalise).collect();

        // U7: the face camera looks at the face-region centroid from d_f along +z.
        let mut centroid = [0.0f64; 3];
        let mut count = 0.0f64;
        for (v, on) in canonical.iter().zip(&avatar.marks.face_region) {
            if *on {
                for c in 0..3 {
                    centroid[c] += f64::from(v[c]);
                }
                count += 1.0;
            }
        }
        if count == 0.0 {
            return Err(AagError::input(
                avatar.source.clone(),
                "the body's face region is empty: the face camera has nothing to look at",
            ));
        }
        let centroid = centroid.map(|c| c / count);
        let face_camera = orbit_camera(
            centroid,
            0.0,
            0.0,
            config.face_distance,
            config.face_fovy_degrees,
            config.face_size,
        );
        let indicator: Vec<[f32; 3]> = avatar
            .marks
            .face_region
            .iter()
            .map(|&on| if on { [1.0; 3] } else { [0.0; 3] })
            .collect();
        let mask_render = render(
            &[MeshInstance {
                positions: &canonical,
                faces: &avatar.faces,
                albedo: Albedo::PerVertex(&indicator),
                label: 1,
                smooth: true,
            }],
            &face_camera,
            &Lighting {
                ambient: [1.0; 3],
                environment: None,
                light: None,
                shadow_resolution: None,
            },
            &bank.settings,
        );
        let face_mask = mask_render.color.iter().map(|c| c[0] > 0.5).collect();
        let face_depth = mask_render.depth.clone();
        let (face_crop, face_alignment_px) = match config.face_crop {
            FaceCropSource::Render => (
                planar_rgb(&bank.render(config.face_identity, &face_camera)),
                None,
            ),
            FaceCropSource::Portrait => {
                let keep: Vec<bool> = face_depth.iter().map(|d| d.is_finite()).collect();
                let photo_camera = Camera::look_at(
                    normalise(&PORTRAIT_EYE),
                    normalise(&PORTRAIT_TARGET),
                    [0.0, 1.0, 0.0],
                    PORTRAIT_FOVY_DEGREES,
                    config.portrait_size,
                    config.portrait_size,
                );
                let cropped = synthetic_portrait_crop(
                    &bank,
                    config,
                    &photo_camera,
                    &avatar,
                    &canonical,
                    &face_camera,
                    &keep,
                )?;
                (cropped.crop, Some(cropped.residual_px))
            }
        };

        let mut eval_cameras = Vec::new();
        for &el in &config.eval_elevations {
            for a in 0..config.eval_azimuths {
                // Offset by half a step from the training azimuth grid's edges.
                let az = -180.0 + 360.0 * (a as f64 + 0.5) / config.eval_azimuths as f64;
                eval_cameras.push(orbit_camera(
                    [0.0; 3],
                    az,
                    el,
                    config.eval_distance,
                    config.eval_fovy_degrees,
                    config.eval_size,
                ));
            }
        }
        let eval_targets = (0..config.identities)
            .map(|k| {
                eval_cameras
                    .iter()
                    .map(|c| planar_rgb(&bank.render(k, c)))
                    .collect()
            })
            .collect();
        Ok(Self {
            config: config.clone(),
            bank,
            body: avatar,
            canonical,
            metres_per_unit: 1.0 / f64::from(scale),
            centre,
            body_betas,
            body_fit,
            head_height,
            face_camera,
            face_crop,
            face_alignment_px,
            face_mask,
            face_depth,
            eval_cameras,
            eval_targets,
        })
    }
}

/// The face identity photographed by `photo_camera` (the portrait), its face points detected
/// with the keypoints' noise, and the crop cut from it by U8 ([`crop_from_portrait`]).
fn synthetic_portrait_crop(
    bank: &IdentityBank,
    config: &PortraitConfig,
    photo_camera: &Camera,
    avatar: &AvatarBody,
    canonical: &[[f32; 3]],
    face_camera: &Camera,
    keep: &[bool],
) -> Result<PortraitCrop, AagError> {
    let photo = planar_rgb(&bank.render(config.face_identity, photo_camera));
    let seen = &bank.identities[config.face_identity].vertices;
    let (photo_pinhole, face_pinhole) = (pinhole(photo_camera), pinhole(face_camera));
    let mut rng = Rng(config.seed ^ 0xFACE);
    let noise = config.keypoint_noise_px;
    let photo_points = ALIGNMENT_LANDMARKS.map(|name| {
        let p = builtin_body()
            .landmark(name)
            .and_then(|v| photo_pinhole.project(seen[v as usize].map(f64::from)))?;
        Some([p[0] + noise * rng.normal(), p[1] + noise * rng.normal()])
    });
    let body_points = ALIGNMENT_LANDMARKS.map(|name| {
        avatar
            .landmark(name)
            .and_then(|v| face_pinhole.project(canonical[v as usize].map(f64::from)))
    });
    let size = config.portrait_size as usize;
    crop_from_portrait(
        &photo,
        size,
        size,
        &photo_points,
        &body_points,
        config.face_size as usize,
        keep,
    )
}
