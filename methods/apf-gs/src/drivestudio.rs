//! A drivestudio processed-Waymo scene (`train-apf --data <scene>`) turned into what APF-GS
//! consumes, as [`crate::data`] turns the synthetic preset:
//!
//! - the chosen cameras' images in the frame window, undistorted and box-filtered by
//!   `data.downscale` through the engine's one bridge from a loaded capture
//!   ([`splatzoo_train::views::dataset`]); the dataset's human dynamic mask (the projected
//!   boxes of moving pedestrians and cyclists) is the coarse mask `M_coarse`;
//! - one tracked person per `humanpose/smpl.pkl` track present (a valid fit and an annotated
//!   box) in at least `data.min_track_frames` training frames: the fit folded into the body
//!   model's parameters ([`splatzoo_train::views::people`]; the built-in body stands in for
//!   SMPL, so the track's betas are dropped), the annotated box made axis-aligned and grown
//!   5 cm (as the synthetic boxes are). A person is hidden in the frames where they are not
//!   present; pedestrians and cyclists without a track stay in the background;
//! - Eq. 3's per-person masks, crops and the test split exactly as on synthetic data
//!   (drivestudio's every 15th timestep, counted from `data.start_frame`);
//! - the LiDAR (`lidar/{t:03}.bin`, every laser) of each training frame projected into its
//!   views as sparse depth ([`splatzoo_train::views::init_points::sparse_depth`]), so the
//!   background, accessory and parent initialisation read it as they read the stand-in;
//! - the sky colour: the mean of the training pixels under `sky_masks/` (drivestudio models
//!   the sky with a network; this method has one background colour), black without sky masks.
//!
//! No ground truth exists on disk: the scores that need it (true-body PSNR, pose error, the σ
//! trace against injected error) are left out of `metrics.json`.

use crate::boxes::world_box;
use crate::data::{ApfCapture, ApfDataConfig, ApfView, TrackedPerson, add_crops, people_masks};
use crate::decouple::{DecoupleConfig, PersonMasks};
use crate::error::ApfError;
use burn::tensor::{Device, Tensor, TensorData};
use rayon::prelude::*;
use splatzoo_datasets::formats::{Dataset, Format, InstanceBox, ViewRecord, drivestudio};
use splatzoo_datasets::masks::Mask;
use splatzoo_datasets::pose_sequence::PoseSequence;
use splatzoo_datasets::posing::pose_frames_with_joints;
use splatzoo_models::body::builtin_body;
use splatzoo_rasterizer::Camera;
use splatzoo_train::TrainError;
use splatzoo_train::views::dataset::{file_image, load_capture};
use splatzoo_train::views::image_store::box_filter;
use splatzoo_train::views::init_points::sparse_depth;
use splatzoo_train::views::people::person_sequence;
use splatzoo_train::views::{DataError, MaskRole};
use std::collections::BTreeSet;
use std::path::Path;

/// Waymo's camera and LiDAR rate (Hz).
const WAYMO_FPS: f64 = 10.0;

/// The classes whose untracked instances are people left in the background.
const PEOPLE_CLASSES: [&str; 2] = ["Pedestrian", "Cyclist"];

fn data_error(e: impl Into<DataError>) -> ApfError {
    ApfError::Train(TrainError::from(e.into()))
}

/// The axis-aligned world box of an annotated (oriented) box, grown by `margin` metres.
pub fn annotated_box(b: &InstanceBox, margin: f32) -> Option<[[f32; 3]; 2]> {
    let m = &b.object_to_world;
    let corners = (0..8).map(|k| {
        let local: [f64; 3] =
            std::array::from_fn(|a| b.size[a] * if (k >> a) & 1 == 1 { 0.5 } else { -0.5 });
        std::array::from_fn(|i| ((0..3).map(|j| m[i][j] * local[j]).sum::<f64>() + m[i][3]) as f32)
    });
    world_box(corners, margin)
}

/// Frames `range` of a sequence.
fn window(seq: &PoseSequence, range: std::ops::Range<usize>) -> PoseSequence {
    let (j, s) = (3 * seq.joints, seq.shape_count);
    PoseSequence {
        joints: seq.joints,
        poses: seq.poses[range.start * j..range.end * j].to_vec(),
        translations: seq.translations[3 * range.start..3 * range.end].to_vec(),
        betas: seq.betas[range.start * s..range.end * s].to_vec(),
        shape_count: s,
        fps: Some(WAYMO_FPS),
    }
}

/// One view read from disk, before the crops and tensors.
struct DiskView {
    record: ViewRecord,
    camera: Camera,
    srgb: Vec<f32>,
    coarse: Mask,
    people: Vec<PersonMasks>,
    sky: Option<Mask>,
}

