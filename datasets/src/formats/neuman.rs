//! NeuMan scene folders (apple/ml-neuman), as its `neuman_helper.py` reads them:
//!
//! - `sparse/{cameras,images,points3D}.txt`: a COLMAP text model ([`super::colmap`]); the world
//!   is COLMAP's, in its own unit (NeuMan rescales it at load time by `3.14 / p95(far)`; we keep
//!   COLMAP's unit and leave scaling to the user).
//! - `images/<NAME>`, sorted by name; the frame index is the number in the name (`00012.png` →
//!   12), which is also the SMPL index.
//! - `segmentations/<NAME>.npy` (an (H, W) array) where present, which `neuman_helper.py`'s
//!   `read_captures` prefers, else `segmentations/<NAME>` (NeuMan's detectron2 `demo.py` writes
//!   it, and a copy as `<NAME>.png`): **0 is the person, 255 the background** in both (the
//!   segmenter saves `(1 − mask)·255`; the helper's `mask` property requires a maximum of 255,
//!   maps 255 to background and inverts) → [`MaskConvention::ZeroIsPerson`]. A mask without a
//!   person pixel is a problem: the helper asserts one.
//! - `smpl_output_optimized.pkl` (else `smpl_output_romp.pkl`), a joblib dump of
//!   `{1: {'pose': [N × (72,)], 'betas': [N × (10,)], …}}`: SMPL axis-angle with the global
//!   orientation in `pose[0:3]`, no translation.
//! - `alignments.npy`: `{NAME: A (4, 3)}`, applied by NeuMan to row vectors, `[x, 1] · A`, so
//!   `x_world = Aᵀ[:, :3] x + A[3]`; the 3×3 block is `s · R` with a per-frame scale `s`, kept as
//!   [`Similarity`] `{s, R, A[3]}` in [`BodyFrame::world_from_smpl`]. Frames without an
//!   alignment are not valid.
//! - `{train,val,test}_split.txt`: one image name per line (written by NeuMan's trainer).
//! - `depth_maps/<NAME>.npy` (else `depth_maps/<stem>.npy`), where present: NeuMan's dense
//!   depth of each image, an (H, W) array of z-depth along the camera's axis in COLMAP's unit,
//!   0 where unknown → [`ViewRecord::depth`] (read by `splatzoo_train::views::dataset::read_depth`).

use super::colmap::{read_cameras, read_images, read_points};
use super::{
    BodyFrame, Dataset, Format, MaskConvention, PoseTrack, Similarity, ViewRecord, expect_values,
};
use crate::DatasetError;
use splatzoo_models::pickle::{Value, load_npy_object, to_array};
use std::collections::BTreeMap;
use std::path::Path;

/// The frame number in a NeuMan image name (`00012.png` → 12).
pub fn frame_number(name: &str) -> Option<usize> {
    Path::new(name).file_stem()?.to_str()?.parse().ok()
}

/// Per-frame arrays of `key` (`list of (len,)` or one `(N, len)` array).
fn per_frame(
    file: &Path,
    person: &Value,
    key: &str,
    len: usize,
) -> Result<Vec<Vec<f64>>, DatasetError> {
    let field = format!("1.{key}");
    let value = person
        .get(key)
        .ok_or_else(|| DatasetError::field(file, &field, "missing"))?;
    let bad = |p: String| DatasetError::field(file, &field, p);
    let expected = format!("({len},) per frame");
    match value.items() {
        Some(items) => items
            .iter()
            .enumerate()
            .map(|(k, item)| {
                let a = to_array(item).map_err(|p| bad(format!("frame {k}: {p}")))?;
                expect_values(
                    file,
                    &format!("{field}[{k}]"),
                    &a.shape,
                    &expected,
                    &a.values,
                    len,
                )
            })
            .collect(),
        None => {
            let a = to_array(value).map_err(bad)?;
            if a.shape.len() != 2 || a.shape[1] != len {
                return Err(bad(format!("shape {:?}, expected (N, {len})", a.shape)));
            }
            a.values
                .chunks(len)
                .enumerate()
                .map(|(k, row)| {
                    expect_values(file, &format!("{field}[{k}]"), &[len], &expected, row, len)
                })
                .collect()
        }
    }
}

