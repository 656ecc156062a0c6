//! The portrait capture. The embedded default (spec §7, preset `portrait`): K synthetic
//! identities ([`crate::identities`], rendered by the independent CPU mesh renderer — never by
//! the splat rasterizer) as the mixture oracle's data, the face crop of the face-loss identity
//! from the fixed face camera (U7) with its face mask, the body's depth from that camera (D_m
//! of U6), and the held-out views the avatar is scored on. Or a user's photo (`data.photo`,
//! [`crate::photo`]): the body prior and the face crop from it, the face mask and depth as
//! above, and no truth.
//!
//! The avatar's body is the body prior: the avatar's body model ([`AvatarBody`]: the built-in
//! body, or a user's SMPL-family file) with the shape fitted to the portrait's keypoints
//! ([`crate::portrait_fit`], [`crate::photo`]); its face region places the face camera and
//! masks the face. Units: its canonical mesh is normalised as HumanGaussian does (bounding box
//! centred at the origin, longest side 0.6 · 1.1¹⁰ = 1.5562); every identity shares that
//! transform, and `metres_per_unit` returns to metres.

use crate::body_prior::AvatarBody;
use crate::cameras::orbit_camera;
use crate::error::AagError;
use crate::face_align::{ALIGNMENT_LANDMARKS, PortraitCrop, crop_from_portrait};
use crate::identities::{IdentityBank, planar_rgb};
use crate::photo::Photo;
use crate::portrait_fit::{
    PORTRAIT_EYE, PORTRAIT_FOVY_DEGREES, PORTRAIT_TARGET, PortraitFit, fit_portrait,
};
use burn::tensor::Device;
use serde::{Deserialize, Serialize};
use splatzoo_datasets::render::{Albedo, Lighting, MeshInstance, RenderSettings, render};
use splatzoo_datasets::synth::identity::Identity;
use splatzoo_datasets::synth::keypoints::pinhole;
use splatzoo_datasets::synth::rng::Rng;
use splatzoo_datasets::synth::scene::posed_once;
use splatzoo_models::body::builtin_body;
use splatzoo_models::body::fit::FitConfig;
use splatzoo_rasterizer::Camera;
use std::path::{Path, PathBuf};