/// The sky mask of a view at training resolution (≥ half the box-filtered pixels), where the
/// scene has one of the image's size.
fn sky_mask(record: &ViewRecord, downscale: u32) -> Option<Mask> {
    let path = record.other_masks.get("sky")?;
    let grey = image::open(path).ok()?.to_luma8();
    let (w, h) = (grey.width() as usize, grey.height() as usize);
    if (w as u32, h as u32) != (record.camera.width, record.camera.height) {
        return None;
    }
    let values: Vec<f32> = grey.pixels().map(|p| f32::from(p[0] > 0)).collect();
    let f = downscale as usize;
    let filtered = box_filter(&values, w, h, 1, f);
    Some(Mask::new(
        w / f,
        h / f,
        filtered.iter().map(|&v| v >= 0.5).collect(),
    ))
}

impl ApfDataConfig {
    /// Reads the drivestudio scene at `path` (see the module's documentation).
    pub(crate) fn build_from_disk(
        &self,
        path: &Path,
        decouple: &DecoupleConfig,
        crop_size: [usize; 2],
        device: &Device,
    ) -> Result<ApfCapture, ApfError> {
        let loaded = load_capture(path, None, self.downscale).map_err(data_error)?;
        let dataset = &loaded.dataset;
        if dataset.format != Format::Drivestudio {
            return Err(ApfError::input(
                path.display().to_string(),
                format!(
                    "train-apf reads drivestudio's processed Waymo scenes; this is a {:?} capture",
                    dataset.format
                ),
            ));
        }
        let end = self.end_frame.unwrap_or(dataset.frame_count);
        if end > dataset.frame_count || end - self.start_frame.min(end) < self.test_every {
            return Err(ApfError::input(
                path.display().to_string(),
                format!(
                    "data.start_frame {} to data.end_frame {end}: the scene has {} frames, and \
                     the window needs at least data.test_every ({})",
                    self.start_frame, dataset.frame_count, self.test_every
                ),
            ));
        }
        let frames = end - self.start_frame;
        let trained: Vec<bool> = (0..frames).map(|t| !self.is_test(t)).collect();
        let camera_name = |c: usize| c.to_string();
        let mut records: Vec<&ViewRecord> = dataset
            .views
            .iter()
            .filter(|r| {
                (self.start_frame..end).contains(&r.frame)
                    && self
                        .cameras
                        .iter()
                        .any(|&c| camera_name(c) == r.camera_name)
            })
            .collect();
        records.sort_by_key(|r| (r.frame, r.camera_name.clone()));
        if records.is_empty() {
            return Err(ApfError::input(
                path.display().to_string(),
                format!(
                    "no images of data.cameras {:?} in frames {}..{end} (the scene has cameras {:?})",
                    self.cameras,
                    self.start_frame,
                    dataset.camera_names()
                ),
            ));
        }
        let body = builtin_body();
        let (faces, rest) = body.model.faces.as_chunks::<3>();
        assert!(rest.is_empty(), "face indices come in threes");
        let (people, mut decisions) = self.tracked_people(dataset, &trained, device)?;
        if people.is_empty() {
            return Err(ApfError::input(
                path.display().to_string(),
                format!(
                    "no pedestrian to model: {}. APF-GS needs a tracked person (train-3dgs \
                     reconstructs a scene without people)",
                    if decisions.is_empty() {
                        "the scene has no humanpose/smpl.pkl track".to_owned()
                    } else {
                        decisions.join("; ")
                    }
                ),
            ));
        }
        let lidar = drivestudio::lidar(&dataset.root).map_err(data_error)?;

        let prior_meshes: Vec<Vec<&[[f32; 3]]>> = (0..frames)
            .map(|t| {
                people
                    .iter()
                    .map(|p| p.prior_frames[t].vertices.as_slice())
                    .collect()
            })
            .collect();
        let read: Vec<DiskView> = records
            .par_iter()
            .map(|record| {
                let t = record.frame - self.start_frame;
                let (camera, file) =
                    file_image(record, MaskRole::Person, loaded.downscale, [0.0; 3]);
                let host = file.decode().map_err(data_error)?;
                let (w, h) = (host.width, host.height);
                let coarse = match &host.person {
                    Some(p) => Mask::new(w, h, p.iter().map(|&v| v >= 0.5).collect()),
                    None => Mask::empty(w, h),
                };
                let boxes: Vec<_> = people.iter().map(|p| p.boxes[t]).collect();
                let masks =
                    people_masks(decouple, &coarse, &camera, &boxes, &prior_meshes[t], faces);
                Ok(DiskView {
                    record: (*record).clone(),
                    camera,
                    srgb: host.srgb,
                    coarse,
                    people: masks,
                    sky: sky_mask(record, loaded.downscale),
                })
            })
            .collect::<Result<_, ApfError>>()?;

        let mut views = Vec::with_capacity(read.len());
        let mut crops: Vec<Vec<Option<Tensor<4>>>> = vec![vec![None; frames]; people.len()];
        let (mut sky_sum, mut sky_count) = ([0.0f64; 3], 0usize);
        for view in read {
            let t = view.record.frame - self.start_frame;
            let (w, h) = (view.camera.width as usize, view.camera.height as usize);
            let is_train = trained[t];
            let lidar = if is_train {
                let points = lidar[view.record.frame].as_deref().unwrap_or_default();
                Some(sparse_depth(&view.camera, points))
            } else {
                None
            };
            if is_train {
                add_crops(
                    &mut crops,
                    t,
                    &view.people,
                    &view.srgb,
                    [w, h],
                    crop_size,
                    device,
                );
                if let Some(sky) = view.sky.as_ref().filter(|s| s.width == w && s.height == h) {
                    for (p, _) in sky.data.iter().enumerate().filter(|&(_, &s)| s) {
                        for (c, total) in sky_sum.iter_mut().enumerate() {
                            *total += f64::from(view.srgb[3 * p + c]);
                        }
                        sky_count += 1;
                    }
                }
            }
            let camera_index = self
                .cameras
                .iter()
                .position(|&c| camera_name(c) == view.record.camera_name)
                .expect("filtered by camera");
            views.push(ApfView {
                name: format!("{}_{:03}", view.record.camera_name, view.record.frame),
                frame: t,
                camera_index,
                camera: view.camera,
                image: Tensor::from_data(TensorData::new(view.srgb, [h, w, 3]), device),
                coarse: view.coarse,
                true_human: None,
                true_accessory: None,
                people: view.people,
                lidar,
            });
        }
        let (train, test): (Vec<usize>, Vec<usize>) =
            (0..views.len()).partition(|&i| trained[views[i].frame]);
        let scene_points = self.background_points_from(&views, &train);
        let background = if sky_count > 0 {
            sky_sum.map(|v| (v / sky_count as f64) as f32)
        } else {
            [0.0; 3]
        };
        let tracked: BTreeSet<&str> = people.iter().map(|p| p.name.as_str()).collect();
        let untracked: BTreeSet<&str> = dataset
            .boxes
            .iter()
            .filter(|b| {
                (self.start_frame..end).contains(&b.frame)
                    && PEOPLE_CLASSES.contains(&b.class.as_str())
                    && !tracked.contains(b.instance.as_str())
            })
            .map(|b| b.instance.as_str())
            .collect();
        decisions.insert(
            0,
            format!(
                "drivestudio scene {}: cameras {:?} × frames {}..{end} at 1/{} resolution; every \
                 {}th timestep held out ({} training, {} test images); {} LiDAR scans; sky \
                 colour {}",
                dataset.root.display(),
                self.cameras,
                self.start_frame,
                self.downscale,
                self.test_every,
                train.len(),
                test.len(),
                lidar[self.start_frame..end].iter().flatten().count(),
                if sky_count > 0 {
                    format!("{background:.3?} from {sky_count} sky pixels")
                } else {
                    "black (no sky masks)".into()
                }
            ),
        );
        decisions.push(format!(
            "{} tracked people get human nodes; {} untracked pedestrians and cyclists stay in \
             the background",
            people.len(),
            untracked.len()
        ));
        Ok(ApfCapture {
            views,
            train,
            test,
            frames,
            fps: WAYMO_FPS,
            trained,
            background,
            scene_points,
            crops,
            untracked: untracked.len(),
            decisions,
            people,
        })
    }

