//! `train-avatar` on a capture from disk: any format the loaders read that has person masks and
//! a pose track (NeuMan, ZJU-MoCap, PeopleSnapshot, THuman2.0/GHG, drivestudio Waymo, the
//! `synth` command's output), through the engine's bridge ([`crate::views::dataset`]).
//!
//! Frames: the capture's own train/test split where it names one (frames seen only by held-out
//! views are the novel poses), else every `holdout_every`-th frame held out. Cameras: those in
//! `data.train_cameras` train (every camera when it is empty); the others, at every
//! `novel_view_every`-th training frame, are the novel views. Frames where the person is not
//! valid are not used. The prior is the capture's pose track with its world placement folded
//! in ([`crate::views::people`]). Only a synthetic export has a true motion to score the
//! refined track against (its true track, named without the prior's `_prior`).

use super::data::{AvatarCapture, AvatarDataConfig, AvatarView, view_depth};
use crate::error::TrainError;
use crate::views::dataset::{Loaded, file_image, first_pass, load_capture};
use crate::views::init_points::back_project;
use crate::views::people::{person_sequence, scale_camera_world};
use crate::views::{ImageSource, ImageStore, InitPoints, MaskRole};
use burn::tensor::{Device, Tensor};
use splatzoo_datasets::formats::{Dataset, Format};
use splatzoo_models::body::{BodyKind, BodyModel};
use std::collections::BTreeSet;

/// Frames held out: from the capture's named split, or by index.
fn held_out_frames(dataset: &Dataset, config: &AvatarDataConfig) -> (Vec<bool>, String) {
    let frames_of = |name: &str| -> Option<BTreeSet<usize>> {
        let ids = dataset.splits.get(name).filter(|v| !v.is_empty())?;
        Some(ids.iter().map(|&i| dataset.views[i].frame).collect())
    };
    // A capture may name its test frames alone (NeuMan's `test_split.txt`): the rest train.
    if let Some(test) = frames_of("test").or_else(|| frames_of("val")) {
        let train = frames_of("train");
        let held: Vec<bool> = (0..dataset.frame_count)
            .map(|f| test.contains(&f) && !train.as_ref().is_some_and(|t| t.contains(&f)))
            .collect();
        if held.iter().any(|&h| h) && held.iter().any(|&h| !h) {
            return (
                held,
                "the capture's own split: frames only its held-out views see".into(),
            );
        }
    }
    (
        (0..dataset.frame_count)
            .map(|f| config.is_held_out(f))
            .collect(),
        format!("every {}th frame held out", config.holdout_every),
    )
}

