//! A real capture: a NeuMan scene folder (`splatzoo_datasets::formats::neuman`, as NeuMan's
//! preprocessing leaves it) read as Prior-4D's acting video, with its own scene. What the
//! paper's inputs need and NeuMan gives, and what it does not:
//!
//! - **acting frames**: every image whose person has a body fit and an alignment, in name
//!   order, resized to `data.width` wide (the height by the image's aspect, intrinsics scaled
//!   alike); its COLMAP camera (scene units: COLMAP's); its person mask (`segmentations/`);
//!   images must be undistorted (NeuMan's are: its COLMAP model is `PINHOLE`).
//! - **the body prior**: the SMPL fit, placed in COLMAP's world by NeuMan's alignment
//!   `x = s R x_smpl + t` and taken into each camera's frame in metres: the world is rescaled
//!   by `1/s` for the body (`splatzoo_train::views::people`), so the alignment's median `s` is
//!   NeuMan's own estimate of the global scale σ, reported beside σ₀, not a truth. The SMPL
//!   pose drives the built-in body's joints (same layout); SMPL's shape coefficients mean
//!   nothing to that body, so the rest shape is used unless `data.capture_betas` (stage D
//!   refines the shape either way).
//! - **held-out frames** for the scores (the capture has no synchronised evaluation camera):
//!   NeuMan's `test_split.txt` where it names a frame, else every `data.held_out_every`-th frame. No
//!   stage trains on their pixels; the body is placed there from the prior
//!   ([`super::ActingFrame::held_out`]).
//! - **the scene prior's points**: COLMAP's sparse points, at most `data.scene_points`.
//! - **ground pixels** (NeuMan has no ground masks; our rule): around the body prior's ankles
//!   and feet projected into each frame, a disc of 0.3 × the person mask's height, below the
//!   ankles and outside the person: the floor she stands on, whatever the scene's scale
//!   (projection needs none).
//! - **the other external priors**, where the user gives them beside the images
//!   ([`super::given`]): 2-D keypoints, normal maps, monocular depth (its affine map fitted to
//!   the COLMAP points' depth in that frame), ground masks (in place of the rule above).
//! - **the scans**, where the user gives them (`data.scene_scan`, `data.human_scan`:
//!   [`super::scans`]).
//! - **never given**: any truth. The trainer turns off what needs a missing input and says so
//!   (`Prior4d`'s decisions).

use super::frames::{read_image, read_person, resized_camera, training_size, undistorted};
use super::given::{
    GROUND, KEYPOINTS, MONO_DEPTH, NORMALS, given_file, read_body25, read_ground, read_mono_depth,
    read_normals, sparse_depth, write_given,
};
use super::scans::{read_human_scan, read_scene_scan};
use super::{
    ActingFrame, CameraSource, EvalFrame, Prior4dCapture, Prior4dDataConfig, to_camera_space,
};
use crate::data::sensors::scaled_camera;
use crate::error::Prior4dError;
use burn::tensor::{Device, Tensor, TensorData};
use glam::{DMat3, DVec3};
use splatzoo_datasets::formats::neuman_writer::{NeumanFrame, frame_name, write_neuman_scene};
use splatzoo_datasets::formats::{Dataset, Similarity, ViewRecord, neuman};
use splatzoo_datasets::masks::Mask;
use splatzoo_models::body::builtin_body;
use splatzoo_rasterizer::Camera;
use splatzoo_train::avatar::track_joints;
use splatzoo_train::host_f32;
use splatzoo_train::views::people::person_sequence;
use splatzoo_train::views::{ColourSum, InitPoints};
use std::path::Path;

/// The built-in body's ankles and feet (SMPL's joint order).
const FEET: [usize; 4] = [7, 8, 10, 11];

