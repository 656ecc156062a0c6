//! `train-avatar`'s data from the synthetic generator: the `monocular` preset (a person walking
//! a circle in a room, filmed by a hand-held camera, watched by a fixed one). Frames are split
//! by index: every `holdout_every`-th frame is held out (novel pose, seen by the hand-held
//! camera); the rest train from the hand-held camera, and the fixed camera at some of the
//! training frames is the novel view. Each view carries the dataset's person mask; the prior
//! track is the generator's perturbed motion, the truth its true motion.

use burn::tensor::{Device, Tensor, TensorData};
use serde::{Deserialize, Serialize};
use splatzoo_datasets::image_io::linear_to_srgb;
use splatzoo_datasets::pose_sequence::PoseSequence;
use splatzoo_datasets::synth::prior::PriorNoise;
use splatzoo_datasets::synth::scene::{ViewTruth, body_label};
use splatzoo_datasets::synth::{Preset, SceneConfig};
use splatzoo_rasterizer::Camera;

/// What the synthetic capture is made of.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AvatarDataConfig {
    pub seed: u64,
    pub width: u32,
    pub height: u32,
    pub frames: usize,
    /// Frame `t` is held out when `t % holdout_every == holdout_every − 1`.
    pub holdout_every: usize,
    /// The fixed camera at every this-many-th training frame is a novel view.
    pub novel_view_every: usize,
    /// Samples per pixel along each axis of the ground-truth renderer.
    pub supersample: usize,
    pub noise: PriorNoise,
}

impl Default for AvatarDataConfig {
    fn default() -> Self {
        Self {
            seed: 0,
            width: 320,
            height: 240,
            frames: 60,
            holdout_every: 5,
            novel_view_every: 4,
            supersample: 2,
            noise: PriorNoise::default(),
        }
    }
}

/// One image with its person mask.
pub struct AvatarView {
    pub name: String,
    pub frame: usize,
    pub camera: Camera,
    /// `[H, W, 3]` sRGB in [0, 1], the whole image.
    pub image: Tensor<3>,
    /// `[H, W]` 1 on the person.
    pub mask: Tensor<2>,
}

impl AvatarView {
    /// The image with everything outside the mask replaced by `background` (what a human-only
    /// avatar is trained and scored against, as GauHuman does on masked captures).
    pub fn masked_target(&self, background: &Tensor<1>) -> Tensor<3> {
        let [h, w, _] = self.image.dims();
        let m = self.mask.clone().reshape([h, w, 1]);
        self.image.clone() * m.clone() + background.clone().reshape([1, 1, 3]) * (m * -1.0 + 1.0)
    }
}

pub struct AvatarCapture {
    pub train: Vec<AvatarView>,
    /// Training frames from a camera never trained on.
    pub novel_view: Vec<AvatarView>,
    /// Held-out frames from the training camera.
    pub novel_pose: Vec<AvatarView>,
    /// The pose track training starts from (one row per frame).
    pub prior: PoseSequence,
    /// The true motion, for pose error only.
    pub truth: PoseSequence,
    /// Per frame: whether it has training images.
    pub trained: Vec<bool>,
    pub fps: f64,
}

fn view(truth: &ViewTruth, name: String, device: &Device) -> AvatarView {
    let r = &truth.render;
    let (h, w) = (r.height, r.width);
    let srgb: Vec<f32> = r.color.iter().flat_map(|c| c.map(linear_to_srgb)).collect();
    let body = body_label(0);
    let mask: Vec<f32> = r.label.iter().map(|&l| f32::from(l == body)).collect();
    AvatarView {
        name,
        frame: truth.frame,
        camera: truth.camera,
        image: Tensor::from_data(TensorData::new(srgb, [h, w, 3]), device),
        mask: Tensor::from_data(TensorData::new(mask, [h, w]), device),
    }
}

impl AvatarDataConfig {
    pub fn is_held_out(&self, frame: usize) -> bool {
        frame % self.holdout_every == self.holdout_every - 1
    }

    /// Builds and renders the capture (the slow part: every frame, both cameras).
    pub fn build(&self, device: &Device) -> AvatarCapture {
        let scene = SceneConfig {
            width: self.width,
            height: self.height,
            frames: Some(self.frames),
            noise: self.noise,
            supersample: self.supersample,
            ..SceneConfig::new(Preset::Monocular, self.seed)
        }
        .build(device);
        let person = &scene.people[0];
        let frames = scene.frame_count;
        let trained: Vec<bool> = (0..frames).map(|t| !self.is_held_out(t)).collect();
        let (mut train, mut novel_view, mut novel_pose) = (Vec::new(), Vec::new(), Vec::new());
        let mut trained_seen = 0;
        for (t, &is_trained) in trained.iter().enumerate() {
            if is_trained {
                let wants_novel =
                    trained_seen % self.novel_view_every == 0 && scene.tracks.len() == 2;
                trained_seen += 1;
                // Both cameras share one shadow map when the frame is also a novel view.
                let mut views = if wants_novel {
                    scene.render_frame(t)
                } else {
                    vec![scene.render_view(t, 0, true)]
                };
                if wants_novel {
                    let fixed = views.pop().expect("the fixed camera, rendered last");
                    novel_view.push(view(
                        &fixed,
                        format!("{}_{t:04}", scene.tracks[1].name),
                        device,
                    ));
                }
                let first = views.pop().expect("one view");
                train.push(view(
                    &first,
                    format!("{}_{t:04}", scene.tracks[0].name),
                    device,
                ));
            } else {
                let truth = scene.render_view(t, 0, true);
                novel_pose.push(view(
                    &truth,
                    format!("{}_{t:04}", scene.tracks[0].name),
                    device,
                ));
            }
        }
        AvatarCapture {
            train,
            novel_view,
            novel_pose,
            prior: person.prior.clone(),
            truth: person.motion.clone(),
            trained,
            fps: scene.fps,
        }
    }
}
