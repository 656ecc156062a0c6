//! The synthetic lighting capture (spec §7): the `monocular` room and walking person, re-lit
//! so the paper's claims become measurable, and rendered by the independent CPU mesh renderer
//! with the ground truth the scores need.
//!
//! - **Light** ([`training_lighting`]): a warm point light low near one wall (inverse-square
//!   falloff: the light on the person changes as they walk), a dim ambient term and a sky-like
//!   SH environment (degree 2: exactly representable by the probes). Shadows on.
//! - **Frames**: the hand-held video, every `test_every`-th frame held out. Each frame carries
//!   its sRGB image, the person mask, depth, the albedo buffer, and the same view rendered
//!   without the person (`empty`), so the person's cast shadow is `empty` versus the image on
//!   pixels the person does not cover ([`IllumFrame::shadow_ratio`]).
//! - **Relit frames** ([`relighting`]): the held-out frames under two other lights (the point
//!   light moved across the room and cooled; a coloured environment with no point light).
//! - **Novel poses**: the same identity in a motion never trained on (turning and waving),
//!   seen from the fixed camera, under the training light.
//! - **Probe truth** ([`CaptureTruth::probe_truth`]): the analytic SH radiance at any point
//!   ([`splatzoo_datasets::render::Lighting::radiance_sh`]), unoccluded.
//! - **Room B** ([`Room::B`]): the same identity filmed the same way in another room under
//!   another light ([`room_b_lighting`]), for transfer: a method reconstructs B from B's video,
//!   moves A's human in, and B's own frames are the ground truth of the same person there.
//!
//! A capture on disk takes the synthetic one's place with `data.capture` ([`crate::disk`]): the
//! same video, without the truth ([`IllumCapture::truth`], [`IllumFrame::truth`]).
//!
//! The renderer is linear Lambert; images are sRGB-encoded like a camera's, so a method's
//! linear albedo is `sRGB⁻¹` of what it sees under unit light.

use crate::IllumError;
use burn::tensor::{Device, Tensor, TensorData};
use rayon::prelude::*;
use splatzoo_datasets::image_io::linear_to_srgb;
use splatzoo_datasets::pose_sequence::PoseSequence;
use splatzoo_datasets::render::{Light, Lighting};
use splatzoo_datasets::synth::environment;
use splatzoo_datasets::synth::motion::{Motion, Start, generate};
use splatzoo_datasets::synth::rig::{CameraTrack, Lens, fixed};
use splatzoo_datasets::synth::scene::{Person, standing_height};
use splatzoo_datasets::synth::{Preset, Scene, SceneConfig, ViewTruth};
use splatzoo_rasterizer::Camera;
use splatzoo_train::views::InitPoints;
use splatzoo_train::views::init_points::back_project;
use std::path::PathBuf;

/// Which room the person is filmed in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Room {
    /// The `monocular` preset's room under [`training_lighting`].
    #[default]
    A,
    /// A smaller room with other furniture under [`room_b_lighting`] (the transfer target).
    B,
}

/// The light the person is filmed under.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum CaptureLight {
    /// The room's point light with shadow maps, its ambient term and environment: the person's
    /// shadow falls on the room (the paper's setting).
    #[default]
    Point,
    /// The room's ambient term and environment alone (overcast, diffuse): nothing casts a
    /// shadow, so the capture calls for no shadow decoder ([`crate::needs`]).
    Diffuse,
}

