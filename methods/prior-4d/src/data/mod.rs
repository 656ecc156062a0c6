//! The synthetic Prior-4D capture (spec §7), rendered by the independent CPU mesh renderer from
//! the `monocular` preset's room, person and cameras: three separate videos and an evaluation
//! camera, each with the noisy stand-ins of the external priors the paper runs.
//!
//! - **Scene scan**: the room without the person, from two hand-held loops (1.2 m high around
//!   the room looking in, 1.7 m high near the middle looking out), with a monocular inverse
//!   depth (true inverse depth under an unknown per-image affine map plus 3 % noise) and a
//!   ground mask (the floor's pixels, jittered).
//! - **Human scan**: the same identity standing in the neutral pose, seen all the way round by
//!   a ring in an empty studio, with person masks and a noisy body fit.
//! - **Acting video**: the preset's hand-held camera circling the person as they walk, wave and
//!   stand, with noisy SfM camera poses, a camera-space body prior (the tracker's estimate
//!   under `PriorNoise`, shape error included), jittered person masks and normal maps (true
//!   normals in the camera frame under a random rotation of `normal_noise_degrees` RMS, blurred).
//!   Its BODY_25 keypoints are the true body's points projected, with pixel noise and misses
//!   ([`splatzoo_datasets::synth::keypoints`]), for stage C's keypoint fit.
//! - **Evaluation**: the preset's fixed camera, synchronised, never trained on.
//!
//! Two gaps the paper's challenges come from are built in: an **appearance gap** (each video
//! its own exposure/white-balance gain) and a **scale gap**: the scene scan, the acting cameras
//! and the evaluation camera live in scene units (metres × `scene_scale`, SfM's arbitrary scale)
//! while the body lives in metres, so the true global scale is σ* = `scene_scale` (for a body
//! of the true height).
//! Every person wears the static clothing relief the naked body model lacks; with
//! `pose_clothing` it also moves with the pose (bunching at bent knees, a hem flaring with the
//! stride), which only ΔV_pose can represent.

mod frames;
pub mod given;
pub mod neuman;
pub mod occluder;
pub mod scans;
mod sensors;
pub mod textureless;

pub use sensors::{rest_pelvis, scaled_camera, to_camera_space};

use crate::error::Prior4dError;
use burn::tensor::{Device, Tensor, TensorData};
use glam::DVec3;
use occluder::occluder;
use rayon::prelude::*;
use sensors::{floor_mask, jittered, mask_tensor, noisy_normals, perturbed, true_normals};
use serde::{Deserialize, Serialize};
use splatzoo_datasets::image_io::linear_to_srgb;
use splatzoo_datasets::masks::Mask;
use splatzoo_datasets::pose_sequence::PoseSequence;
use splatzoo_datasets::synth::environment::Environment;
use splatzoo_datasets::synth::keypoints::{DetectorNoise, detect, pinhole};
use splatzoo_datasets::synth::motion::{Motion, Start, generate};
use splatzoo_datasets::synth::prior::PriorNoise;
use splatzoo_datasets::synth::rig::{CameraTrack, ring};
use splatzoo_datasets::synth::rng::Rng;
use splatzoo_datasets::synth::scene::{Person, standing_height};
use splatzoo_datasets::synth::{Preset, Scene, SceneConfig, ViewTruth};
use splatzoo_models::body::builtin_body;
use splatzoo_models::body::fit::body25_targets;
use splatzoo_rasterizer::Camera;
use splatzoo_train::views::InitPoints;
use splatzoo_train::views::init_points::back_project;
use std::path::PathBuf;
use textureless::textureless_panels;

