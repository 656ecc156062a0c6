//! NLF-GS subjects from a real capture: any loaded format with `inputs` and `targets` view
//! splits and a body fit per subject — THuman2.0 as GHG renders it (`splatzoo_datasets::
//! formats::ghg`: frames are subjects; inputs are view 0 of ring positions 0, 6, 11, targets
//! of 3, 8, 13, GHG's test protocol). Each subject becomes what the synthetic generator gives
//! ([`NlfSubject`]):
//!
//! - its three input and three target views, images and masks resized to the training side
//!   (`size`², bilinear; masks thresholded at one half) with the intrinsics scaled alike; images
//!   must be square, as GHG's are;
//! - the body posed by the capture's fit (SMPL-X's for THuman2.0: give the matching model file,
//!   `data.body_model`; the built-in body takes the 21 body joints and drops the rest), in the
//!   world the engine folds the fit's placement into (`splatzoo_train::views::people`: rescaled
//!   by `1/s` so the body keeps its size, cameras with it);
//! - the body's depth in each input view, rendered from that posed mesh by the CPU mesh
//!   renderer (what the occlusion test of Eq. 4 reads);
//! - the background: the mean colour of the input views' pixels off the mask (GHG renders on
//!   black).

use crate::data::{INPUTS, NlfSubject, NlfView};
use burn::tensor::{Device, Tensor, TensorData};
use image::imageops::FilterType;
use splatzoo_datasets::formats::{Dataset, ViewRecord};
use splatzoo_datasets::render::{Albedo, Lighting, MeshInstance, RenderSettings, render};
use splatzoo_models::body::lbs::{PoseInput, pose};
use splatzoo_models::body::{BodyModel, BodyTensors};
use splatzoo_rasterizer::Camera;
use splatzoo_train::TrainError;
use splatzoo_train::views::people::{person_sequence, scale_camera_world};

fn input_error(root: &std::path::Path, problem: impl Into<String>) -> TrainError {
    TrainError::Dataset(splatzoo_datasets::DatasetError::file(root, problem.into()))
}

/// `record`'s image and mask at `size`², its camera scaled to match and into the world scaled
/// by `world_scale`.
fn view(
    record: &ViewRecord,
    size: u32,
    world_scale: f64,
    device: &Device,
) -> Result<NlfView, TrainError> {
    let file_error = |problem: String| input_error(&record.image, problem);
    let picture = image::open(&record.image)
        .map_err(|e| file_error(format!("cannot read ({e})")))?
        .to_rgb8();
    let (w, h) = picture.dimensions();
    if w != h || w == 0 {
        return Err(file_error(format!(
            "a {w}×{h} image; NLF-GS trains on square views (GHG's are 1024²)"
        )));
    }
    let resized = image::imageops::resize(&picture, size, size, FilterType::Triangle);
    let pixels: Vec<f32> = resized
        .as_raw()
        .iter()
        .map(|&v| f32::from(v) / 255.0)
        .collect();
    let mask_path = record
        .mask
        .as_ref()
        .ok_or_else(|| file_error("no person mask beside the image".into()))?;
    let mask = image::open(mask_path)
        .map_err(|e| input_error(mask_path, format!("cannot read ({e})")))?
        .to_luma8();
    if mask.dimensions() != (w, h) {
        return Err(input_error(
            mask_path,
            format!("a {:?} mask for a {w}×{h} image", mask.dimensions()),
        ));
    }
    let mask = image::imageops::resize(&mask, size, size, FilterType::Triangle);
    let mask: Vec<f32> = mask
        .as_raw()
        .iter()
        .map(|&v| f32::from(u8::from(v >= 128)))
        .collect();
    let r = f64::from(size) / f64::from(w);
    let full = scale_camera_world(&record.camera, world_scale);
    let camera = Camera {
        fx: (f64::from(full.fx) * r) as f32,
        fy: (f64::from(full.fy) * r) as f32,
        cx: (f64::from(full.cx) * r) as f32,
        cy: (f64::from(full.cy) * r) as f32,
        width: size,
        height: size,
        ..full
    };
    let s = size as usize;
    Ok(NlfView {
        camera,
        image: Tensor::from_data(TensorData::new(pixels, [s, s, 3]), device),
        mask: Tensor::from_data(TensorData::new(mask, [s, s]), device),
    })
}