/// The capture's size and split.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct IllumDataConfig {
    pub seed: u64,
    pub room: Room,
    pub light: CaptureLight,
    pub width: u32,
    pub height: u32,
    /// Frames of the hand-held video.
    pub frames: usize,
    /// Every `test_every`-th frame is held out (NeuMan's split is about every 5th).
    pub test_every: usize,
    /// Frames of the novel-pose clip.
    pub novel_pose_frames: usize,
    /// Samples per pixel along each axis.
    pub supersample: usize,
    /// Shadow-map resolution per cube face.
    pub shadow_resolution: usize,
    /// Scene points kept from the back-projected empty views (or a capture's points).
    pub scene_points: usize,
    /// A capture on disk in place of the synthetic one ([`crate::disk`]): any format the
    /// loaders read with person masks and a pose track (NeuMan, ZJU-MoCap, …). The synthetic
    /// fields above but `seed`, `test_every` and `scene_points` are then unused.
    pub capture: Option<PathBuf>,
    /// The capture's format (detected when absent).
    pub format: Option<String>,
    /// The capture's images are box-filtered by this factor.
    pub downscale: u32,
    /// Which of the capture's pose tracks is the person.
    pub person: usize,
    /// The capture's cameras that train (every camera when empty); the others' views at
    /// training frames are held out.
    pub train_cameras: Vec<String>,
}

impl Default for IllumDataConfig {
    fn default() -> Self {
        Self {
            seed: 11,
            room: Room::A,
            light: CaptureLight::Point,
            width: 160,
            height: 120,
            frames: 60,
            test_every: 5,
            novel_pose_frames: 10,
            supersample: 2,
            shadow_resolution: 512,
            scene_points: 30_000,
            capture: None,
            format: None,
            downscale: 1,
            person: 0,
            train_cameras: Vec::new(),
        }
    }
}

impl IllumDataConfig {
    /// Checks every size before anything is rendered.
    pub fn validate(&self) -> Result<(), IllumError> {
        let bad =
            |field: &str, problem: &str| Err(IllumError::input(format!("data.{field}"), problem));
        if self.width < 8 || self.height < 8 {
            return bad("width/height", "must be at least 8 pixels");
        }
        if self.frames < 2 {
            return bad("frames", "must be at least 2 (one trained, one held out)");
        }
        if self.test_every < 2 {
            return bad("test_every", "must be at least 2");
        }
        if self.downscale == 0 {
            return bad("downscale", "must be at least 1");
        }
        if self.supersample == 0 || self.shadow_resolution < 16 {
            return bad("supersample/shadow_resolution", "must be ≥ 1 and ≥ 16");
        }
        Ok(())
    }
}

/// The training light: a warm point light 1.4 m high near the +x wall, dim ambient, and a
/// sky-like environment brighter from above and slightly blue.
pub fn training_lighting(shadow_resolution: usize) -> Lighting {
    let mut environment = [[0.0f32; 3]; 9];
    environment[0] = [0.35, 0.40, 0.50]; // DC: about 0.1–0.14 of uniform radiance
    environment[1] = [-0.10, -0.10, -0.12]; // Y_1,-1 = −C1 y: brighter from +y
    environment[4] = [0.02, 0.02, 0.03];
    Lighting {
        ambient: [0.04; 3],
        environment: Some(environment),
        light: Some(Light::Point {
            position: [2.4, 1.4, 0.6],
            color: [4.2, 3.6, 2.8],
        }),
        shadow_resolution: Some(shadow_resolution),
    }
}

/// Room B's light: a cool lamp high near the −z wall and a warm environment from below-left.
pub fn room_b_lighting(shadow_resolution: usize) -> Lighting {
    let mut environment = [[0.0f32; 3]; 9];
    environment[0] = [0.55, 0.42, 0.30];
    environment[3] = [-0.12, -0.08, -0.04]; // Y_1,1 = −C1 x: warmer from +x
    environment[1] = [0.06, 0.05, 0.04]; // a little brighter from below (a lit floor)
    Lighting {
        ambient: [0.03; 3],
        environment: Some(environment),
        light: Some(Light::Point {
            position: [-0.4, 2.2, -2.3],
            color: [2.6, 3.2, 4.4],
        }),
        shadow_resolution: Some(shadow_resolution),
    }
}