/// Every knob of the synthetic capture.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Prior4dDataConfig {
    pub seed: u64,
    /// Image size of every video.
    pub width: u32,
    pub height: u32,
    /// Acting-video frames at 10 Hz.
    pub acting_frames: usize,
    /// Scene-scan views, half on each loop.
    pub scene_views: usize,
    /// Human-scan views around the person.
    pub scan_views: usize,
    /// Most starting points of the scene prior (a random subset of the back-projected scan).
    pub scene_points: usize,
    /// Scene units per metre: the scene scan, the acting and evaluation cameras are metres ×
    /// this (SfM's arbitrary scale); σ* for a body of the true height.
    pub scene_scale: f64,
    /// Linear RGB gains of the scan videos and of the acting and evaluation videos.
    pub scan_gain: [f32; 3],
    pub acting_gain: [f32; 3],
    /// The body tracker's errors on the scans and the acting video.
    pub noise: PriorNoise,
    /// SfM errors of the acting cameras: rotation (degrees) and centre (metres, × scale).
    pub camera_rotation_noise_degrees: f64,
    pub camera_translation_noise: f64,
    /// RMS rotation of the given normal maps (degrees).
    pub normal_noise_degrees: f64,
    /// The acting video's 2-D keypoints (BODY_25): pixel noise of each coordinate and the
    /// share of visible points missed (spec §3: 2 px, 5 %).
    pub keypoint_noise_px: f64,
    pub keypoint_miss_rate: f64,
    /// Person and ground masks are dilated or eroded by up to this many pixels.
    pub mask_jitter: usize,
    /// Samples per pixel along each axis.
    pub supersample: usize,
    /// A cabinet in front of where the person stops, hiding her legs from the acting camera
    /// (part of the room, so in every video).
    pub occluder: bool,
    /// Clothing that also moves with the pose (trousers bunching at bent knees, the jacket hem
    /// flaring with the stride: `splatzoo_datasets::synth::clothing::pose_relief`), what
    /// ΔV_pose is for (spec §7's clothing signal).
    pub pose_clothing: bool,
    /// Plainly painted panels over the walls behind the person in the evaluation view (spec
    /// §7's textureless wall: [`textureless::textureless_panels`]).
    pub textureless_wall: bool,
    /// A real capture to read instead of rendering the synthetic one: a NeuMan scene folder
    /// ([`neuman`]), read at `width` wide with `scene_points` and `seed`; the other knobs are
    /// the synthetic capture's.
    pub capture: Option<PathBuf>,
    /// On a real capture without a test split: every this many frames is held out for scoring.
    pub held_out_every: usize,
    /// On a real capture: keep its fit's shape coefficients (they mean the built-in body's own
    /// only if that is the body it was fitted with).
    pub capture_betas: bool,
    /// On a real capture: its scene scan and human scan ([`scans`]); without them the priors
    /// come from the acting video.
    pub scene_scan: Option<PathBuf>,
    pub human_scan: Option<PathBuf>,
}

impl Default for Prior4dDataConfig {
    fn default() -> Self {
        Self {
            seed: 0,
            width: 200,
            height: 150,
            acting_frames: 60,
            scene_views: 96,
            scan_views: 36,
            scene_points: 30_000,
            scene_scale: 0.7,
            scan_gain: [1.15, 1.08, 0.95],
            acting_gain: [1.0; 3],
            noise: PriorNoise::default(),
            camera_rotation_noise_degrees: 0.3,
            camera_translation_noise: 0.01,
            normal_noise_degrees: 8.0,
            keypoint_noise_px: 2.0,
            keypoint_miss_rate: 0.05,
            mask_jitter: 1,
            supersample: 2,
            occluder: false,
            pose_clothing: false,
            textureless_wall: false,
            capture: None,
            held_out_every: 8,
            capture_betas: false,
            scene_scan: None,
            human_scan: None,
        }
    }
}