/// Longest side of the normalised body (HumanGaussian: 0.6 · 1.1¹⁰).
pub const BODY_EXTENT: f64 = 1.556_245_1;
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
    /// Where the face crop comes from (U8) in the synthetic capture.
    pub face_crop: FaceCropSource,
    /// A user's portrait (PNG or JPEG) in place of the synthetic identities: the body prior is
    /// fitted to its OpenPose keypoints and the face crop cut from it ([`crate::photo`]); a
    /// guidance model (`guidance_model`) is then required and no held-out truth exists.
    pub photo: Option<PathBuf>,
    /// The photo's OpenPose JSON (none: `<stem>_keypoints.json` beside the photo).
    pub photo_keypoints: Option<PathBuf>,
    /// The photo camera's vertical field of view (a 50 mm lens on a full-frame sensor held
    /// upright: 40°).
    pub photo_fovy_degrees: f64,
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
            photo: None,
            photo_keypoints: None,
            photo_fovy_degrees: 40.0,
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
        if self.photo.is_some() && !self.body_fit {
            return Err(
                "data: body_fit = false takes a synthetic identity's true shape; a photo's body \
                 is fitted (keep body_fit = true)"
                    .into(),
            );
        }
        if self.photo.is_none() && self.photo_keypoints.is_some() {
            return Err("data: photo_keypoints without data.photo".into());
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

/// What only the synthetic capture has: the identities (the oracle's data) and their renders
/// from the held-out cameras.
#[derive(Debug, Clone)]
pub struct SyntheticTruth {
    pub bank: IdentityBank,
    /// `[identity][view]` held-out renders in [0, 1], `[3, H, W]`.
    pub eval_targets: Vec<Vec<Vec<f32>>>,
}

/// The portrait capture: the synthetic default, or a user's photo (`data.photo`).
#[derive(Debug, Clone)]
pub struct PortraitCapture {
    pub config: PortraitConfig,
    /// The synthetic identities and the held-out truth (none for a user's photo).
    pub truth: Option<SyntheticTruth>,
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
    /// Where the crop was cut from a portrait photo (`face_crop = "portrait"`, or a user's
    /// photo): the alignment's RMS residual, crop pixels, and the face points it used.
    pub face_alignment: Option<(f64, usize)>,
    pub face_mask: Vec<bool>,
    /// `[S, S]` the canonical body's depth from the face camera (∞ off the body): D_m of U6.
    pub face_depth: Vec<f32>,
    /// Held-out cameras (the prompted identity's renders there are in `truth`).
    pub eval_cameras: Vec<Camera>,
}

/// HumanGaussian's normalisation of a body-space mesh: its bounding box centred at the origin,
/// its longest side [`BODY_EXTENT`].
#[derive(Debug, Clone, Copy)]
struct Normalisation {
    centre: [f32; 3],
    scale: f32,
}

impl Normalisation {
    fn of(vertices: &[[f32; 3]]) -> Self {
        let mut lo = [f32::INFINITY; 3];
        let mut hi = [f32::NEG_INFINITY; 3];
        for p in vertices {
            for c in 0..3 {
                lo[c] = lo[c].min(p[c]);
                hi[c] = hi[c].max(p[c]);
            }
        }
        let longest = (0..3).map(|c| hi[c] - lo[c]).fold(0.0f32, f32::max);
        Self {
            centre: [0, 1, 2].map(|c| 0.5 * (lo[c] + hi[c])),
            scale: BODY_EXTENT as f32 / longest,
        }
    }

    fn apply(&self, p: &[f32; 3]) -> [f32; 3] {
        [0, 1, 2].map(|c| (p[c] - self.centre[c]) * self.scale)
    }
}

/// The body prior in the capture's units and what the face loss sees of it (U7).
struct PriorView {
    normalisation: Normalisation,
    canonical: Vec<[f32; 3]>,
    head_height: f64,
    face_camera: Camera,
    face_mask: Vec<bool>,
    face_depth: Vec<f32>,
}

impl PriorView {
    /// `avatar` of shape `betas` in the canonical pose, normalised; the face camera looks at
    /// the face region's centroid from d_f along +z.
    fn new(
        config: &PortraitConfig,
        avatar: &AvatarBody,
        betas: &[f64],
        device: &Device,
    ) -> Result<Self, AagError> {
        let prior = avatar.posed(betas, &config.canonical.axis_angle(), device);
        let normalisation = Normalisation::of(&prior.vertices);
        let canonical: Vec<[f32; 3]> = prior
            .vertices
            .iter()
            .map(|p| normalisation.apply(p))
            .collect();
        let head_height = f64::from(normalisation.apply(&prior.joints[HEAD_JOINT])[1]);
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
        let face_camera = orbit_camera(
            centroid.map(|c| c / count),
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
            &RenderSettings {
                background: [0.0; 3],
                supersample: 1,
            },
        );
        Ok(Self {
            normalisation,
            head_height,
            face_camera,
            face_mask: mask_render.color.iter().map(|c| c[0] > 0.5).collect(),
            face_depth: mask_render.depth,
            canonical,
        })
    }

    /// The face crop keeps the body's silhouette from the face camera.
    fn silhouette(&self) -> Vec<bool> {
        self.face_depth.iter().map(|d| d.is_finite()).collect()
    }

    /// The face camera's pixels of `avatar`'s [`ALIGNMENT_LANDMARKS`] on the canonical body.
    fn face_points(&self, avatar: &AvatarBody) -> [Option<[f64; 2]>; 5] {
        let face_pinhole = pinhole(&self.face_camera);
        ALIGNMENT_LANDMARKS.map(|name| {
            avatar
                .landmark(name)
                .and_then(|v| face_pinhole.project(self.canonical[v as usize].map(f64::from)))
        })
    }
}

/// The held-out cameras: `eval_azimuths` at each of `eval_elevations`, offset by half a step
/// from the training azimuth grid's edges.
fn eval_cameras(config: &PortraitConfig) -> Vec<Camera> {
    let mut cameras = Vec::new();
    for &el in &config.eval_elevations {
        for a in 0..config.eval_azimuths {
            let az = -180.0 + 360.0 * (a as f64 + 0.5) / config.eval_azimuths as f64;
            cameras.push(orbit_camera(
                [0.0; 3],
                az,
                el,
                config.eval_distance,
                config.eval_fovy_degrees,
                config.eval_size,
            ));
        }
    }
    cameras
}

impl PortraitCapture {
    /// Identity `label`'s mesh posed by the 72-D SMPL `pose` (no translation), in the
    /// capture's normalised units; none without the synthetic identities.
    pub fn posed_vertices(
        &self,
        label: usize,
        pose: &[f64; 72],
        device: &Device,
    ) -> Option<Vec<[f32; 3]>> {
        let betas = &self.truth.as_ref()?.bank.identities[label].identity.betas;
        Some(self.normalised(&posed_once(betas, pose, device).vertices))
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

    /// The synthetic capture, or the user's photo's where `data.photo` names one.
    pub fn build(config: &PortraitConfig, device: &Device) -> Result<Self, AagError> {
        config.validate().map_err(|m| AagError::input("data", m))?;
        let avatar = AvatarBody::load(config.body_model.as_deref(), config.body_marks.as_deref())?;
        match &config.photo {
            Some(path) => Self::from_photo(config, avatar, path, device),
            None => Self::synthetic(config, avatar, device),
        }
    }

    /// A user's photo: the body prior fitted to its keypoints, the face crop cut from it; no
    /// identities, no held-out truth.
    fn from_photo(
        config: &PortraitConfig,
        avatar: AvatarBody,
        path: &Path,
        device: &Device,
    ) -> Result<Self, AagError> {
        let photo = Photo::read(
            path,
            config.photo_keypoints.as_deref(),
            config.photo_fovy_degrees,
        )?;
        let fit = photo.fit(&avatar, device)?;
        let view = PriorView::new(config, &avatar, &fit.betas, device)?;
        let cropped = crop_from_portrait(
            &photo.image,
            photo.width as usize,
            photo.height as usize,
            &photo.face_points(FitConfig::default().min_confidence),
            &view.face_points(&avatar),
            config.face_size as usize,
            &view.silhouette(),
        )
        .map_err(|e| {
            AagError::input(
                photo.keypoints_path.display().to_string(),
                format!("face_keypoints_2d: {e}"),
            )
        })?;
        Ok(Self::assemble(
            config,
            None,
            avatar,
            view,
            fit.betas.clone(),
            Some(fit),
            (cropped.crop, Some((cropped.residual_px, cropped.points))),
        ))
    }

    /// The embedded default: K identities from the seed, the prompted one's portrait fitted
    /// (or its true shape), the face crop rendered or cut from its portrait.
    fn synthetic(
        config: &PortraitConfig,
        avatar: AvatarBody,
        device: &Device,
    ) -> Result<Self, AagError> {
        let pose = config.canonical.axis_angle();
        let identities: Vec<Identity> = (0..config.identities)
            .map(|k| Identity::sample(config.seed.wrapping_mul(1000).wrapping_add(k as u64)))
            .collect();
        let posed: Vec<Vec<[f32; 3]>> = identities
            .iter()
            .map(|id| posed_once(&id.betas, &pose, device).vertices)
            .collect();
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
        let view = PriorView::new(config, &avatar, &body_betas, device)?;
        let normalisation = view.normalisation;
        let bank = IdentityBank::build(config, &identities, &posed, |p| normalisation.apply(p));
        let face_crop = match config.face_crop {
            FaceCropSource::Render => (
                planar_rgb(&bank.render(config.face_identity, &view.face_camera)),
                None,
            ),
            FaceCropSource::Portrait => {
                let photo_camera = Camera::look_at(
                    normalisation.apply(&PORTRAIT_EYE),
                    normalisation.apply(&PORTRAIT_TARGET),
                    [0.0, 1.0, 0.0],
                    PORTRAIT_FOVY_DEGREES,
                    config.portrait_size,
                    config.portrait_size,
                );
                let cropped =
                    synthetic_portrait_crop(&bank, config, &photo_camera, &avatar, &view)?;
                (cropped.crop, Some((cropped.residual_px, cropped.points)))
            }
        };
        let cameras = eval_cameras(config);
        let eval_targets = (0..config.identities)
            .map(|k| {
                cameras
                    .iter()
                    .map(|c| planar_rgb(&bank.render(k, c)))
                    .collect()
            })
            .collect();
        Ok(Self::assemble(
            config,
            Some(SyntheticTruth { bank, eval_targets }),
            avatar,
            view,
            body_betas,
            body_fit,
            face_crop,
        ))
    }

    fn assemble(
        config: &PortraitConfig,
        truth: Option<SyntheticTruth>,
        body: AvatarBody,
        view: PriorView,
        body_betas: Vec<f64>,
        body_fit: Option<PortraitFit>,
        (face_crop, face_alignment): (Vec<f32>, Option<(f64, usize)>),
    ) -> Self {
        Self {
            config: config.clone(),
            truth,
            body,
            canonical: view.canonical,
            metres_per_unit: 1.0 / f64::from(view.normalisation.scale),
            centre: view.normalisation.centre,
            body_betas,
            body_fit,
            head_height: view.head_height,
            face_camera: view.face_camera,
            face_crop,
            face_alignment,
            face_mask: view.face_mask,
            face_depth: view.face_depth,
            eval_cameras: eval_cameras(config),
        }
    }
}

/// The face identity photographed by `photo_camera` (the portrait), its face points detected
/// with the keypoints' noise, and the crop cut from it by U8 ([`crop_from_portrait`]).
fn synthetic_portrait_crop(
    bank: &IdentityBank,
    config: &PortraitConfig,
    photo_camera: &Camera,
    avatar: &AvatarBody,
    view: &PriorView,
) -> Result<PortraitCrop, AagError> {
    let photo = planar_rgb(&bank.render(config.face_identity, photo_camera));
    let seen = &bank.identities[config.face_identity].vertices;
    let photo_pinhole = pinhole(photo_camera);
    let mut rng = Rng(config.seed ^ 0xFACE);
    let noise = config.keypoint_noise_px;
    let photo_points = ALIGNMENT_LANDMARKS.map(|name| {
        let p = builtin_body()
            .landmark(name)
            .and_then(|v| photo_pinhole.project(seen[v as usize].map(f64::from)))?;
        Some([p[0] + noise * rng.normal(), p[1] + noise * rng.normal()])
    });
    let size = config.portrait_size as usize;
    crop_from_portrait(
        &photo,
        size,
        size,
        &photo_points,
        &view.face_points(avatar),
        config.face_size as usize,
        &view.silhouette(),
    )
}
