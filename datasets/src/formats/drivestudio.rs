//! drivestudio's processed Waymo scenes (`data/waymo/processed/training/NNN/`), as its
//! `waymo_sourceloader.py` reads them:
//!
//! - `ego_pose/{t:03}.txt`: ego(vehicle) → Waymo global world at frame t, a row-major 4×4
//!   (`np.savetxt`); frames are these files. The world is re-centred on the first frame's ego
//!   pose `E₀`, as drivestudio does: `world ← E₀⁻¹ · global` (a rigid change of frame; the new
//!   world is the first ego frame: x forward, y left, z up, metres).
//! - `extrinsics/{cam}.txt`: camera → ego in **Waymo's camera axes** (x forward, y left, z up);
//!   `intrinsics/{cam}.txt`: `fx fy cx cy k1 k2 p1 p2 k3` at full resolution (one per line, or
//!   on one line). Camera ids are Waymo's minus one: 0 FRONT, 1 FRONT_LEFT, 2 FRONT_RIGHT,
//!   3 SIDE_LEFT, 4 SIDE_RIGHT. OpenCV camera → world: `E₀⁻¹ · E_t · extrinsic · C` with
//!   `C = [[0,0,1,0],[−1,0,0,0],[0,−1,0,0],[0,0,0,1]]` (OpenCV z → Waymo x, x → −y, y → −z);
//!   world-to-camera is its inverse. drivestudio casts rays through `x − cx + 0.5`, so its
//!   principal point is already in our `+0.5` convention.
//! - `images/{t:03}_{cam}.jpg` (size from the file); masks `fine_dynamic_masks/human/…png`
//!   where that folder exists, else `dynamic_masks/human/…png` (0/255, non-zero = person; box
//!   masks of moving pedestrians and cyclists); beside it, as further masks, `sky_masks/`, and
//!   the `vehicle` and `all` (→ `dynamic`) dynamic masks. `waymo_preprocess.py`
//!   (`save_dynamic_mask`) writes all three classes for **every** image: the projected 3D boxes
//!   of the class's labels whose speed exceeds 1 m/s, thresholded to 0/255, so a human mask is
//!   all zero wherever no pedestrian or cyclist moves, which is most of a real scene. An empty
//!   human mask is valid data here: [`super::check`] reports it as a warning, not a problem.
//! - `instances/instances_info.json`: per instance key `{id, class_name, frame_annotations:
//!   {frame_idx, obj_to_world (4×4 per frame, Waymo global), box_size (l, w, h)}}`, re-centred
//!   like the cameras; `instances/frame_instances.json`: instance keys per frame.
//! - `humanpose/smpl.pkl` (joblib of torch tensors, per instance key): `smpl.global_orient`
//!   [F, 1, 3, 3] and `smpl.body_pose` [F, 23, 3, 3] **rotation matrices** (→ axis-angle here),
//!   `smpl.betas` `[F, 10]`, `selected_cam_idx` `[F]`, `valid_mask` `[F]`. The global orientation is
//!   in the OpenCV frame of camera `selected_cam_idx[t]`, so `world_from_smpl` carries that
//!   camera's camera-to-world rotation; drivestudio puts the root at the person's box centre
//!   ([`BodyFrame::root_position`]).
//! - `lidar/{t:03}.bin`: the LiDAR returns of frame t, read apart from the dataset by
//!   [`lidar`] (a method that wants depth asks for them).

use super::{
    BodyFrame, Dataset, Distortion, Format, InstanceBox, MaskConvention, PoseTrack, Similarity,
    ViewRecord, camera_from, expect_values,
};
use crate::DatasetError;
use splatzoo_models::pickle::{Value, to_array};
pub use splatzoo_models::rotation_scalar::matrix_axis_angle;
use std::collections::BTreeMap;
use std::path::Path;

type Matrix = [[f64; 4]; 4];

/// OpenCV camera axes → Waymo camera axes.
const OPENCV_TO_WAYMO: Matrix = [
    [0.0, 0.0, 1.0, 0.0],
    [-1.0, 0.0, 0.0, 0.0],
    [0.0, -1.0, 0.0, 0.0],
    [0.0, 0.0, 0.0, 1.0],
];

fn multiply(a: &Matrix, b: &Matrix) -> Matrix {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..4).map(|k| a[i][k] * b[k][j]).sum()))
}