impl Prior4dDataConfig {
    pub fn validate(&self) -> Result<(), String> {
        if self.width < 16 || self.height < 16 {
            return Err(format!(
                "data.width and data.height ≥ 16, got {}×{}",
                self.width, self.height
            ));
        }
        if self.acting_frames < 2 || self.scene_views < 4 || self.scan_views < 4 {
            return Err("data: acting_frames ≥ 2, scene_views ≥ 4 and scan_views ≥ 4".into());
        }
        if !(self.scene_scale.is_finite() && self.scene_scale > 0.0) {
            return Err(format!("data.scene_scale > 0, got {}", self.scene_scale));
        }
        let scans = self.scene_scan.is_some() || self.human_scan.is_some();
        if scans && self.capture.is_none() {
            return Err(
                "data.scene_scan and data.human_scan are a real capture's: give data.capture too"
                    .into(),
            );
        }
        if self.held_out_every < 2 {
            return Err(format!(
                "data.held_out_every ≥ 2, got {}",
                self.held_out_every
            ));
        }
        if self.supersample == 0 {
            return Err("data.supersample ≥ 1".into());
        }
        let keypoints_ok = self.keypoint_noise_px.is_finite()
            && self.keypoint_noise_px >= 0.0
            && (0.0..1.0).contains(&self.keypoint_miss_rate);
        if !keypoints_ok {
            return Err(format!(
                "data.keypoint_noise_px ≥ 0 and data.keypoint_miss_rate in [0, 1), got {} and {}",
                self.keypoint_noise_px, self.keypoint_miss_rate
            ));
        }
        Ok(())
    }
}

impl Prior4dDataConfig {
    /// The acting video's BODY_25 keypoints from the true posed body (its own random stream,
    /// so the other sensors' noise is the same with or without them).
    fn keypoints(&self, person: &Person, cameras: &[Camera]) -> Vec<Vec<[f32; 3]>> {
        let targets = body25_targets(|n| builtin_body().landmark(n));
        let noise = DetectorNoise {
            pixel_sigma: self.keypoint_noise_px,
            miss_rate: self.keypoint_miss_rate,
        };
        let mut rng = Rng(self.seed ^ 0x4B50_0000);
        cameras
            .iter()
            .zip(&person.frames)
            .map(|(camera, frame)| {
                let image = Some([camera.width, camera.height]);
                detect(frame, &targets, &pinhole(camera), image, &noise, &mut rng)
                    .into_iter()
                    .map(|p| p.map_or([0.0; 3], |p| [p[0] as f32, p[1] as f32, 0.9]))
                    .collect()
            })
            .collect()
    }
}

/// One scene-scan view.
pub struct SceneScanView {
    /// In scene units.
    pub camera: Camera,
    /// `[H, W, 3]` sRGB.
    pub image: Tensor<3>,
    /// `[H, W]` the monocular inverse depth (an unknown affine map of the true one, noisy).
    pub mono_inverse_depth: Tensor<2>,
    /// True camera-space depth (scene units, ∞ on the background): the sparse points the
    /// monocular depth's affine map is fitted to are sampled from it.
    pub depth: Vec<f32>,
    pub ground: Mask,
    /// `[H, W]` 0/1 pixels the scene is not trained on: the person, where the views are the
    /// acting video's ([`crate::sources`]); `None` on the scan, which shows no one.
    pub person: Option<Tensor<2>>,
}

/// One human-scan view.
pub struct HumanScanView {
    pub camera: Camera,
    pub image: Tensor<3>,
    /// `[H, W]` 0/1 person mask.
    pub mask: Tensor<2>,
}

/// One acting frame.
pub struct ActingFrame {
    /// The SfM estimate of the camera, in scene units.
    pub camera: Camera,
    pub image: Tensor<3>,
    /// `[H, W]` 0/1 person mask.
    pub mask: Tensor<2>,
    /// `[H, W, 3]` the given normal map, camera frame (OpenCV axes), zero off the person;
    /// `None` where the capture gives none (the normal term then has nothing to compare with).
    pub normals: Option<Tensor<3>>,
    /// Kept for scoring: no stage trains on its image (a real capture's held-out frames, which
    /// [`EvalFrame::acting_frame`] points at; none on the synthetic capture, which has its own
    /// evaluation camera). Stage D still places the body there, from the prior.
    pub held_out: bool,
    /// The floor's pixels outside the person mask, jittered, its monocular inverse depth (0 on
    /// the person) and true depth (∞ on the person), as the scan views have them: read only
    /// when the scene prior comes from this video ([`crate::sources`]).
    pub ground: Mask,
    pub mono_inverse_depth: Tensor<2>,
    pub depth: Vec<f32>,
}