/// The ground rule of the module's documentation: pixels within `0.3 ×` the person's height of
/// the lowest projected foot point `feet` (camera frame), no higher than the highest ankle,
/// outside the person mask dilated by 2 pixels.
pub fn ground_near_feet(camera: &Camera, person: &Mask, feet: &[[f64; 3]]) -> Mask {
    let (w, h) = (person.width, person.height);
    let rows: Vec<usize> = (0..h)
        .filter(|&y| (0..w).any(|x| person.get(x, y)))
        .collect();
    let projected: Vec<[f64; 2]> = feet
        .iter()
        .filter(|p| p[2] > 1e-6)
        .map(|p| {
            [
                f64::from(camera.fx) * p[0] / p[2] + f64::from(camera.cx),
                f64::from(camera.fy) * p[1] / p[2] + f64::from(camera.cy),
            ]
        })
        .collect();
    let (Some(top), Some(bottom), false) = (rows.first(), rows.last(), projected.is_empty()) else {
        return Mask::empty(w, h);
    };
    let radius = 0.3 * (bottom - top + 1) as f64;
    let highest = projected.iter().map(|p| p[1]).fold(f64::INFINITY, f64::min);
    let outside = person.dilate(2);
    let data = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| {
            let (u, v) = (x as f64 + 0.5, y as f64 + 0.5);
            v >= highest
                && !outside.get(x, y)
                && projected
                    .iter()
                    .any(|p| (u - p[0]).powi(2) + (v - p[1]).powi(2) <= radius * radius)
        })
        .collect();
    Mask::new(w, h, data)
}

/// NeuMan's test split, where the folder names one with a frame in it.
fn test_split(dataset: &Dataset) -> Option<&Vec<usize>> {
    dataset
        .splits
        .get("test")
        .filter(|indices| !indices.is_empty())
}

/// The acting frames' view records: those with a valid body, in name order, and which are held
/// out.
fn acting_records<'a>(
    dataset: &'a Dataset,
    valid: &[bool],
    held_out_every: usize,
) -> Vec<(&'a ViewRecord, bool)> {
    let test: Option<Vec<&str>> = test_split(dataset).map(|indices| {
        indices
            .iter()
            .map(|&i| dataset.views[i].camera_name.as_str())
            .collect()
    });
    let every = held_out_every.max(2);
    dataset
        .views
        .iter()
        .filter(|v| valid.get(v.frame).copied().unwrap_or(false))
        .enumerate()
        .map(|(k, v)| {
            let held_out = match &test {
                Some(names) => names.contains(&v.camera_name.as_str()),
                None => k % every == every - 1,
            };
            (v, held_out)
        })
        .collect()
}