/// The inverse of a rigid transform.
fn rigid_inverse(m: &Matrix) -> Matrix {
    let mut out = [[0.0; 4]; 4];
    for i in 0..3 {
        for j in 0..3 {
            out[i][j] = m[j][i];
        }
        out[i][3] = -(0..3).map(|k| m[k][i] * m[k][3]).sum::<f64>();
    }
    out[3][3] = 1.0;
    out
}

/// Whitespace-separated numbers of a text file: exactly `count`, finite.
fn numbers(path: &Path, count: usize, expected: &str) -> Result<Vec<f64>, DatasetError> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| DatasetError::file(path, format!("cannot read ({e})")))?;
    let values: Option<Vec<f64>> = text.split_whitespace().map(|v| v.parse().ok()).collect();
    let values = values
        .ok_or_else(|| DatasetError::file(path, format!("not numbers (expected {expected})")))?;
    expect_values(path, "values", &[values.len()], expected, &values, count)
}

fn matrix_file(path: &Path) -> Result<Matrix, DatasetError> {
    let v = numbers(path, 16, "a row-major 4×4 matrix")?;
    let m: Matrix = std::array::from_fn(|i| std::array::from_fn(|j| v[4 * i + j]));
    rigid(path, "values", m)
}

/// Checks the last row and the rotation block of a rigid transform.
fn rigid(path: &Path, key: &str, m: Matrix) -> Result<Matrix, DatasetError> {
    let orthonormal = (0..3).all(|i| {
        (0..3).all(|j| {
            let d: f64 = (0..3).map(|k| m[k][i] * m[k][j]).sum();
            (d - if i == j { 1.0 } else { 0.0 }).abs() < 1e-3
        })
    });
    if m[3] != [0.0, 0.0, 0.0, 1.0] || !orthonormal {
        return Err(DatasetError::field(
            path,
            key,
            "expected a rigid 4×4 transform (orthonormal rotation, last row 0 0 0 1)",
        ));
    }
    Ok(m)
}

fn json(path: &Path) -> Result<serde_json::Value, DatasetError> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| DatasetError::file(path, format!("cannot read ({e})")))?;
    serde_json::from_str(&text).map_err(|e| DatasetError::file(path, format!("not JSON ({e})")))
}

/// The frame numbers on disk (sorted) and each frame's ego → Waymo-global pose.
fn ego_poses(root: &Path) -> Result<(Vec<usize>, Vec<Matrix>), DatasetError> {
    let ego_dir = root.join("ego_pose");
    let mut frame_numbers: Vec<usize> = std::fs::read_dir(&ego_dir)
        .map_err(|e| DatasetError::file(&ego_dir, format!("cannot list ({e})")))?
        .filter_map(|e| e.ok())
        .filter_map(|e| e.path().file_stem()?.to_str()?.parse().ok())
        .collect();
    frame_numbers.sort_unstable();
    if frame_numbers.is_empty() {
        return Err(DatasetError::file(
            &ego_dir,
            "holds no {t:03}.txt ego poses",
        ));
    }
    let ego: Vec<Matrix> = frame_numbers
        .iter()
        .map(|t| matrix_file(&ego_dir.join(format!("{t:03}.txt"))))
        .collect::<Result<_, _>>()?;
    Ok((frame_numbers, ego))
}

/// Values per LiDAR return in `lidar/{t:03}.bin` (float32): origin (3), point (3), flow (3),
/// flow class, ground label, intensity, elongation, laser id.
const LIDAR_VALUES: usize = 14;

/// Each frame's LiDAR returns in the re-centred world (metres), from drivestudio's
/// `lidar/{t:03}.bin` (the `N × 14` float32 rows its preprocessing writes, points in the ego
/// frame of that timestep: `world = E₀⁻¹ · E_t · p`); `None` for a frame without a file. Every
/// return of every laser is kept (drivestudio's `only_use_top_lidar` is off by default).
pub fn lidar(root: &Path) -> Result<Vec<Option<Vec<[f64; 3]>>>, DatasetError> {
    let (frame_numbers, ego) = ego_poses(root)?;
    let recentre = rigid_inverse(&ego[0]);
    frame_numbers
        .iter()
        .zip(&ego)
        .map(|(t, e)| {
            let path = root.join(format!("lidar/{t:03}.bin"));
            if !path.is_file() {
                return Ok(None);
            }
            let bytes = std::fs::read(&path)
                .map_err(|e| DatasetError::file(&path, format!("cannot read ({e})")))?;
            let row = 4 * LIDAR_VALUES;
            if bytes.len() % row != 0 {
                return Err(DatasetError::file(
                    &path,
                    format!(
                        "{} bytes, expected float32 rows of {LIDAR_VALUES} values ({row} bytes each)",
                        bytes.len()
                    ),
                ));
            }
            let to_world = multiply(&recentre, e);
            let mut points = Vec::with_capacity(bytes.len() / row);
            for (k, r) in bytes.chunks_exact(row).enumerate() {
                let value =
                    |i: usize| f32::from_le_bytes(r[4 * i..4 * i + 4].try_into().expect("4 bytes"));
                let p = [value(3) as f64, value(4) as f64, value(5) as f64];
                if !p.iter().all(|v| v.is_finite()) {
                    return Err(DatasetError::field(
                        &path,
                        &format!("row {k}"),
                        "a non-finite point (values 3..6)",
                    ));
                }
                points.push(std::array::from_fn(|i| {
                    (0..3).map(|j| to_world[i][j] * p[j]).sum::<f64>() + to_world[i][3]
                }));
            }
            Ok(Some(points))
        })
        .collect()
}

