//! APF-GS's data: the synthetic `driving` preset (pedestrians with accessories crossing in
//! front of a car; three car-mounted cameras; a prior-corruption window; clothing relief the
//! body model lacks; one untracked pedestrian; a swinging handbag; a LiDAR stand-in), turned
//! into what the method consumes:
//!
//! - every view's image, the dataset's coarse human mask (human ∪ accessory, all people), and
//!   for scoring only the true human and accessory masks;
//! - the tracked people: their prior track (noisy, corrupted in a window), and on synthetic
//!   data the truth for pose error and the injected error per frame;
//! - Eq. 3's per-person masks in every view ([`crate::decouple`]): the coarse mask split by
//!   each tracked person's projected box, the initial prior's silhouette rendered by the CPU
//!   mesh renderer (z-buffered across tracked people);
//! - the sparse LiDAR-like depth of the training views (background and accessory
//!   initialisation, parent selection) and each tracked person's crops for the image encoder.
//!
//! A drivestudio processed-Waymo scene on disk (`data.path`) becomes the same [`ApfCapture`]
//! in [`crate::drivestudio`], through the per-view helpers here (`people_masks`,
//! `add_crops`).
//!
//! The split is drivestudio's: every `test_every`-th timestep (`t ≡ −1 mod test_every`: 14,
//! 29, 44, 59) is held out from training in every camera. Held-out images are only read to
//! score.

use crate::boxes::{box_mask, world_box};
use crate::decouple::{DecoupleConfig, PersonMasks, decouple_view};
use crate::error::ApfError;
use burn::tensor::{Device, Tensor, TensorData};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use splatzoo_datasets::image_io::linear_to_srgb;
use splatzoo_datasets::masks::{Mask, crop_resize, grow_box};
use splatzoo_datasets::pose_sequence::PoseSequence;
use splatzoo_datasets::posing::{PosedFrame, pose_frames_with_joints};
use splatzoo_datasets::render::{Albedo, Lighting, MeshInstance, RenderSettings, render};
use splatzoo_datasets::synth::prior::PriorNoise;
use splatzoo_datasets::synth::scene::body_label;
use splatzoo_datasets::synth::{Preset, SceneConfig};
use splatzoo_models::body::builtin_body;
use splatzoo_models::rotation_scalar::{axis_angle_matrix, matrix_axis_angle};
use splatzoo_rasterizer::Camera;
use splatzoo_train::views::InitPoints;
use splatzoo_train::views::init_points::{back_project, nearest_neighbour_scales};
use std::path::PathBuf;

/// How coarse the dataset's human masks are.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CoarseMask {
    Exact,
    Dilated,
    Boxes,
}

/// What the capture is made of.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ApfDataConfig {
    pub seed: u64,
    pub width: u32,
    pub height: u32,
    pub frames: usize,
    /// Timestep `t` is held out when `t % test_every == test_every − 1`.
    pub test_every: usize,
    pub supersample: usize,
    pub noise: PriorNoise,
    /// The preset's prior-corruption window (an arm and a leg badly wrong for a few frames).
    pub corruption: bool,
    /// The dataset's coarse human mask: the exact union of people and accessories, that union
    /// dilated by `coarse_dilation` pixels, or every person's filled 2-D box (drivestudio's
    /// `dynamic_masks` style).
    pub coarse: CoarseMask,
    pub coarse_dilation: usize,
    /// LiDAR stand-in: beam rows per image and depth noise (metres).
    pub lidar_rows: usize,
    pub lidar_noise: f64,
    /// Most background points kept from the LiDAR.
    pub background_points: usize,
    /// A drivestudio processed-Waymo scene instead of the synthetic preset (`--data`;
    /// [`crate::drivestudio`]). Then the preset's keys (`width`, `height`, `frames`,
    /// `supersample`, `noise`, `corruption`, `coarse`, `lidar_*`) do not apply and the keys
    /// below do.
    pub path: Option<PathBuf>,
    /// On disk: the Waymo cameras trained on, by drivestudio's ids (0 FRONT, 1 FRONT_LEFT,
    /// 2 FRONT_RIGHT, 3 SIDE_LEFT, 4 SIDE_RIGHT); drivestudio's default is the three front ones.
    pub cameras: Vec<usize>,
    /// On disk: images (and masks) box-filtered by this factor (Waymo's 1920×1280 → 480×320 at 4).
    pub downscale: u32,
    /// On disk: the frames `[start_frame, end_frame)` of the scene (to its end without
    /// `end_frame`), as drivestudio's `start_timestep`/`end_timestep`.
    pub start_frame: usize,
    pub end_frame: Option<usize>,
    /// On disk: a pedestrian's track gets a human node when the person is present (a valid
    /// body fit and a box) in at least this many training frames; shorter tracks stay in the
    /// background.
    pub min_track_frames: usize,
}