/// One evaluation frame (never trained on).
pub struct EvalFrame {
    /// The acting frame whose body and (refined) camera place the person in this view: the
    /// synchronised frame on the synthetic capture, the held-out frame itself on a real one.
    pub acting_frame: usize,
    pub camera: Camera,
    pub image: Tensor<3>,
    /// The person mask: the true one on the synthetic capture, the given one on a real one.
    pub mask: Mask,
    /// True camera-frame normals (zero off the person), where the capture knows them.
    pub normals: Option<Vec<[f32; 3]>>,
}

/// What only the synthetic capture knows, for the scores (`None` on a real capture, whose
/// scores then leave out σ*, the camera error, MPJPE and the floor penetration).
pub struct CaptureTruth {
    /// The true acting cameras, scene units.
    pub acting_cameras: Vec<Camera>,
    /// The acting video's true body motion, each frame in its true camera's frame (metres).
    pub acting_motion: PoseSequence,
    /// The person's true shape.
    pub betas: Vec<f64>,
    /// Scene units per metre (σ* for a body of the true height); the true floor is `y = 0`.
    pub scale: f64,
}

/// Where the acting video's cameras come from: what decides whether stage D refines them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CameraSource {
    /// A calibrated rig or tracking system: exact up to noise far below a pixel.
    Calibrated,
    /// Registered by SfM into the scene scan's frame: off by a fraction of a degree and a
    /// centimetre or so, which stage D corrects.
    Estimated,
}

pub struct Prior4dCapture {
    pub scene_scan: Vec<SceneScanView>,
    /// Back-projected from the scan's true depth, scene units (the SfM points' stand-in).
    pub scene_points: InitPoints,
    /// The same from the acting video alone: its true depth outside the given person masks,
    /// back-projected through the given (SfM) cameras and thinned to as many points (what SfM
    /// on that video would give; read only when the scene prior comes from it).
    pub acting_points: InitPoints,
    /// sRGB.
    pub scene_background: [f32; 3],
    pub human_scan: Vec<HumanScanView>,
    /// The scan's body fit, world metres, one frame per view.
    pub scan_prior: PoseSequence,
    pub scan_background: [f32; 3],
    pub acting: Vec<ActingFrame>,
    /// Where `acting`'s cameras come from (the synthetic capture: estimated unless both of its
    /// camera-noise knobs are 0).
    pub acting_cameras: CameraSource,
    /// The acting video's body prior in each frame's camera frame (metres).
    pub acting_prior: PoseSequence,
    /// BODY_25 keypoints `[x, y, confidence]` of every acting frame (`[0, 0, 0]` where the
    /// detector missed the point or it is off the image); empty where the capture gives none.
    pub acting_keypoints: Vec<Vec<[f32; 3]>>,
    pub eval: Vec<EvalFrame>,
    pub truth: Option<CaptureTruth>,
    pub fps: f64,
    pub decisions: Vec<String>,
}

impl Prior4dCapture {
    /// The acting frames the stages train on: all but the held-out ones.
    pub fn trained_frames(&self) -> impl Iterator<Item = &ActingFrame> {
        self.acting.iter().filter(|frame| !frame.held_out)
    }

    /// Their indices.
    pub fn trained_indices(&self) -> Vec<usize> {
        (0..self.acting.len())
            .filter(|&t| !self.acting[t].held_out)
            .collect()
    }
}

fn srgb(view: &ViewTruth, gain: [f32; 3]) -> Vec<f32> {
    view.render
        .color
        .iter()
        .flat_map(|c| [0, 1, 2].map(|k| linear_to_srgb((c[k] * gain[k]).clamp(0.0, 1.0))))
        .collect()
}