pub fn load(root: &Path) -> Result<Dataset, DatasetError> {
    let (frame_numbers, ego) = ego_poses(root)?;
    let recentre = rigid_inverse(&ego[0]);
    let mut cameras = Vec::new();
    for cam in 0..5 {
        let extrinsic = root.join(format!("extrinsics/{cam}.txt"));
        if !extrinsic.is_file() {
            continue;
        }
        let e = matrix_file(&extrinsic)?;
        let k = numbers(
            &root.join(format!("intrinsics/{cam}.txt")),
            9,
            "fx fy cx cy k1 k2 p1 p2 k3",
        )?;
        cameras.push((cam, multiply(&e, &OPENCV_TO_WAYMO), k));
    }
    let dynamic = if root.join("fine_dynamic_masks").is_dir() {
        root.join("fine_dynamic_masks")
    } else {
        root.join("dynamic_masks")
    };
    let human_masks = dynamic.join("human");
    let mut views = Vec::new();
    let mut camera_to_world: BTreeMap<(usize, usize), Matrix> = BTreeMap::new();
    for (cam, opencv_to_ego, k) in &cameras {
        let cam = *cam;
        let mut size = None;
        for (f, t) in frame_numbers.iter().enumerate() {
            let image = root.join(format!("images/{t:03}_{cam}.jpg"));
            let s = match size {
                Some(s) => s,
                None => {
                    let s = image::image_dimensions(&image).map_err(|e| {
                        DatasetError::file(&image, format!("cannot read the image header ({e})"))
                    })?;
                    size = Some(s);
                    s
                }
            };
            let c2w = multiply(&recentre, &multiply(&ego[f], opencv_to_ego));
            camera_to_world.insert((f, cam), c2w);
            let w2c = rigid_inverse(&c2w);
            let file = format!("{t:03}_{cam}.png");
            let mask = human_masks.join(&file);
            let other_masks = [
                ("sky", root.join("sky_masks")),
                ("vehicle", dynamic.join("vehicle")),
                ("dynamic", dynamic.join("all")),
            ]
            .into_iter()
            .map(|(name, dir)| (name.to_owned(), dir.join(&file)))
            .filter(|(_, path)| path.is_file())
            .collect();
            views.push(ViewRecord {
                frame: f,
                camera_name: cam.to_string(),
                camera: camera_from(
                    [k[0], k[1], k[2], k[3]],
                    s,
                    std::array::from_fn(|i| std::array::from_fn(|j| w2c[i][j])),
                    [w2c[0][3], w2c[1][3], w2c[2][3]],
                ),
                distortion: Distortion {
                    k1: k[4],
                    k2: k[5],
                    p1: k[6],
                    p2: k[7],
                    k3: k[8],
                },
                image,
                mask: mask.is_file().then_some(mask),
                mask_convention: MaskConvention::NonZeroIsPerson,
                other_masks,
                depth: None,
            });
        }
    }
    let frame_of = |t: usize| frame_numbers.binary_search(&t).ok();
    let boxes = read_boxes(root, &recentre, &frame_of)?;
    let people = read_people(
        root,
        frame_numbers.len(),
        &frame_of,
        &camera_to_world,
        &boxes,
    )?;
    Ok(Dataset {
        format: Format::Drivestudio,
        frame_times: Vec::new(),
        root: root.to_path_buf(),
        frame_count: frame_numbers.len(),
        views,
        people,
        splits: BTreeMap::new(),
        points: Vec::new(),
        boxes,
        warnings: Vec::new(),
        image_downscale: 1,
    })
}