    /// The people with a track present in enough training frames of the window, and what was
    /// decided for every track.
    fn tracked_people(
        &self,
        dataset: &Dataset,
        trained: &[bool],
        device: &Device,
    ) -> Result<(Vec<TrackedPerson>, Vec<String>), ApfError> {
        let body = builtin_body();
        let frames = trained.len();
        let range = self.start_frame..self.start_frame + frames;
        let mut people = Vec::new();
        let mut decisions = Vec::new();
        for (k, track) in dataset.people.iter().enumerate() {
            let boxes: Vec<Option<[[f32; 3]; 2]>> = range
                .clone()
                .map(|f| {
                    dataset
                        .boxes
                        .iter()
                        .find(|b| b.instance == track.person && b.frame == f)
                        .and_then(|b| annotated_box(b, 0.05))
                })
                .collect();
            let present: Vec<bool> = range
                .clone()
                .zip(&boxes)
                .map(|(f, b)| b.is_some() && track.frames.get(f).is_some_and(Option::is_some))
                .collect();
            let trained_frames = (0..frames).filter(|&t| present[t] && trained[t]).count();
            if trained_frames < self.min_track_frames {
                decisions.push(format!(
                    "track {} stays in the background: present in {trained_frames} training \
                     frames, data.min_track_frames is {}",
                    track.person, self.min_track_frames
                ));
                continue;
            }
            let sequence = person_sequence(dataset, k, &body.model, false).map_err(data_error)?;
            let prior = window(&sequence.sequence, range.clone());
            let prior_frames = pose_frames_with_joints(&body.model, &prior, device);
            decisions.push(format!(
                "track {} gets a human node: present in {trained_frames} training frames{}",
                track.person,
                if sequence.notes.is_empty() {
                    String::new()
                } else {
                    format!(" ({})", sequence.notes.join("; "))
                }
            ));
            people.push(TrackedPerson {
                name: track.person.clone(),
                prior,
                truth: None,
                injected: vec![0.0; frames],
                true_parents: Vec::new(),
                corrupted: vec![false; frames],
                prior_frames,
                present,
                boxes,
            });
        }
        Ok((people, decisions))
    }
}
