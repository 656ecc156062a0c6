//! `train-avatar`'s data. By default from the synthetic generator: the `monocular` preset (a
//! person walking a circle in a room, filmed by a hand-held camera, watched by a fixed one).
//! Frames are split by index: every `holdout_every`-th frame is held out (novel pose, seen by
//! the hand-held camera); the rest train from the hand-held camera, and the fixed camera at
//! some of the training frames is the novel view. Each view carries the dataset's person mask;
//! the prior track is the generator's perturbed motion, the truth its true motion.
//!
//! With `data.path`, a capture in any format with person masks and a pose track
//! ([`super::capture`]); its pixels are decoded on demand through the engine's bounded
//! [`ImageStore`].

use crate::error::TrainError;
use crate::views::dataset::training_depth;
use crate::views::init_points::back_project;
use crate::views::{Frame, ImageSource, ImageStore, InitPoints};
use burn::tensor::{Device, Tensor, TensorData};
use serde::{Deserialize, Serialize};
use splatzoo_datasets::formats::ViewRecord;
use splatzoo_datasets::image_io::linear_to_srgb;
use splatzoo_datasets::pose_sequence::PoseSequence;
use splatzoo_datasets::synth::prior::PriorNoise;
use splatzoo_datasets::synth::scene::{ViewTruth, body_label};
use splatzoo_datasets::synth::{Preset, SceneConfig};
use splatzoo_rasterizer::Camera;
use std::path::PathBuf;

/// Which synthetic capture `train-avatar` makes when no capture folder is given.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum AvatarPreset {
    /// A person walking a circle in a room, a hand-held camera; a fixed corner camera is the
    /// novel view.
    Monocular,
    /// The studio ring: four of its sixteen cameras train, four others are novel views.
    Multiview,
}

/// What the capture is made of.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AvatarDataConfig {
    pub preset: AvatarPreset,
    pub seed: u64,
    pub width: u32,
    pub height: u32,
    pub frames: usize,
    /// Frame `t` is held out when `t % holdout_every == holdout_every − 1`.
    pub holdout_every: usize,
    /// The novel-view cameras at every this-many-th training frame are novel views.
    pub novel_view_every: usize,
    /// Samples per pixel along each axis of the ground-truth renderer.
    pub supersample: usize,
    pub noise: PriorNoise,
    /// A capture folder to train on instead of the synthetic preset.
    pub path: Option<PathBuf>,
    /// Its format (detected when absent).
    pub format: Option<String>,
    /// Which of the capture's people (index into its pose tracks).
    pub person: usize,
    /// Cameras trained on (names as the loader gives them); empty: every camera. The others
    /// at training frames are the novel views.
    pub train_cameras: Vec<String>,
    /// Capture images are box-filtered down by this integer factor.
    pub downscale: u32,
    /// Decoded images kept in memory, MiB.
    pub cache_mib: usize,
}

impl Default for AvatarDataConfig {
    fn default() -> Self {
        Self {
            preset: AvatarPreset::Monocular,
            seed: 0,
            width: 320,
            height: 240,
            frames: 60,
            holdout_every: 5,
            novel_view_every: 4,
            supersample: 2,
            noise: PriorNoise::default(),
            path: None,
            format: None,
            person: 0,
            train_cameras: Vec::new(),
            downscale: 1,
            cache_mib: 4096,
        }
    }
}

/// One image of the capture (its pixels in the capture's store).
pub struct AvatarView {
    pub name: String,
    pub frame: usize,
    pub camera: Camera,
    pub key: usize,
    /// The capture's record this view was read from (`None` for the synthetic preset's
    /// views): its depth map, where it has one ([`AvatarCapture::depth`]).
    pub record: Option<ViewRecord>,
}

/// A view's pixels.
pub struct AvatarFrame {
    /// `[H, W, 3]` sRGB in [0, 1], the whole image.
    pub image: Tensor<3>,
    /// `[H, W]` 1 on the person.
    pub mask: Tensor<2>,
}