fn read_boxes(
    root: &Path,
    recentre: &Matrix,
    frame_of: &dyn Fn(usize) -> Option<usize>,
) -> Result<Vec<InstanceBox>, DatasetError> {
    let path = root.join("instances/instances_info.json");
    if !path.is_file() {
        return Ok(Vec::new());
    }
    let info = json(&path)?;
    let instances = info
        .as_object()
        .ok_or_else(|| DatasetError::file(&path, "expected an object keyed by instance"))?;
    let mut boxes = Vec::new();
    for (key, instance) in instances {
        let field = |name: &str| format!("{key}.{name}");
        let class = instance["class_name"]
            .as_str()
            .ok_or_else(|| DatasetError::field(&path, &field("class_name"), "expected a string"))?;
        let annotations = &instance["frame_annotations"];
        let list = |name: &str| {
            annotations[name].as_array().ok_or_else(|| {
                DatasetError::field(
                    &path,
                    &field(&format!("frame_annotations.{name}")),
                    "expected a list",
                )
            })
        };
        let (frames, poses, sizes) = (list("frame_idx")?, list("obj_to_world")?, list("box_size")?);
        if poses.len() != frames.len() || sizes.len() != frames.len() {
            return Err(DatasetError::field(
                &path,
                &field("frame_annotations"),
                "frame_idx, obj_to_world and box_size differ in length",
            ));
        }
        for (k, ((t, pose), size)) in frames.iter().zip(poses).zip(sizes).enumerate() {
            let at = |name: &str| field(&format!("frame_annotations.{name}[{k}]"));
            let t = t.as_u64().ok_or_else(|| {
                DatasetError::field(&path, &at("frame_idx"), "expected a frame number")
            })?;
            let Some(frame) = frame_of(t as usize) else {
                continue; // outside the frames on disk
            };
            let m: Option<Vec<f64>> =
                pose.as_array()
                    .filter(|rows| rows.len() == 4)
                    .and_then(|rows| {
                        rows.iter()
                            .flat_map(|r| r.as_array().cloned().unwrap_or_default())
                            .map(|v| v.as_f64())
                            .collect()
                    });
            let m = m.filter(|m| m.len() == 16).ok_or_else(|| {
                DatasetError::field(&path, &at("obj_to_world"), "expected a 4×4 list of numbers")
            })?;
            let m = rigid(
                &path,
                &at("obj_to_world"),
                std::array::from_fn(|i| std::array::from_fn(|j| m[4 * i + j])),
            )?;
            let size: Option<Vec<f64>> = size
                .as_array()
                .and_then(|s| s.iter().map(|v| v.as_f64()).collect());
            let size = size.filter(|s| s.len() == 3 && s.iter().all(|v| v.is_finite() && *v > 0.0));
            let size = size.ok_or_else(|| {
                DatasetError::field(
                    &path,
                    &at("box_size"),
                    "expected [length, width, height] > 0",
                )
            })?;
            boxes.push(InstanceBox {
                instance: key.clone(),
                class: class.to_owned(),
                frame,
                object_to_world: multiply(recentre, &m),
                size: [size[0], size[1], size[2]],
            });
        }
    }
    let frames_path = root.join("instances/frame_instances.json");
    if frames_path.is_file() {
        let listed = json(&frames_path)?;
        let listed = listed
            .as_object()
            .ok_or_else(|| DatasetError::file(&frames_path, "expected an object keyed by frame"))?;
        for (t, ids) in listed {
            for id in ids.as_array().into_iter().flatten() {
                let key = id
                    .as_u64()
                    .map(|v| v.to_string())
                    .or_else(|| id.as_str().map(str::to_owned));
                if !key.is_some_and(|k| instances.contains_key(&k)) {
                    return Err(DatasetError::field(
                        &frames_path,
                        t,
                        format!("instance {id} is not in instances_info.json"),
                    ));
                }
            }
        }
    }
    Ok(boxes)
}

fn tensor(
    file: &Path,
    v: &Value,
    key: &str,
    shape: &[usize],
    expected: &str,
) -> Result<Vec<f64>, DatasetError> {
    let a = to_array(v).map_err(|p| DatasetError::field(file, key, p))?;
    if a.shape != shape {
        return Err(DatasetError::field(
            file,
            key,
            format!("shape {:?}, expected {expected}", a.shape),
        ));
    }
    let n = a.values.len();
    expect_values(file, key, &a.shape, expected, &a.values, n)
}