/// The views of `split` showing frame `frame`, in camera-name order; exactly three.
fn split_views<'a>(
    dataset: &'a Dataset,
    split: &str,
    frame: usize,
) -> Result<Vec<&'a ViewRecord>, TrainError> {
    let mut views: Vec<&ViewRecord> = dataset
        .splits
        .get(split)
        .map(|indices| {
            indices
                .iter()
                .map(|&i| &dataset.views[i])
                .filter(|v| v.frame == frame)
                .collect()
        })
        .unwrap_or_default();
    views.sort_by(|a, b| a.camera_name.cmp(&b.camera_name));
    if views.len() != INPUTS.len() {
        return Err(input_error(
            &dataset.root,
            format!(
                "subject {frame}: {} `{split}` views, NLF-GS takes {} (GHG's protocol: view 0 of \
                 ring positions 0, 6, 11 in, 3, 8, 13 out)",
                views.len(),
                INPUTS.len()
            ),
        ));
    }
    Ok(views)
}

/// Every subject of `dataset` with a body fit (each person track's valid frames, in frame
/// order), at most `limit`, as NLF-GS subjects at `size`² on `model`; the notes of the pose
/// conversion beside them.
pub fn capture_subjects(
    dataset: &Dataset,
    model: &BodyModel,
    size: u32,
    limit: usize,
    device: &Device,
) -> Result<(Vec<NlfSubject>, Vec<String>), TrainError> {
    let tensors = BodyTensors::new(model, device);
    let faces: Vec<[u32; 3]> = model
        .faces
        .chunks_exact(3)
        .map(|f| [f[0], f[1], f[2]])
        .collect();
    let mut subjects = Vec::new();
    // GHG gives each subject its own track, valid at its own frame.
    let tracks = (0..dataset.people.len())
        .map(|person| person_sequence(dataset, person, model, true))
        .collect::<Result<Vec<_>, _>>()?;
    let mut frames: Vec<(usize, usize)> = tracks
        .iter()
        .enumerate()
        .flat_map(|(person, track)| {
            (0..dataset.frame_count)
                .filter(|&f| track.valid[f])
                .map(move |f| (f, person))
        })
        .collect();
    frames.sort_unstable();
    let mut notes: Vec<String> = tracks.iter().flat_map(|t| t.notes.clone()).collect();
    notes.sort();
    notes.dedup();
    for (frame, person) in frames.into_iter().take(limit) {
        let people = &tracks[person];
        let inputs = split_views(dataset, "inputs", frame)?
            .into_iter()
            .map(|r| view(r, size, people.world_scale, device))
            .collect::<Result<Vec<_>, _>>()?;
        let targets = split_views(dataset, "targets", frame)?
            .into_iter()
            .map(|r| view(r, size, people.world_scale, device))
            .collect::<Result<Vec<_>, _>>()?;
        let sequence = &people.sequence;
        let betas = sequence.frame_betas(frame).to_vec();
        let translation = sequence.translation(frame);
        let as_row = |v: &[f64]| -> Tensor<2> {
            let values: Vec<f32> = v.iter().map(|&x| x as f32).collect();
            Tensor::from_data(TensorData::new(values, [1, v.len()]), device)
        };
        let posed = pose(
            &tensors,
            &PoseInput::from_axis_angle(
                as_row(&betas),
                as_row(sequence.pose(frame)),
                as_row(&translation),
            ),
        );
        let vertices = posed.vertices;
        let positions: Vec<[f32; 3]> = splatzoo_train::host_f32(&vertices)
            .chunks_exact(3)
            .map(|p| [p[0], p[1], p[2]])
            .collect();
        let mesh = MeshInstance {
            positions: &positions,
            faces: &faces,
            albedo: Albedo::Uniform([0.5; 3]),
            label: 1,
            smooth: true,
        };
        let settings = RenderSettings {
            background: [0.0; 3],
            supersample: 1,
        };
        let depth: Vec<f32> = inputs
            .iter()
            .flat_map(|v| {
                let r = render(&[mesh], &v.camera, &Lighting::default(), &settings);
                r.depth
                    .into_iter()
                    .zip(r.label)
                    .map(|(d, l)| if l == 1 { d } else { f32::INFINITY })
                    .collect::<Vec<_>>()
            })
            .collect();
        let (mut sum, mut count) = ([0.0f64; 3], 0usize);
        for v in &inputs {
            let image = splatzoo_train::host_f32(&v.image);
            for (k, &m) in splatzoo_train::host_f32(&v.mask).iter().enumerate() {
                if m < 0.5 {
                    for c in 0..3 {
                        sum[c] += f64::from(image[3 * k + c]);
                    }
                    count += 1;
                }
            }
        }
        let background = sum.map(|s| (s / count.max(1) as f64) as f32);
        let s = size as usize;
        subjects.push(NlfSubject {
            seed: frame as u64,
            inputs,
            targets,
            vertices,
            input_depth: Tensor::from_data(TensorData::new(depth, [3, s, s]), device),
            background,
            betas,
            translation,
        });
    }
    if subjects.is_empty() {
        return Err(input_error(&dataset.root, "no subject with a body fit"));
    }
    Ok((subjects, notes))
}