/// Reads the NeuMan folder `root` as a Prior-4D capture (the module's documentation).
pub fn read_neuman(
    root: &Path,
    options: &Prior4dDataConfig,
    device: &Device,
) -> Result<Prior4dCapture, Prior4dError> {
    let dataset = neuman::load(root).map_err(|e| Prior4dError::Train(e.into()))?;
    let model = &builtin_body().model;
    let person = person_sequence(&dataset, 0, model, options.capture_betas)
        .map_err(|e| Prior4dError::Train(e.into()))?;
    let records = acting_records(&dataset, &person.valid, options.held_out_every);
    let trained = records.iter().filter(|(_, held)| !held).count();
    if trained < 2 || trained == records.len() {
        return Err(Prior4dError::input(
            root.display().to_string(),
            format!(
                "{} frames with a body fit, {trained} to train on: expected at least 2 to \
                 train on and 1 held out",
                records.len()
            ),
        ));
    }
    let model_file = root.join("sparse/cameras.txt");
    for (record, _) in &records {
        undistorted(record, &model_file)?;
    }
    let (width, height) = training_size(&records[0].0.camera, options.width);
    let frames: Vec<usize> = records.iter().map(|(r, _)| r.frame).collect();
    let cameras: Vec<Camera> = records
        .iter()
        .map(|(r, _)| resized_camera(&r.camera, (width, height)))
        .collect();
    let metre_cameras: Vec<Camera> = cameras
        .iter()
        .map(|c| scaled_camera(c, person.world_scale))
        .collect();
    let world_track = person.sequence.frames_subset(&frames);
    let acting_prior = to_camera_space(&world_track, &metre_cameras, model);
    let joints = host_f32(&track_joints(model, &acting_prior, device));
    let joint_count = model.joint_count();

    let (w, h) = (width as usize, height as usize);
    let size = (w, h);
    let all_points = InitPoints::from_sparse(&dataset.points);
    let mut keypoints = Vec::new();
    let mut acting = Vec::with_capacity(records.len());
    let mut eval = Vec::new();
    let mut background = ColourSum::default();
    for (t, ((record, held_out), camera)) in records.iter().zip(&cameras).enumerate() {
        let pixels = read_image(record, (width, height))?;
        let mask = read_person(record, (width, height))?;
        background.add(&pixels, Some(&mask));
        let feet: Vec<[f64; 3]> = FEET
            .iter()
            .map(|&j| {
                let base = 3 * (t * joint_count + j);
                [0, 1, 2].map(|c| f64::from(joints[base + c]))
            })
            .collect();
        let full = (record.camera.width as usize, record.camera.height as usize);
        let ground = match given_file(root, GROUND, record, ".png") {
            Some(path) => read_ground(&path, full, size)?,
            None => ground_near_feet(camera, &mask, &feet),
        };
        if let Some(path) = given_file(root, KEYPOINTS, record, "_keypoints.json") {
            let scale = (w as f64 / full.0 as f64, h as f64 / full.1 as f64);
            keypoints.push(read_body25(&path, scale)?);
        }
        let normals = given_file(root, NORMALS, record, ".npy")
            .map(|path| read_normals(&path, full, size, &mask))
            .transpose()?;
        let (mono, depth) = match given_file(root, MONO_DEPTH, record, ".npy") {
            Some(path) => (
                read_mono_depth(&path, full, size)?,
                sparse_depth(camera, &all_points.positions),
            ),
            None => (vec![0.0; w * h], vec![f32::INFINITY; w * h]),
        };
        let image = Tensor::<3>::from_data(TensorData::new(pixels, [h, w, 3]), device);
        if *held_out {
            eval.push(EvalFrame {
                acting_frame: t,
                camera: *camera,
                image: image.clone(),
                mask: mask.clone(),
                normals: normals
                    .as_ref()
                    .map(|n| n.chunks(3).map(|c| [c[0], c[1], c[2]]).collect()),
            });
        }
        acting.push(ActingFrame {
            camera: *camera,
            image,
            mask: super::sensors::mask_tensor(&mask, device),
            normals: normals.map(|n| Tensor::from_data(TensorData::new(n, [h, w, 3]), device)),
            held_out: *held_out,
            ground,
            mono_inverse_depth: Tensor::from_data(TensorData::new(mono, [h, w]), device),
            depth,
        });
    }
    let points = all_points.thinned(options.scene_points, options.seed ^ 0x9414_0002);
    let mut decisions = vec![format!(
        "NeuMan capture {}: {} acting frames with a body fit ({} held out for the scores{}), \
         {}×{}, {} COLMAP points; NeuMan's alignment puts σ near {:.4} (its own estimate, not \
         a truth)",
        root.display(),
        acting.len(),
        eval.len(),
        if test_split(&dataset).is_some() {
            ": test_split.txt"
        } else {
            ""
        },
        width,
        height,
        points.len(),
        1.0 / person.world_scale
    )];
    decisions.extend(person.notes.iter().map(|note| format!("body fit: {note}")));
    let mut scene_scan = Vec::new();
    let mut scene_points = points.clone();
    let mut scene_background = background.mean();
    if let Some(scan) = &options.scene_scan {
        (scene_scan, scene_points, scene_background) = read_scene_scan(scan, options, device)?;
        let grounded = scene_scan.iter().filter(|v| v.ground.area() > 0).count();
        decisions.push(format!(
            "scene scan {}: {} views, {} points, ground masks in {grounded}",
            scan.display(),
            scene_scan.len(),
            scene_points.len()
        ));
    }
    let (mut human_scan, mut scan_prior, mut scan_background) =
        (Vec::new(), world_track.frames_subset(&[]), [0.0; 3]);
    if let Some(scan) = &options.human_scan {
        (human_scan, scan_prior, scan_background) = read_human_scan(scan, options, device)?;
        decisions.push(format!(
            "human scan {}: {} views with a body fit",
            scan.display(),
            human_scan.len()
        ));
    }
    let given = |folder: &str| root.join(folder).is_dir();
    let mut lacking: Vec<&str> = [
        (NORMALS, "normal maps"),
        (
            MONO_DEPTH,
            "monocular depth (stage A's depth term then compares nothing)",
        ),
        (KEYPOINTS, "2-D keypoints"),
    ]
    .iter()
    .filter(|(folder, _)| !given(folder))
    .map(|(_, what)| *what)
    .collect();
    lacking.extend([
        "the scene and human scans",
        "any truth (no σ*, camera, MPJPE or floor scores)",
    ]);
    decisions.push(format!(
        "given beside the images (data::given): {}; not given: {}; ground pixels {}",
        [KEYPOINTS, NORMALS, MONO_DEPTH, GROUND]
            .iter()
            .filter(|folder| given(folder))
            .map(|folder| format!("{folder}/"))
            .collect::<Vec<_>>()
            .join(", "),
        lacking.join(", "),
        if given(GROUND) {
            "from ground/"
        } else {
            "by the feet rule"
        }
    ));
    Ok(Prior4dCapture {
        scene_scan,
        scene_points,
        acting_points: points,
        scene_background,
        human_scan,
        scan_prior,
        scan_background,
        acting,
        acting_cameras: CameraSource::Estimated,
        acting_prior,
        acting_keypoints: keypoints,
        eval,
        truth: None,
        fps: world_track.fps.unwrap_or(30.0),
        decisions,
    })
}