impl Default for ApfDataConfig {
    fn default() -> Self {
        Self {
            seed: 0,
            width: 384,
            height: 216,
            frames: 60,
            test_every: 15,
            supersample: 2,
            noise: PriorNoise::default(),
            corruption: true,
            coarse: CoarseMask::Exact,
            coarse_dilation: 3,
            lidar_rows: 32,
            lidar_noise: 0.02,
            background_points: 40_000,
            path: None,
            cameras: vec![0, 1, 2],
            downscale: 4,
            start_frame: 0,
            end_frame: None,
            min_track_frames: 3,
        }
    }
}

impl ApfDataConfig {
    pub fn is_test(&self, frame: usize) -> bool {
        frame % self.test_every == self.test_every - 1
    }

    pub fn validate(&self) -> Result<(), String> {
        if self.test_every < 2 {
            return Err("data.test_every ≥ 2".into());
        }
        if self.frames < self.test_every {
            return Err(format!(
                "data.frames ({}) ≥ data.test_every ({})",
                self.frames, self.test_every
            ));
        }
        if self.width < 16 || self.height < 16 {
            return Err("data.width and data.height ≥ 16".into());
        }
        if self.downscale == 0 || self.min_track_frames == 0 {
            return Err("data.downscale ≥ 1 and data.min_track_frames ≥ 1".into());
        }
        if self.cameras.is_empty() || self.cameras.iter().any(|&c| c > 4) {
            return Err(format!(
                "data.cameras: one or more of drivestudio's Waymo camera ids 0–4, got {:?}",
                self.cameras
            ));
        }
        if self.end_frame.is_some_and(|end| end <= self.start_frame) {
            return Err(format!(
                "data.end_frame ({:?}) > data.start_frame ({})",
                self.end_frame, self.start_frame
            ));
        }
        Ok(())
    }
}

/// One image.
pub struct ApfView {
    pub name: String,
    pub frame: usize,
    pub camera_index: usize,
    pub camera: Camera,
    /// `[H, W, 3]` sRGB.
    pub image: Tensor<3>,
    /// The dataset's merged human mask (all people, accessories included).
    pub coarse: Mask,
    /// Ground truth for scoring only (synthetic data): the tracked pedestrians' body pixels
    /// (what the human nodes model) and every accessory's pixels.
    pub true_human: Option<Mask>,
    pub true_accessory: Option<Mask>,
    /// Eq. 3's masks of every tracked person.
    pub people: Vec<PersonMasks>,
    /// Sparse depth (camera z; NaN without a return), training views only.
    pub lidar: Option<Vec<f32>>,
}

/// A pedestrian with a prior track.
pub struct TrackedPerson {
    pub name: String,
    pub prior: PoseSequence,
    /// The true motion and per-frame injected pose error (radians, mean over joints), on
    /// synthetic data.
    pub truth: Option<PoseSequence>,
    pub injected: Vec<f64>,
    /// The joint each true accessory hangs from (synthetic data; parent selection's check).
    pub true_parents: Vec<usize>,
    /// Whether frame `t` lies in the corruption window (synthetic data).
    pub corrupted: Vec<bool>,
    /// The prior posed at every frame (Eq. 3's `M_kine`, parent selection).
    pub prior_frames: Vec<PosedFrame>,
    /// Whether the person is in the scene at frame `t` (a driving scene's pedestrians come and
    /// go: their node is hidden where their track or box is missing).
    pub present: Vec<bool>,
    /// The person's world box at every frame (a driving dataset's annotated 3-D box; on
    /// synthetic data the true body and accessories grown by 5 cm).
    pub boxes: Vec<Option<[[f32; 3]; 2]>>,
}