impl AvatarFrame {
    /// The image with everything outside the mask replaced by `background` (what a human-only
    /// avatar is trained and scored against, as GauHuman does on masked captures).
    pub fn masked_target(&self, background: &Tensor<1>) -> Tensor<3> {
        let [h, w, _] = self.image.dims();
        let m = self.mask.clone().reshape([h, w, 1]);
        self.image.clone() * m.clone() + background.clone().reshape([1, 1, 3]) * (m * -1.0 + 1.0)
    }
}

pub struct AvatarCapture {
    pub store: ImageStore,
    pub train: Vec<AvatarView>,
    /// Training frames from a camera never trained on.
    pub novel_view: Vec<AvatarView>,
    /// Held-out frames from the training camera.
    pub novel_pose: Vec<AvatarView>,
    /// The pose track training starts from (one row per frame).
    pub prior: PoseSequence,
    /// The true motion, for pose error only (synthetic captures).
    pub truth: Option<PoseSequence>,
    /// Whether `prior` is the true motion itself (a synthetic capture without tracker noise),
    /// which pose refinement would have nothing to correct in ([`super::refinement`]).
    pub track_is_truth: bool,
    /// Per frame: whether it has training images.
    pub trained: Vec<bool>,
    pub fps: f64,
    /// What the loader decided and why.
    pub decisions: Vec<String>,
    /// Points a static background node can start from, and where they came from (the
    /// capture's sparse points, or the synthetic truth's depth outside the person).
    pub scenery_points: InitPoints,
    pub scenery_source: Option<&'static str>,
    /// The factor a capture's images are box-filtered by, and the factor its world is scaled
    /// by so the body keeps its own size ([`crate::views::people`]); 1 for the synthetic preset.
    pub downscale: u32,
    pub world_scale: f64,
}

impl AvatarCapture {
    /// A view's image and person mask (decoded on demand for captures on disk).
    pub fn frame(&self, view: &AvatarView) -> Result<AvatarFrame, TrainError> {
        let Frame { image, person, .. } = self.store.frame(view.key)?;
        let mask = person
            .ok_or_else(|| TrainError::Config(format!("view {}: no person mask", view.name)))?;
        Ok(AvatarFrame { image, mask })
    }

    /// A view's depth map at its training resolution, row-major, in the scaled world's unit
    /// (non-finite where unknown); `None` where the capture gives none.
    pub fn depth(&self, view: &AvatarView) -> Result<Option<Vec<f32>>, TrainError> {
        view_depth(view, self.downscale, self.world_scale)
    }
}

/// `view`'s depth map at `1/downscale` of its capture's size, in the world scaled by
/// `world_scale`; `None` where it has none.
pub(crate) fn view_depth(
    view: &AvatarView,
    downscale: u32,
    world_scale: f64,
) -> Result<Option<Vec<f32>>, TrainError> {
    let Some(record) = &view.record else {
        return Ok(None);
    };
    let scale = world_scale as f32;
    Ok(training_depth(record, downscale)?
        .map(|depth| depth.into_iter().map(|d| d * scale).collect()))
}

/// Back-projects every 8th pixel of a rendered view's depth outside the person (an RGB-D
/// stand-in for SfM points of the surroundings).
fn scenery_depth(truth: &ViewTruth, points: &mut InitPoints) {
    let r = &truth.render;
    let body = body_label(0);
    let depth: Vec<f32> = r
        .depth
        .iter()
        .zip(&r.label)
        .map(|(&d, &l)| if l == body { f32::NAN } else { d })
        .collect();
    let srgb: Vec<f32> = r.color.iter().flat_map(|c| c.map(linear_to_srgb)).collect();
    back_project(&truth.camera, &depth, &srgb, 8, points);
}