/// A monocular depth network's stand-in: the true inverse depth under a random affine map, with
/// 3 % noise; 0 where `depth` is not finite and positive.
fn monocular_inverse_depth(depth: &[f32], rng: &mut Rng) -> Vec<f32> {
    let (a, b) = (rng.range(0.5, 2.0), rng.range(0.0, 0.2));
    depth
        .iter()
        .map(|&d| {
            if d.is_finite() && d > 0.0 {
                ((a / f64::from(d) + b) * (1.0 + 0.03 * rng.normal())) as f32
            } else {
                0.0
            }
        })
        .collect()
}

fn image_tensor(values: Vec<f32>, w: usize, h: usize, device: &Device) -> Tensor<3> {
    Tensor::from_data(TensorData::new(values, [h, w, 3]), device)
}

/// The scene scan's cameras: half on a 2.8 m loop at 1.2 m looking in across the room, half on
/// a 0.8 m loop at 1.7 m looking out at the walls, each aim jittered.
fn scan_loops(views: usize, fov_x_degrees: f32, w: u32, h: u32, rng: &mut Rng) -> Vec<Camera> {
    let inner = views / 2;
    (0..views)
        .map(|k| {
            let outer = k >= inner;
            let (n, i) = if outer {
                (views - inner, k - inner)
            } else {
                (inner, k)
            };
            let angle =
                std::f64::consts::TAU * (i as f64 + 0.5 * f64::from(u8::from(outer))) / n as f64;
            let (radius, height, look) = if outer {
                (0.8, 1.7, 3.5)
            } else {
                (2.8, 1.2, -1.5)
            };
            let position = [radius * angle.sin(), height, radius * angle.cos()];
            let target = [
                look * angle.sin() + rng.range(-0.2, 0.2),
                if outer { 1.0 } else { 0.5 } + rng.range(-0.2, 0.2),
                look * angle.cos() + rng.range(-0.2, 0.2),
            ];
            Camera::look_at(
                position.map(|v| v as f32),
                target.map(|v| v as f32),
                [0.0, 1.0, 0.0],
                fov_x_degrees,
                w,
                h,
            )
        })
        .collect()
}