/// The held-out lights: `moved` (the point light across the room near the −x wall, higher
/// and cooler) and `coloured` (no point light; an environment orange from +x, blue from −x).
pub fn relighting(shadow_resolution: usize) -> Vec<(&'static str, Lighting)> {
    let base = training_lighting(shadow_resolution);
    let mut coloured = [[0.0f32; 3]; 9];
    coloured[0] = [1.6, 1.3, 1.3];
    coloured[3] = [-0.55, -0.05, 0.45]; // Y_1,1 = −C1 x: orange from +x, blue from −x
    coloured[1] = [-0.15, -0.15, -0.15];
    vec![
        (
            "moved",
            Lighting {
                light: Some(Light::Point {
                    position: [-2.2, 2.1, -0.8],
                    color: [3.0, 3.4, 4.4],
                }),
                ..base
            },
        ),
        (
            "coloured",
            Lighting {
                ambient: [0.0; 3],
                environment: Some(coloured),
                light: None,
                shadow_resolution: None,
            },
        ),
    ]
}

/// One view of the video: what a method sees, and (synthetic captures) what only the renderer
/// knows.
#[derive(Debug, Clone)]
pub struct IllumFrame {
    /// Frame index within its clip (the row of the body track).
    pub frame: usize,
    pub held_out: bool,
    pub camera: Camera,
    /// `[H, W, 3]` sRGB image.
    pub image: Tensor<3>,
    /// `[H, W]` person mask (1 on the person).
    pub mask: Tensor<2>,
    /// Camera-space depth, row-major, in metres: the renderer's (infinite on the background)
    /// or a capture's depth map; non-finite where unknown.
    pub depth: Vec<f32>,
    /// The person's pixels.
    pub person: Vec<bool>,
    /// `[H, W]` 1 where the pixel is real data (inside an undistorted image); `None` when every
    /// pixel is ([`Self::on_real_pixels`]).
    pub valid: Option<Tensor<2>>,
    /// The renderer's truth of this view; `None` for a capture on disk.
    pub truth: Option<FrameTruth>,
}

/// What the renderer knows of a view beyond its image.
#[derive(Debug, Clone)]
pub struct FrameTruth {
    /// Linear albedo of what each pixel sees.
    pub albedo: Vec<[f32; 3]>,
    /// Linear colour of the view with shadows (what the image encodes).
    pub linear: Vec<[f32; 3]>,
    /// Linear colour of the same view without the person.
    pub empty: Vec<[f32; 3]>,
    /// Depth of the view without the person (the room behind).
    pub empty_depth: Vec<f32>,
}

impl IllumFrame {
    /// `rendered` (on the autodiff device) where this frame's pixels are real data and
    /// `observed` (the frame's image on the same device) elsewhere, so no loss or score counts
    /// the pixels an undistortion left empty.
    pub fn on_real_pixels(&self, rendered: Tensor<3>, observed: Tensor<3>) -> Tensor<3> {
        let Some(valid) = &self.valid else {
            return rendered;
        };
        let [h, w, _] = self.image.dims();
        let v = valid.clone().autodiff().reshape([h, w, 1]);
        rendered * v.clone() + observed.detach() * (v.neg() + 1.0)
    }

    /// The ground-truth occlusion `I_with / I_without` on pixels the person does not cover
    /// (`None` on the person and where the empty view is black); `None` without the
    /// renderer's truth (a capture on disk has no person-free view of each frame).
    pub fn shadow_ratio(&self) -> Option<Vec<Option<f32>>> {
        let truth = self.truth.as_ref()?;
        Some(
            truth
                .linear
                .iter()
                .zip(&truth.empty)
                .zip(&self.person)
                .map(|((with, without), &person)| {
                    let (a, b) = (with.iter().sum::<f32>(), without.iter().sum::<f32>());
                    (!person && b > 1e-4).then(|| a / b)
                })
                .collect(),
        )
    }
}

/// A held-out frame under another light.
#[derive(Debug, Clone)]
pub struct RelitFrame {
    pub light: &'static str,
    pub frame: IllumFrame,
}