pub fn load(root: &Path) -> Result<Dataset, DatasetError> {
    let sparse = root.join("sparse");
    let intrinsics = read_cameras(&sparse.join("cameras.txt"))?;
    let mut images = read_images(&sparse.join("images.txt"))?;
    images.sort_by(|a, b| a.name.cmp(&b.name));
    let images_path = sparse.join("images.txt");
    let mut views = Vec::with_capacity(images.len());
    for image in &images {
        let k = intrinsics.get(&image.camera_id).ok_or_else(|| {
            DatasetError::field(
                &images_path,
                &image.name,
                format!("CAMERA_ID {} is not in cameras.txt", image.camera_id),
            )
        })?;
        let frame = frame_number(&image.name).ok_or_else(|| {
            DatasetError::field(
                &images_path,
                &image.name,
                "expected a numbered image name such as 00012.png",
            )
        })?;
        // neuman_helper.py: `<NAME>.npy` first, else the image-named PNG.
        let segmentations = root.join("segmentations");
        let mask = [
            segmentations.join(format!("{}.npy", image.name)),
            segmentations.join(&image.name),
        ]
        .into_iter()
        .find(|p| p.is_file());
        let depth_maps = root.join("depth_maps");
        let stem = Path::new(&image.name)
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let depth = [
            depth_maps.join(format!("{}.npy", image.name)),
            depth_maps.join(format!("{stem}.npy")),
        ]
        .into_iter()
        .find(|p| p.is_file());
        views.push(ViewRecord {
            frame,
            camera_name: image.name.clone(),
            camera: image.camera(k),
            distortion: k.distortion,
            image: root.join("images").join(&image.name),
            mask,
            mask_convention: MaskConvention::ZeroIsPerson,
            other_masks: Default::default(),
            depth,
        });
    }
    let frame_count = views.iter().map(|v| v.frame + 1).max().unwrap_or(0);

    let smpl_path = ["smpl_output_optimized.pkl", "smpl_output_romp.pkl"]
        .iter()
        .map(|n| root.join(n))
        .find(|p| p.is_file())
        .ok_or_else(|| {
            DatasetError::file(
                &root.join("smpl_output_optimized.pkl"),
                "missing (nor smpl_output_romp.pkl)",
            )
        })?;
    let smpl =
        splatzoo_models::pickle::load(&smpl_path).map_err(|p| DatasetError::file(&smpl_path, p))?;
    let people = smpl.keys();
    if people.len() != 1 {
        return Err(DatasetError::file(
            &smpl_path,
            format!("expected one person (key 1), found keys {people:?}"),
        ));
    }
    let person = smpl.get(&people[0]).expect("listed key");
    let poses = per_frame(&smpl_path, person, "pose", 72)?;
    let betas = per_frame(&smpl_path, person, "betas", 10)?;
    if poses.len() != betas.len() {
        return Err(DatasetError::field(
            &smpl_path,
            "1.betas",
            format!("{} frames, but `pose` has {}", betas.len(), poses.len()),
        ));
    }

    let align_path = root.join("alignments.npy");
    let alignments =
        load_npy_object(&align_path).map_err(|p| DatasetError::file(&align_path, p))?;
    let mut frames = vec![None; frame_count.max(poses.len())];
    for view in &views {
        let name = &view.camera_name;
        let Some(a) = alignments.get(name) else {
            continue;
        };
        let a = to_array(a).map_err(|p| DatasetError::field(&align_path, name, p))?;
        let a = expect_values(&align_path, name, &a.shape, "(4, 3)", &a.values, 12)?;
        let pose = poses.get(view.frame).ok_or_else(|| {
            DatasetError::field(
                &smpl_path,
                "1.pose",
                format!(
                    "no entry for frame {} ({name}); {} frames",
                    view.frame,
                    poses.len()
                ),
            )
        })?;
        // Row-vector form: x_world = [x, 1] · A, i.e. M = A[:3]ᵀ, t = A[3].
        let m: [[f64; 3]; 3] = std::array::from_fn(|i| std::array::from_fn(|j| a[3 * j + i]));
        let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
        if det <= 0.0 {
            return Err(DatasetError::field(
                &align_path,
                name,
                "the 3×3 block is not a scaled rotation (determinant ≤ 0)",
            ));
        }
        let scale = det.cbrt();
        frames[view.frame] = Some(BodyFrame {
            global_orient: [pose[0], pose[1], pose[2]],
            body_pose: pose[3..].to_vec(),
            betas: betas[view.frame].clone(),
            transl: [0.0; 3],
            world_from_smpl: Similarity {
                scale,
                rotation: m.map(|r| r.map(|v| v / scale)),
                translation: [a[9], a[10], a[11]],
            },
            extra: Default::default(),
            root_position: None,
        });
    }

    let mut splits = BTreeMap::new();
    for split in ["train", "val", "test"] {
        let path = root.join(format!("{split}_split.txt"));
        let Ok(text) = std::fs::read_to_string(&path) else {
            continue;
        };
        let mut indices = Vec::new();
        for (line, name) in text.lines().enumerate().map(|(i, l)| (i + 1, l.trim())) {
            if name.is_empty() {
                continue;
            }
            let index = views
                .iter()
                .position(|v| v.camera_name == name)
                .ok_or_else(|| {
                    DatasetError::field(
                        &path,
                        &format!("line {line}"),
                        format!("{name} is not an image of sparse/images.txt"),
                    )
                })?;
            indices.push(index);
        }
        splits.insert(split.to_owned(), indices);
    }
    let points_path = sparse.join("points3D.txt");
    let points = if points_path.is_file() {
        read_points(&points_path)?
    } else {
        Vec::new()
    };
    Ok(Dataset {
        format: Format::Neuman,
        frame_times: Vec::new(),
        root: root.to_path_buf(),
        frame_count,
        views,
        people: vec![PoseTrack {
            person: people[0].clone(),
            frames,
        }],
        splits,
        points,
        boxes: Vec::new(),
        warnings: Vec::new(),
        image_downscale: 1,
    })
}