/// Loads the capture at `config.path` for `model`.
pub fn load(
    config: &AvatarDataConfig,
    model: &BodyModel,
    device: &Device,
) -> Result<AvatarCapture, TrainError> {
    let path = config
        .path
        .as_ref()
        .ok_or_else(|| TrainError::Config("data.path is not set".into()))?;
    let Loaded { dataset, downscale } =
        load_capture(path, config.format.as_deref(), config.downscale)?;
    // SMPL fits' betas mean SMPL's shape directions; a synthetic export's were made for the
    // built-in body.
    let use_betas = model.kind != BodyKind::Builtin || dataset.format == Format::Synthetic;
    let person = person_sequence(&dataset, config.person, model, use_betas)?;
    let mut decisions = vec![format!(
        "{:?} capture: {} views, {} frames, person {} of {}",
        dataset.format,
        dataset.views.len(),
        dataset.frame_count,
        config.person,
        dataset.people.len()
    )];
    decisions.push(if use_betas {
        "the track's shape coefficients kept (they are the body model's own)".into()
    } else {
        "the built-in body from its rest shape (the track's SMPL betas do not apply), shape refined"
            .into()
    });
    decisions.extend(person.notes.iter().cloned());
    let (held, how) = held_out_frames(&dataset, config);
    decisions.push(format!("novel poses: {how}"));
    let cameras = dataset.camera_names();
    for name in &config.train_cameras {
        if !cameras.contains(&name.as_str()) {
            return Err(TrainError::Config(format!(
                "data.train_cameras names `{name}`, which {} does not have (it has {})",
                dataset.root.display(),
                cameras
                    .iter()
                    .take(8)
                    .copied()
                    .collect::<Vec<_>>()
                    .join(", ")
            )));
        }
    }
    let trains = |camera: &str| {
        config.train_cameras.is_empty() || config.train_cameras.iter().any(|c| c == camera)
    };
    decisions.push(if config.train_cameras.is_empty() {
        "every camera trains; novel views only where the capture's split names them".into()
    } else {
        format!("training cameras: {}", config.train_cameras.join(", "))
    });
    let mut store = ImageStore::new(config.cache_mib, device);
    let (mut train, mut novel_view, mut novel_pose) = (Vec::new(), Vec::new(), Vec::new());
    let trained_frames: BTreeSet<usize> = dataset
        .views
        .iter()
        .filter(|v| person.valid[v.frame] && !held[v.frame] && trains(&v.camera_name))
        .map(|v| v.frame)
        .collect();
    let novel_view_frames: BTreeSet<usize> = trained_frames
        .iter()
        .copied()
        .enumerate()
        .filter(|(k, _)| k % config.novel_view_every == 0)
        .map(|(_, f)| f)
        .collect();
    // Training views with a depth map (for a background node's start).
    let mut with_depth = Vec::new();
    for record in &dataset.views {
        let f = record.frame;
        if !person.valid[f] {
            continue;
        }
        let set = if held[f] {
            if !trains(&record.camera_name) {
                continue;
            }
            &mut novel_pose
        } else if trains(&record.camera_name) {
            &mut train
        } else if novel_view_frames.contains(&f) {
            &mut novel_view
        } else {
            continue;
        };
        if record.mask.is_none() {
            return Err(TrainError::Data(crate::views::DataError::File {
                file: record.image.display().to_string(),
                problem: "train-avatar needs a person mask for every view, and this one has none"
                    .into(),
            }));
        }
        let (camera, file) = file_image(record, MaskRole::Person, downscale, [0.0; 3]);
        let stem = record
            .image
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        set.push(AvatarView {
            name: format!("{}_{f:05}_{stem}", record.camera_name.replace('/', "_"))
                .chars()
                .take(96)
                .collect(),
            frame: f,
            camera: scale_camera_world(&camera, person.world_scale),
            key: store.push(ImageSource::File(Box::new(file))),
            record: Some(record.clone()),
        });
        if !held[f] && trains(&record.camera_name) && record.depth.is_some() {
            with_depth.push(train.len() - 1);
        }
    }
    if train.is_empty() {
        return Err(TrainError::Config(format!(
            "{}: no view is left to train on (valid person frames, training cameras, not held out)",
            dataset.root.display()
        )));
    }
    let keys: Vec<usize> = train
        .iter()
        .chain(&novel_view)
        .chain(&novel_pose)
        .map(|v| v.key)
        .collect();
    first_pass(&store, &keys, device)?;
    let trained: Vec<bool> = (0..person.valid.len())
        .map(|f| trained_frames.contains(&f))
        .collect();
    let (scenery_points, scenery_source) = if !dataset.points.is_empty() {
        let mut points = InitPoints::from_sparse(&dataset.points);
        let s = person.world_scale as f32;
        points.positions.iter_mut().flatten().for_each(|v| *v *= s);
        points.sigmas.iter_mut().for_each(|v| *v *= s);
        (points, Some("the capture's sparse points"))
    } else {
        let mut points = InitPoints::default();
        // Every fourth depth map, every 8th pixel, the person left out.
        for &k in with_depth.iter().step_by(4) {
            let view = &train[k];
            let frame = store.frame(view.key)?;
            let pixels = (&frame.image, frame.person.as_ref());
            depth_outside_person(view, pixels, downscale, person.world_scale, &mut points)?;
        }
        let source = (!points.is_empty()).then_some("the capture's depth maps outside the person");
        (points, source)
    };
    // A synthetic export carries the true motion beside the prior: score the refined track.
    let truth = match dataset.people[config.person].person.strip_suffix("_prior") {
        Some(stem) => match dataset.people.iter().position(|p| p.person == stem) {
            Some(k) => Some(person_sequence(&dataset, k, model, use_betas)?.sequence),
            None => None,
        },
        None => None,
    };
    if truth.is_some() {
        decisions.push("the capture's true motion scores the refined track (MPJPE)".into());
    }
    Ok(AvatarCapture {
        scenery_source,
        scenery_points,
        downscale,
        world_scale: person.world_scale,
        store,
        train,
        novel_view,
        novel_pose,
        prior: person.sequence,
        truth,
        // A track on disk is a tracker's estimate (a synthetic export's prior is perturbed).
        track_is_truth: false,
        trained,
        fps: 30.0,
        decisions,
    })
}

/// Back-projects a training view's depth map (every 8th pixel, the person's pixels left out)
/// into `points`, in the world scaled by `world_scale`.
fn depth_outside_person(
    view: &AvatarView,
    (image, person): (&Tensor<3>, Option<&Tensor<2>>),
    downscale: u32,
    world_scale: f64,
    points: &mut InitPoints,
) -> Result<(), TrainError> {
    let Some(mut depth) = view_depth(view, downscale, world_scale)? else {
        return Ok(());
    };
    if let Some(person) = person.map(crate::host_f32) {
        for (d, p) in depth.iter_mut().zip(person) {
            if p > 0.5 {
                *d = f32::NAN;
            }
        }
    }
    back_project(&view.camera, &depth, &crate::host_f32(image), 8, points);
    Ok(())
}