/// The whole capture: the video a method trains on and, for the synthetic capture, its truth.
#[derive(Debug, Clone)]
pub struct IllumCapture {
    pub config: IllumDataConfig,
    /// The video, training and held-out frames in order.
    pub frames: Vec<IllumFrame>,
    /// The body track a tracker hands over (one row per frame, metres): the generator's
    /// perturbed prior, or a capture's own fit ([`crate::disk`]).
    pub prior: PoseSequence,
    /// sRGB points the scene starts from.
    pub scene_points: InitPoints,
    /// The room's background colour, sRGB.
    pub background: [f32; 3],
    /// What reading the capture decided, and why (printed at start).
    pub decisions: Vec<String>,
    /// What only the synthetic capture knows; `None` for a capture on disk.
    pub truth: Option<CaptureTruth>,
}

/// The synthetic capture's truth: what the truth scores (albedo, relit, shadow region, novel
/// poses, probes) compare against.
#[derive(Debug, Clone)]
pub struct CaptureTruth {
    /// The scene as rendered (people with their true motion, tracks, the training light).
    pub scene: Scene,
    pub relit: Vec<RelitFrame>,
    pub novel_pose: Vec<IllumFrame>,
    /// The person of the novel-pose clip (its true motion drives evaluation).
    pub novel_person: Person,
}

impl CaptureTruth {
    /// The analytic SH radiance (degree 2) of the training light at `point`, unoccluded.
    pub fn probe_truth(&self, point: [f64; 3]) -> [[f64; 3]; 9] {
        self.scene.lighting.radiance_sh(point)
    }

    /// The motion the capture was rendered with.
    pub fn motion(&self) -> &PoseSequence {
        &self.scene.people[0].motion
    }
}

impl IllumCapture {
    pub fn train_frames(&self) -> impl Iterator<Item = &IllumFrame> {
        self.frames.iter().filter(|f| !f.held_out)
    }

    pub fn test_frames(&self) -> impl Iterator<Item = &IllumFrame> {
        self.frames.iter().filter(|f| f.held_out)
    }
}

fn frame_of(truth: &ViewTruth, empty: &ViewTruth, held_out: bool, device: &Device) -> IllumFrame {
    let r = &truth.render;
    let (w, h) = (r.width, r.height);
    let srgb: Vec<f32> = r
        .color
        .iter()
        .flat_map(|c| c.map(|v| linear_to_srgb(v.clamp(0.0, 1.0))))
        .collect();
    let person = truth.human_mask();
    let mask: Vec<f32> = person.iter().map(|&p| f32::from(u8::from(p))).collect();
    IllumFrame {
        frame: truth.frame,
        held_out,
        camera: truth.camera,
        image: Tensor::from_data(TensorData::new(srgb, [h, w, 3]), device),
        mask: Tensor::from_data(TensorData::new(mask, [h, w]), device),
        depth: r.depth.clone(),
        person,
        valid: None,
        truth: Some(FrameTruth {
            albedo: r.albedo.clone(),
            linear: r.color.clone(),
            empty: empty.render.color.clone(),
            empty_depth: empty.render.depth.clone(),
        }),
    }
}