impl Prior4dDataConfig {
    /// Builds and renders the capture.
    pub fn build(&self, device: &Device) -> Result<Prior4dCapture, Prior4dError> {
        self.validate()
            .map_err(|problem| Prior4dError::input("data", problem))?;
        if let Some(root) = &self.capture {
            return neuman::read_neuman(root, self, device);
        }
        let (w, h) = (self.width as usize, self.height as usize);
        let model = &builtin_body().model;
        let mut rng = Rng(self.seed ^ 0x9414_0000);
        let mut acting_scene = SceneConfig {
            width: self.width,
            height: self.height,
            frames: Some(self.acting_frames),
            noise: self.noise,
            supersample: self.supersample,
            clothing_relief: true,
            ..SceneConfig::new(Preset::Monocular, self.seed)
        }
        .build(device);
        acting_scene.people[0].clothed = true;
        acting_scene.people[0].pose_clothing = self.pose_clothing;
        let fps = acting_scene.fps;
        let lens_camera = acting_scene.tracks[0].cameras[0];
        let fov = 2.0
            * (0.5 * self.width as f32 / lens_camera.fx)
                .atan()
                .to_degrees();
        if self.occluder {
            let cabinet = occluder(
                &acting_scene.people[0].motion,
                &acting_scene.tracks[0].cameras,
                self.seed,
            );
            acting_scene.environment.props.push(cabinet);
        }
        if self.textureless_wall {
            let fixed = acting_scene.tracks[1].cameras[0];
            let panels = textureless_panels(&acting_scene.environment, &fixed);
            if panels.is_empty() {
                return Err(Prior4dError::input(
                    "data.textureless_wall",
                    "the room has no wall ahead of the evaluation camera",
                ));
            }
            acting_scene.environment.props.extend(panels);
        }

        // The scene scan: the room without the person.
        let scan_cameras = scan_loops(self.scene_views, fov, self.width, self.height, &mut rng);
        let scene_scan_scene = Scene {
            frame_count: scan_cameras.len(),
            tracks: vec![CameraTrack {
                name: "scene_scan".into(),
                cameras: scan_cameras,
            }],
            ..acting_scene.clone()
        };
        let scale = self.scene_scale;
        let scene_truths: Vec<ViewTruth> = (0..self.scene_views)
            .into_par_iter()
            .map(|k| scene_scan_scene.render_view(k, 0, false))
            .collect();
        let mut scene_points = InitPoints::default();
        let mut scene_scan = Vec::with_capacity(scene_truths.len());
        for truth in &scene_truths {
            let image = srgb(truth, self.scan_gain);
            let camera = scaled_camera(&truth.camera, scale);
            let depth: Vec<f32> = truth
                .render
                .depth
                .iter()
                .map(|&d| (f64::from(d) * scale) as f32)
                .collect();
            back_project(&camera, &depth, &image, 4, &mut scene_points);
            let mono = monocular_inverse_depth(&depth, &mut rng);
            scene_scan.push(SceneScanView {
                camera,
                image: image_tensor(image, w, h, device),
                mono_inverse_depth: Tensor::from_data(TensorData::new(mono, [h, w]), device),
                depth,
                ground: jittered(floor_mask(truth), self.mask_jitter, &mut rng),
                person: None,
            });
        }
        let scene_points = scene_points.thinned(self.scene_points, self.seed ^ 0x9414_0001);
        let scene_background = acting_scene.environment.background.map(linear_to_srgb);

        // The human scan: the same identity standing still, a ring of cameras, an empty studio.
        let identity = acting_scene.people[0].identity.clone();
        let true_betas = identity.betas.clone();
        let standing = generate(
            &[Motion::Idle {
                seconds: self.scan_views as f64 / fps,
            }],
            Start {
                position: [0.0, 0.0],
                heading: 0.0,
                standing_height: standing_height(&identity.betas, device),
            },
            fps,
        );
        let mut scanned = Person::new(
            identity,
            &standing,
            &[],
            &self.noise,
            self.seed ^ 0x5CA7,
            device,
        );
        scanned.clothed = true;
        scanned.pose_clothing = self.pose_clothing;
        let scan_frames = scanned.motion.frames().min(self.scan_views);
        let human_scan_scene = Scene {
            frame_count: scan_frames,
            environment: Environment::default(),
            people: vec![scanned],
            tracks: vec![CameraTrack {
                name: "human_scan".into(),
                cameras: ring(
                    scan_frames,
                    2.2,
                    -8.0,
                    DVec3::new(0.0, 0.9, 0.0),
                    splatzoo_datasets::synth::rig::Lens {
                        width: self.width,
                        height: self.height,
                        fov_x_degrees: 50.0,
                    },
                ),
            }],
            ..acting_scene.clone()
        };
        let scan_truths: Vec<ViewTruth> = (0..scan_frames)
            .into_par_iter()
            .map(|k| human_scan_scene.render_view(k, 0, true))
            .collect();
        let human_scan = scan_truths
            .iter()
            .map(|truth| HumanScanView {
                camera: truth.camera,
                image: image_tensor(srgb(truth, self.scan_gain), w, h, device),
                mask: mask_tensor(
                    &jittered(
                        Mask::new(w, h, truth.human_mask()),
                        self.mask_jitter,
                        &mut rng,
                    ),
                    device,
                ),
            })
            .collect();
        let scan_prior = human_scan_scene.people[0].prior.clone();
        let scan_background = human_scan_scene.environment.background.map(linear_to_srgb);

        // The acting video and the evaluation camera, frame by frame.
        let mut acting = Vec::with_capacity(self.acting_frames);
        let mut acting_points = InitPoints::default();
        // Its own stream: the acting video's ground masks and monocular depth leave the rest of
        // the capture as it was.
        let mut acting_scene_rng = Rng(self.seed ^ 0x9414_0003);
        let mut eval = Vec::with_capacity(self.acting_frames);
        let mut true_cameras = Vec::with_capacity(self.acting_frames);
        for t in 0..acting_scene.frame_count {
            let mut truths = acting_scene.render_tracks(t, &[0, 1], true).into_iter();
            let (act, fixed) = (
                truths.next().expect("the hand-held view"),
                truths.next().expect("the fixed view"),
            );
            let person = jittered(
                Mask::new(w, h, act.human_mask()),
                self.mask_jitter,
                &mut rng,
            );
            let normals =
                noisy_normals(&act, &act.human_mask(), self.normal_noise_degrees, &mut rng);
            let true_camera = scaled_camera(&act.camera, scale);
            let camera = perturbed(
                &true_camera,
                self.camera_rotation_noise_degrees,
                self.camera_translation_noise * scale,
                &mut rng,
            );
            let image = srgb(&act, self.acting_gain);
            let surroundings: Vec<f32> = act
                .render
                .depth
                .iter()
                .zip(&person.data)
                .map(|(&d, &p)| {
                    if p {
                        f32::INFINITY
                    } else {
                        (f64::from(d) * scale) as f32
                    }
                })
                .collect();
            back_project(&camera, &surroundings, &image, 4, &mut acting_points);
            let mono = monocular_inverse_depth(&surroundings, &mut acting_scene_rng);
            let floor = floor_mask(&act);
            let ground = Mask::new(
                w,
                h,
                floor
                    .data
                    .iter()
                    .zip(&person.data)
                    .map(|(&f, &p)| f && !p)
                    .collect(),
            );
            true_cameras.push(true_camera);
            acting.push(ActingFrame {
                camera,
                image: image_tensor(image, w, h, device),
                mask: mask_tensor(&person, device),
                normals: Some(Tensor::from_data(
                    TensorData::new(normals, [h, w, 3]),
                    device,
                )),
                held_out: false,
                ground: jittered(ground, self.mask_jitter, &mut acting_scene_rng),
                mono_inverse_depth: Tensor::from_data(TensorData::new(mono, [h, w]), device),
                depth: surroundings,
            });
            let eval_mask = Mask::new(w, h, fixed.human_mask());
            eval.push(EvalFrame {
                acting_frame: t,
                camera: scaled_camera(&fixed.camera, scale),
                image: image_tensor(srgb(&fixed, self.acting_gain), w, h, device),
                normals: Some(true_normals(&fixed, &eval_mask)),
                mask: eval_mask,
            });
        }
        let acting_points = acting_points.thinned(self.scene_points, self.seed ^ 0x9414_0002);
        let metre_cameras = &acting_scene.tracks[0].cameras;
        let person = &acting_scene.people[0];
        let acting_prior = to_camera_space(&person.prior, metre_cameras, model);
        let acting_truth = to_camera_space(&person.motion, metre_cameras, model);
        let acting_keypoints = self.keypoints(person, metre_cameras);
        let decisions = vec![format!(
            "synthetic Prior-4D capture, seed {}: scene scan {} views, human scan {} views, \
             acting video {} frames{} + a fixed evaluation camera, {}×{}; scene \
             units of 1/{} m (σ* = {}), scan gain {:?}, acting gain {:?}",
            self.seed,
            scene_scan.len(),
            scan_frames,
            acting.len(),
            if self.occluder {
                " (a cabinet hiding the person's legs where she stops)"
            } else {
                ""
            },
            self.width,
            self.height,
            scale,
            scale,
            self.scan_gain,
            self.acting_gain
        )];
        Ok(Prior4dCapture {
            scene_scan,
            scene_points,
            acting_points,
            scene_background,
            human_scan,
            scan_prior,
            scan_background,
            acting,
            acting_cameras: if self.camera_rotation_noise_degrees == 0.0
                && self.camera_translation_noise == 0.0
            {
                CameraSource::Calibrated
            } else {
                CameraSource::Estimated
            },
            acting_prior,
            acting_keypoints,
            eval,
            truth: Some(CaptureTruth {
                acting_cameras: true_cameras,
                acting_motion: acting_truth,
                betas: true_betas,
                scale,
            }),
            fps,
            decisions,
        })
    }
}