/// NeuMan's fits carry SMPL's 10 shape coefficients.
pub const NEUMAN_BETAS: usize = 10;

/// Writes the synthetic `capture`'s acting video as a NeuMan scene under `root`
/// (`splatzoo_datasets::formats::neuman_writer`), frames `test` listed as its test split: its
/// images, person masks, SfM cameras (COLMAP's world = scene units), acting points, and the
/// camera-space body prior `x_c = R_c (x − J₀) + J₀ + t_c` (metres) as SMPL's pose (global
/// orientation `R_c`, no translation; the first [`NEUMAN_BETAS`] shape coefficients) with the
/// alignment `s = σ*`, `R = R_wcᵀ`, `t = σ* R_wcᵀ t_c − R_wcᵀ T_wc`, which puts the body where
/// the camera `[R_wc | T_wc]` films it. [`read_neuman`] reads back the same cameras, masks,
/// images (to 8 bits) and camera-space prior (its further shape coefficients zeroed). With
/// `with_given`, the capture's noisy keypoints, normal maps, monocular depth and ground masks
/// go beside them ([`super::given`]).
pub fn write_acting_as_neuman(
    capture: &Prior4dCapture,
    root: &Path,
    test: &[usize],
    with_given: bool,
) -> Result<(), Prior4dError> {
    let truth = capture.truth.as_ref().ok_or_else(|| {
        Prior4dError::input(
            "capture",
            "only the synthetic capture knows the scale its body is placed at",
        )
    })?;
    let sigma = truth.scale;
    let prior = &capture.acting_prior;
    if prior.joints != 24 || prior.shape_count < NEUMAN_BETAS {
        return Err(Prior4dError::input(
            "acting prior",
            format!(
                "{} joints and {} shape coefficients; NeuMan's SMPL fits take 24 and {NEUMAN_BETAS}",
                prior.joints, prior.shape_count
            ),
        ));
    }
    let frames: Vec<NeumanFrame> = capture
        .acting
        .iter()
        .enumerate()
        .map(|(t, frame)| {
            let m = frame.camera.world_to_camera;
            let r = DMat3::from_cols_array_2d(
                &[0, 1, 2].map(|j| [0, 1, 2].map(|i| f64::from(m[i][j]))),
            );
            let big_t = DVec3::new(f64::from(m[0][3]), f64::from(m[1][3]), f64::from(m[2][3]));
            let t_c = DVec3::from(prior.translation(t));
            let rt = r.transpose();
            NeumanFrame {
                camera: frame.camera,
                rgb: host_f32(&frame.image)
                    .iter()
                    .map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8)
                    .collect(),
                person: host_f32(&frame.mask).iter().map(|&m| m > 0.5).collect(),
                pose: prior.pose(t).to_vec(),
                betas: prior.frame_betas(t)[..NEUMAN_BETAS].to_vec(),
                alignment: Similarity {
                    scale: sigma,
                    rotation: [0, 1, 2].map(|i| rt.row(i).to_array()),
                    translation: (sigma * (rt * t_c) - rt * big_t).to_array(),
                },
                depth: None,
            }
        })
        .collect();
    let points = capture.acting_points.to_sparse();
    write_neuman_scene(root, &frames, &points, test).map_err(|e| Prior4dError::Train(e.into()))?;
    if with_given {
        write_given(capture, root, frame_name)?;
    }
    Ok(())
}