impl IllumDataConfig {
    /// Builds and renders the synthetic capture, or reads `capture` from disk.
    pub fn build(&self, device: &Device) -> Result<IllumCapture, IllumError> {
        self.validate()?;
        if let Some(path) = &self.capture {
            return crate::disk::read_capture(self, path, device);
        }
        let mut scene = SceneConfig {
            width: self.width,
            height: self.height,
            frames: Some(self.frames),
            supersample: self.supersample,
            shadow_resolution: Some(self.shadow_resolution),
            ..SceneConfig::new(Preset::Monocular, self.seed)
        }
        .build(device);
        match self.room {
            Room::A => scene.lighting = training_lighting(self.shadow_resolution),
            Room::B => {
                scene.environment = environment::room(self.seed ^ 0x0B0B, 6.5, 2.8);
                scene.lighting = room_b_lighting(self.shadow_resolution);
            }
        }
        if self.light == CaptureLight::Diffuse {
            scene.lighting.light = None;
            scene.lighting.shadow_resolution = None;
        }
        let held_out = |t: usize| t % self.test_every == self.test_every - 1;

        let frames: Vec<IllumFrame> = (0..scene.frame_count)
            .into_par_iter()
            .map(|t| {
                let truth = scene.render_view(t, 0, true);
                let empty = scene.render_view(t, 0, false);
                frame_of(&truth, &empty, held_out(t), device)
            })
            .collect();

        let mut relit = Vec::new();
        for (name, lighting) in relighting(self.shadow_resolution) {
            let lit = Scene {
                lighting,
                ..scene.clone()
            };
            let views: Vec<IllumFrame> = (0..lit.frame_count)
                .into_par_iter()
                .filter(|&t| held_out(t))
                .map(|t| {
                    let truth = lit.render_view(t, 0, true);
                    let empty = lit.render_view(t, 0, false);
                    frame_of(&truth, &empty, true, device)
                })
                .collect();
            relit.extend(
                views
                    .into_iter()
                    .map(|frame| RelitFrame { light: name, frame }),
            );
        }

        // The novel-pose clip: the same identity turning and waving where the walk began.
        let identity = scene.people[0].identity.clone();
        let start = scene.people[0].motion.translation(0);
        let clip = generate(
            &[
                Motion::Turn {
                    seconds: 0.5 * self.novel_pose_frames as f64 / scene.fps,
                    angle: 2.0,
                },
                Motion::Wave {
                    seconds: self.novel_pose_frames as f64 / scene.fps,
                },
            ],
            Start {
                position: [start[0], start[2]],
                heading: 0.5,
                standing_height: standing_height(&identity.betas, device),
            },
            scene.fps,
        );
        let novel_person = Person::new(
            identity,
            &clip,
            &[],
            &scene.noise,
            self.seed ^ 0x1E11,
            device,
        );
        let novel_frames = novel_person.motion.frames().min(self.novel_pose_frames);
        let lens = Lens {
            width: self.width,
            height: self.height,
            fov_x_degrees: 55.0,
        };
        let target = glam::DVec3::new(start[0], 0.9, start[2]);
        let novel_scene = Scene {
            frame_count: novel_frames,
            people: vec![novel_person.clone()],
            tracks: vec![CameraTrack {
                name: "novel_pose".into(),
                cameras: fixed(
                    target + glam::DVec3::new(1.6, 0.5, 2.2),
                    target,
                    novel_frames,
                    lens,
                ),
            }],
            ..scene.clone()
        };
        let novel_pose: Vec<IllumFrame> = (0..novel_frames)
            .into_par_iter()
            .map(|t| {
                let truth = novel_scene.render_view(t, 0, true);
                let empty = novel_scene.render_view(t, 0, false);
                frame_of(&truth, &empty, true, device)
            })
            .collect();

        let mut scene_points = InitPoints::default();
        for (frame, truth) in frames
            .iter()
            .filter(|f| !f.held_out)
            .filter_map(|f| Some((f, f.truth.as_ref()?)))
        {
            let srgb: Vec<f32> = truth
                .empty
                .iter()
                .flat_map(|c| c.map(|v| linear_to_srgb(v.clamp(0.0, 1.0))))
                .collect();
            back_project(
                &frame.camera,
                &truth.empty_depth,
                &srgb,
                4,
                &mut scene_points,
            );
        }
        let scene_points = scene_points.thinned(self.scene_points, self.seed ^ 0x1E11_0001);
        let background = scene.environment.background.map(linear_to_srgb);
        let prior = scene.people[0].prior.clone();
        Ok(IllumCapture {
            config: self.clone(),
            frames,
            prior,
            scene_points,
            background,
            decisions: vec![format!(
                "synthetic capture: room {:?} under the {:?} light, {}×{}, {} frames",
                self.room, self.light, self.width, self.height, self.frames
            )],
            truth: Some(CaptureTruth {
                scene,
                relit,
                novel_pose,
                novel_person,
            }),
        })
    }
}