fn view(truth: &ViewTruth, name: String, store: &mut ImageStore, device: &Device) -> AvatarView {
    let r = &truth.render;
    let (h, w) = (r.height, r.width);
    let srgb: Vec<f32> = r.color.iter().flat_map(|c| c.map(linear_to_srgb)).collect();
    let body = body_label(0);
    let mask: Vec<f32> = r.label.iter().map(|&l| f32::from(l == body)).collect();
    let key = store.push(ImageSource::Memory(Box::new(Frame {
        image: Tensor::from_data(TensorData::new(srgb, [h, w, 3]), device),
        person: Some(Tensor::from_data(TensorData::new(mask, [h, w]), device)),
        valid: None,
    })));
    AvatarView {
        name,
        frame: truth.frame,
        camera: truth.camera,
        key,
        record: None,
    }
}

impl AvatarDataConfig {
    pub fn is_held_out(&self, frame: usize) -> bool {
        frame % self.holdout_every == self.holdout_every - 1
    }

    /// The synthetic scene's camera tracks that train and those that are novel views.
    fn synthetic_tracks(&self) -> (Vec<usize>, Vec<usize>) {
        match self.preset {
            AvatarPreset::Monocular => (vec![0], vec![1]),
            // GauHuman's ZJU-MoCap protocol: four evenly spaced training cameras.
            AvatarPreset::Multiview => (vec![0, 4, 8, 12], vec![2, 6, 10, 14]),
        }
    }

    /// Builds and renders the synthetic capture (the slow part: every frame, every camera
    /// used).
    pub fn build(&self, device: &Device) -> AvatarCapture {
        let mut store = ImageStore::new(self.cache_mib, device);
        let preset = match self.preset {
            AvatarPreset::Monocular => Preset::Monocular,
            AvatarPreset::Multiview => Preset::Multiview,
        };
        let scene = SceneConfig {
            width: self.width,
            height: self.height,
            frames: Some(self.frames),
            noise: self.noise,
            supersample: self.supersample,
            ..SceneConfig::new(preset, self.seed)
        }
        .build(device);
        let person = &scene.people[0];
        let frames = scene.frame_count;
        let (train_tracks, novel_tracks) = self.synthetic_tracks();
        let trained: Vec<bool> = (0..frames).map(|t| !self.is_held_out(t)).collect();
        let (mut train, mut novel_view, mut novel_pose) = (Vec::new(), Vec::new(), Vec::new());
        let mut trained_seen = 0;
        let mut scenery_points = InitPoints::default();
        for (t, &is_trained) in trained.iter().enumerate() {
            let wants_novel = is_trained && trained_seen % self.novel_view_every == 0;
            trained_seen += usize::from(is_trained);
            let mut tracks = train_tracks.clone();
            if wants_novel {
                tracks.extend(&novel_tracks);
            }
            // One shadow map for every camera of the frame.
            for truth in scene.render_tracks(t, &tracks, true) {
                if is_trained && train_tracks.contains(&truth.track) && train.len() % 4 == 0 {
                    scenery_depth(&truth, &mut scenery_points);
                }
                let set = if !is_trained {
                    &mut novel_pose
                } else if train_tracks.contains(&truth.track) {
                    &mut train
                } else {
                    &mut novel_view
                };
                let name = format!("{}_{t:04}", scene.tracks[truth.track].name);
                set.push(view(&truth, name, &mut store, device));
            }
        }
        let names = |tracks: &[usize]| {
            tracks
                .iter()
                .map(|&k| scene.tracks[k].name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        };
        AvatarCapture {
            store,
            train,
            novel_view,
            novel_pose,
            prior: person.prior.clone(),
            truth: Some(person.motion.clone()),
            track_is_truth: self.noise == PriorNoise::none(),
            trained,
            fps: scene.fps,
            decisions: vec![
                format!(
                    "synthetic {:?} preset: the generator's perturbed track as the prior",
                    self.preset
                ),
                format!(
                    "training cameras {}; novel views from {}",
                    names(&train_tracks),
                    names(&novel_tracks)
                ),
            ],
            scenery_source: (!scenery_points.is_empty())
                .then_some("the rendered depth outside the person"),
            scenery_points,
            downscale: 1,
            world_scale: 1.0,
        }
    }
}