fn read_people(
    root: &Path,
    frame_count: usize,
    frame_of: &dyn Fn(usize) -> Option<usize>,
    camera_to_world: &BTreeMap<(usize, usize), Matrix>,
    boxes: &[InstanceBox],
) -> Result<Vec<PoseTrack>, DatasetError> {
    let path = root.join("humanpose/smpl.pkl");
    if !path.is_file() {
        return Ok(Vec::new());
    }
    let data = splatzoo_models::pickle::load(&path).map_err(|p| DatasetError::file(&path, p))?;
    let mut people = Vec::new();
    for key in data.keys() {
        let person = data.get(&key).expect("listed key");
        let field = |name: &str| format!("{key}.{name}");
        let smpl = person
            .get("smpl")
            .ok_or_else(|| DatasetError::field(&path, &field("smpl"), "missing"))?;
        let get = |v: &Value, name: &str, full: &str| {
            v.get(name)
                .ok_or_else(|| DatasetError::field(&path, full, "missing"))
                .cloned()
        };
        let betas_v = get(smpl, "betas", &field("smpl.betas"))?;
        let f = to_array(&betas_v)
            .map_err(|p| DatasetError::field(&path, &field("smpl.betas"), p))?
            .shape
            .first()
            .copied()
            .unwrap_or(0);
        let orient = tensor(
            &path,
            &get(smpl, "global_orient", &field("smpl.global_orient"))?,
            &field("smpl.global_orient"),
            &[f, 1, 3, 3],
            "[F, 1, 3, 3]",
        )?;
        let body = tensor(
            &path,
            &get(smpl, "body_pose", &field("smpl.body_pose"))?,
            &field("smpl.body_pose"),
            &[f, 23, 3, 3],
            "[F, 23, 3, 3]",
        )?;
        let betas = tensor(&path, &betas_v, &field("smpl.betas"), &[f, 10], "[F, 10]")?;
        let camera = tensor(
            &path,
            &get(person, "selected_cam_idx", &field("selected_cam_idx"))?,
            &field("selected_cam_idx"),
            &[f],
            "[F]",
        )?;
        let valid = tensor(
            &path,
            &get(person, "valid_mask", &field("valid_mask"))?,
            &field("valid_mask"),
            &[f],
            "[F]",
        )?;
        let matrix = |values: &[f64]| -> [[f64; 3]; 3] {
            std::array::from_fn(|i| std::array::from_fn(|j| values[3 * i + j]))
        };
        let mut frames = vec![None; frame_count];
        for t in 0..f {
            let Some(frame) = frame_of(t) else { continue };
            if valid[t] == 0.0 {
                continue;
            }
            let cam = camera[t];
            let c2w = camera_to_world
                .get(&(frame, cam as usize))
                .filter(|_| cam >= 0.0)
                .ok_or_else(|| {
                    DatasetError::field(
                        &path,
                        &field(&format!("selected_cam_idx[{t}]")),
                        format!("camera {cam} has no view in frame {t}"),
                    )
                })?;
            let centre = boxes
                .iter()
                .find(|b| b.instance == key && b.frame == frame)
                .map(|b| {
                    [
                        b.object_to_world[0][3],
                        b.object_to_world[1][3],
                        b.object_to_world[2][3],
                    ]
                })
                .ok_or_else(|| {
                    DatasetError::field(
                        &path,
                        &field(&format!("valid_mask[{t}]")),
                        "valid, but the instance has no box in that frame",
                    )
                })?;
            let go = matrix(&orient[9 * t..9 * t + 9]);
            let body_pose = (0..23)
                .flat_map(|j| {
                    matrix_axis_angle(&matrix(&body[(t * 23 + j) * 9..(t * 23 + j) * 9 + 9]))
                })
                .collect();
            frames[frame] = Some(BodyFrame {
                global_orient: matrix_axis_angle(&go),
                body_pose,
                betas: betas[10 * t..10 * t + 10].to_vec(),
                transl: [0.0; 3],
                world_from_smpl: Similarity {
                    scale: 1.0,
                    rotation: std::array::from_fn(|i| std::array::from_fn(|j| c2w[i][j])),
                    translation: [0.0; 3],
                },
                root_position: Some(centre),
                extra: Default::default(),
            });
        }
        people.push(PoseTrack {
            person: key,
            frames,
        });
    }
    Ok(people)
}