pub struct ApfCapture {
    pub views: Vec<ApfView>,
    pub train: Vec<usize>,
    pub test: Vec<usize>,
    pub people: Vec<TrackedPerson>,
    pub frames: usize,
    pub fps: f64,
    /// Per frame: whether it has training images.
    pub trained: Vec<bool>,
    /// sRGB colour where nothing is (the synthetic sky).
    pub background: [f32; 3],
    /// The background node's initial points (LiDAR outside every tracked person's box mask).
    pub scene_points: InitPoints,
    /// `crops[h][t]`: `[V, 3, ch, cw]` crops of person `h` at frame `t` from the training
    /// views that show them.
    pub crops: Vec<Vec<Option<Tensor<4>>>>,
    pub untracked: usize,
    pub decisions: Vec<String>,
}

/// Mean angle (radians) between two poses' local joint rotations, joints 1.. (not the root).
pub fn pose_error(a: &[f64], b: &[f64]) -> f64 {
    let j = a.len() / 3;
    let mut sum = 0.0;
    for k in 1..j {
        let ra = axis_angle_matrix([a[3 * k], a[3 * k + 1], a[3 * k + 2]]);
        let rb = axis_angle_matrix([b[3 * k], b[3 * k + 1], b[3 * k + 2]]);
        let rel: [[f64; 3]; 3] = std::array::from_fn(|r| {
            std::array::from_fn(|c| (0..3).map(|i| ra[i][r] * rb[i][c]).sum())
        });
        let v = matrix_axis_angle(&rel);
        sum += (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    }
    sum / (j - 1).max(1) as f64
}

/// `[1, 3, ch, cw]` crop of an sRGB image `[H·W·3]` around `rectangle` (grown 10 %).
fn crop(
    image: &[f32],
    w: usize,
    h: usize,
    rectangle: [usize; 4],
    size: [usize; 2],
    device: &Device,
) -> Tensor<4> {
    let [ch, cw] = size;
    let pixels = crop_resize(image, w, h, grow_box(rectangle, 0.1), cw, ch);
    Tensor::<3>::from_data(TensorData::new(pixels, [ch, cw, 3]), device)
        .permute([2, 0, 1])
        .reshape([1, 3, ch, cw])
}

/// Eq. 3's masks of every tracked person in one view: the coarse mask split by each person's
/// projected box (`None`: not in the scene at this frame), `M_kine` from the prior meshes
/// z-buffered across people.
pub(crate) fn people_masks(
    decouple: &DecoupleConfig,
    coarse: &Mask,
    camera: &Camera,
    boxes: &[Option<[[f32; 3]; 2]>],
    prior_meshes: &[&[[f32; 3]]],
    faces: &[[u32; 3]],
) -> Vec<PersonMasks> {
    let (w, h) = (coarse.width, coarse.height);
    let box_masks: Vec<Mask> = boxes
        .iter()
        .map(|b| b.map_or_else(|| Mask::empty(w, h), |b| box_mask(camera, &b)))
        .collect();
    let owner = prior_owner(prior_meshes, faces, camera);
    decouple_view(decouple, coarse, &box_masks, &owner)
}

/// Adds each visible person's crop of one training view at frame `t` to `crops[person][t]`
/// (people covering fewer than 16 pixels give none).
pub(crate) fn add_crops(
    crops: &mut [Vec<Option<Tensor<4>>>],
    t: usize,
    people: &[PersonMasks],
    srgb: &[f32],
    [w, h]: [usize; 2],
    crop_size: [usize; 2],
    device: &Device,
) {
    for (p, masks) in people.iter().enumerate() {
        let Some(rect) = masks.coarse.bounding_box() else {
            continue;
        };
        if masks.coarse.area() < 16 {
            continue;
        }
        let c = crop(srgb, w, h, rect, crop_size, device);
        crops[p][t] = Some(match crops[p][t].take() {
            Some(prev) => Tensor::cat(vec![prev, c], 0),
            None => c,
        });
    }
}

/// Per-pixel owner among the tracked people's prior meshes at one frame, from `camera`.
fn prior_owner(meshes: &[&[[f32; 3]]], faces: &[[u32; 3]], camera: &Camera) -> Vec<Option<usize>> {
    let instances: Vec<MeshInstance> = meshes
        .iter()
        .enumerate()
        .map(|(k, positions)| MeshInstance {
            positions,
            faces,
            albedo: Albedo::Uniform([1.0; 3]),
            label: u8::try_from(k + 1).expect("at most 254 tracked people"),
            smooth: false,
        })
        .collect();
    let lighting = Lighting {
        ambient: [1.0; 3],
        environment: None,
        light: None,
        shadow_resolution: None,
    };
    let settings = RenderSettings {
        background: [0.0; 3],
        supersample: 1,
    };
    render(&instances, camera, &lighting, &settings)
        .label
        .into_iter()
        .map(|l| (l > 0).then(|| l as usize - 1))
        .collect()
}

impl ApfDataConfig {
    /// Builds and renders the synthetic capture (or reads the scene at `path`), with Eq. 3's
    /// masks for `decouple`.
    pub fn build(
        &self,
        decouple: &DecoupleConfig,
        crop_size: [usize; 2],
        device: &Device,
    ) -> Result<ApfCapture, ApfError> {
        if let Some(path) = &self.path {
            return self.build_from_disk(path, decouple, crop_size, device);
        }
        let mut scene_config = SceneConfig {
            width: self.width,
            height: self.height,
            frames: Some(self.frames),
            noise: self.noise,
            supersample: self.supersample,
            ..SceneConfig::new(Preset::Driving, self.seed)
        };
        if !self.corruption {
            scene_config.corruption = None;
        }
        let scene = scene_config.build(device);
        let body = builtin_body();
        let (faces, rest) = body.model.faces.as_chunks::<3>();
        assert!(rest.is_empty(), "face indices come in threes");
        let tracked: Vec<usize> = (0..scene.people.len())
            .filter(|&k| scene.people[k].tracked)
            .collect();
        let mut priors: Vec<Vec<PosedFrame>> = tracked
            .iter()
            .map(|&k| pose_frames_with_joints(&body.model, &scene.people[k].prior, device))
            .collect();
        let frames = scene.frame_count;
        let trained: Vec<bool> = (0..frames).map(|t| !self.is_test(t)).collect();
        let all_tracks: Vec<usize> = (0..scene.tracks.len()).collect();
        let (w, h) = (self.width as usize, self.height as usize);
        let mut views = Vec::new();
        let mut crops: Vec<Vec<Option<Tensor<4>>>> = vec![vec![None; frames]; tracked.len()];
        let mut person_boxes = vec![Vec::with_capacity(frames); tracked.len()];
        for t in 0..frames {
            let truths = scene.render_tracks(t, &all_tracks, true);
            let boxes: Vec<Option<[[f32; 3]; 2]>> = tracked
                .iter()
                .map(|&k| {
                    let person = &scene.people[k];
                    let accessories = (0..person.accessories.len())
                        .flat_map(|a| scene.accessory_vertices(k, a, t));
                    world_box(
                        person.frames[t].vertices.iter().copied().chain(accessories),
                        0.05,
                    )
                })
                .collect();
            for (p, b) in boxes.iter().enumerate() {
                person_boxes[p].push(*b);
            }
            let prior_meshes: Vec<&[[f32; 3]]> =
                priors.iter().map(|p| p[t].vertices.as_slice()).collect();
            let per_view: Vec<_> = truths
                .par_iter()
                .map(|truth| {
                    let camera = truth.camera;
                    let coarse = match self.coarse {
                        CoarseMask::Exact => Mask::new(w, h, truth.coarse_mask()),
                        CoarseMask::Dilated => {
                            Mask::new(w, h, truth.coarse_mask()).dilate(self.coarse_dilation)
                        }
                        CoarseMask::Boxes => Mask::new(w, h, truth.coarse_mask_boxes()),
                    };
                    let people =
                        people_masks(decouple, &coarse, &camera, &boxes, &prior_meshes, faces);
                    (coarse, people)
                })
                .collect();
            for (truth, (coarse, people)) in truths.into_iter().zip(per_view) {
                let srgb: Vec<f32> = truth
                    .render
                    .color
                    .iter()
                    .flat_map(|c| c.map(linear_to_srgb))
                    .collect();
                let is_train = trained[t];
                if is_train {
                    add_crops(&mut crops, t, &people, &srgb, [w, h], crop_size, device);
                }
                let lidar = is_train.then(|| {
                    truth.lidar_depth(
                        self.lidar_rows,
                        self.lidar_noise,
                        self.seed ^ ((t * 16 + truth.track) as u64),
                    )
                });
                views.push(ApfView {
                    name: format!("{}_{t:04}", scene.tracks[truth.track].name),
                    frame: t,
                    camera_index: truth.track,
                    camera: truth.camera,
                    image: Tensor::from_data(TensorData::new(srgb, [h, w, 3]), device),
                    true_human: Some(Mask::new(
                        w,
                        h,
                        truth
                            .render
                            .label
                            .iter()
                            .map(|&l| tracked.iter().any(|&k| l == body_label(k)))
                            .collect(),
                    )),
                    true_accessory: Some(Mask::new(w, h, truth.accessory_mask())),
                    coarse,
                    people,
                    lidar,
                });
            }
        }
        let (train, test): (Vec<usize>, Vec<usize>) =
            (0..views.len()).partition(|&i| trained[views[i].frame]);
        let scene_points = self.background_points_from(&views, &train);
        let accessory_iou = accessory_iou(&views, &train);
        let people: Vec<TrackedPerson> = tracked
            .iter()
            .zip(priors.drain(..).zip(person_boxes))
            .map(|(&k, (prior_frames, boxes))| {
                let person = &scene.people[k];
                let injected = (0..frames)
                    .map(|t| pose_error(person.prior.pose(t), person.motion.pose(t)))
                    .collect();
                let corrupted = (0..frames)
                    .map(|t| {
                        scene_config
                            .corruption
                            .as_ref()
                            .is_some_and(|c| c.contains(t))
                    })
                    .collect();
                TrackedPerson {
                    name: format!("pedestrian_{k}"),
                    present: vec![true; frames],
                    prior: person.prior.clone(),
                    truth: Some(person.motion.clone()),
                    injected,
                    true_parents: person.accessories.iter().map(|a| a.joint).collect(),
                    corrupted,
                    prior_frames,
                    boxes,
                }
            })
            .collect();
        let untracked = scene.people.len() - tracked.len();
        let bg = scene.environment.background.map(linear_to_srgb);
        Ok(ApfCapture {
            decisions: vec![
                format!(
                    "synthetic driving preset, seed {}: {} cameras × {frames} frames at {}×{}; \
                     every {}th timestep held out ({} training, {} test images)",
                    self.seed,
                    scene.tracks.len(),
                    self.width,
                    self.height,
                    self.test_every,
                    train.len(),
                    test.len()
                ),
                format!(
                    "{} tracked pedestrians get human nodes; {untracked} untracked stay in the \
                     background (no prior track)",
                    tracked.len()
                ),
                match accessory_iou {
                    Some(iou) => format!(
                        "Eq. 3 ({}): IoU of the decoupled accessory masks with the true ones \
                         {iou:.3} (mean over training images showing an accessory)",
                        if decouple.cleanup {
                            "with the cleanup"
                        } else {
                            "literal"
                        }
                    ),
                    None => "Eq. 3: no true accessory masks to score the decoupling".into(),
                },
            ],
            views,
            train,
            test,
            people,
            frames,
            fps: scene.fps,
            trained,
            background: bg,
            scene_points,
            crops,
            untracked,
        })
    }

    /// LiDAR returns of the training views outside every tracked person's box, colour from the
    /// image, thinned to `background_points`.
    pub(crate) fn background_points_from(&self, views: &[ApfView], train: &[usize]) -> InitPoints {
        let mut points = InitPoints::default();
        for &i in train {
            let view = &views[i];
            let Some(lidar) = &view.lidar else { continue };
            let srgb = splatzoo_train::host_f32(&view.image);
            let outside: Vec<f32> = lidar
                .iter()
                .enumerate()
                .map(|(p, &d)| {
                    let on_person = view.people.iter().any(|m| m.coarse.data[p]);
                    if on_person { f32::NAN } else { d }
                })
                .collect();
            back_project(&view.camera, &outside, &srgb, 1, &mut points);
        }
        let mut points = points.thinned(self.background_points, self.seed ^ 0xB6_0000);
        points.sigmas = nearest_neighbour_scales(&points.positions, 3);
        points
    }
}

/// Mean IoU of `∪_h M_acc^h` with the true accessory mask over the training images where
/// either is non-empty (synthetic data only).
fn accessory_iou(views: &[ApfView], train: &[usize]) -> Option<f64> {
    let ious: Vec<f64> = train
        .iter()
        .filter_map(|&i| {
            let view = &views[i];
            let truth = view.true_accessory.as_ref()?;
            let decoupled = view
                .people
                .iter()
                .fold(Mask::empty(truth.width, truth.height), |m, p| {
                    m.or(&p.accessory)
                });
            decoupled.iou(truth)
        })
        .collect();
    (!ious.is_empty()).then(|| ious.iter().sum::<f64>() / ious.len() as f64)
}
