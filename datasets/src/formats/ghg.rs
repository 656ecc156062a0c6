//! THuman2.0 as rendered by GHG (Generalizable Human Gaussians; the same renderer as
//! GPS-Gaussian), in the layout GHG's `process_dataset/render_image.py` writes and its
//! `CUSTOM_DATASET.md` describes:
//!
//! ```text
//! THuman/
//! ├── THuman2.0_Release/<subject>/   the scans (render_image.py also writes
//! │                                   <subject>_transform.npy here)
//! ├── THuman2.0_smplx/<subject>/smplx_param.pkl   the SMPL-X fits, beside the split folders
//! └── train/, val/                   the split folders: img/, mask/, parm/, depth/, transform/, …
//! ```
//!
//! `<root>` is a split folder (`THuman/val`) holding, per `<s>` = `<subject>_<pid:03>` (16 ring
//! positions per subject) and view `<v>` ∈ 0..5:
//!
//! - `img/<s>/<v>.jpg` (1024², RGB; `<v>_hr.jpg`, written for views 2–4 at 2048², ignored),
//!   `mask/<s>/<v>.png` (0/255, non-zero = person);
//! - `parm/<s>/<v>_intrinsic.npy` (3, 3) and `<v>_extrinsic.npy` (3, 4) `[R | t]`,
//!   world-to-camera with OpenCV axes, metres, world y up. GHG's taichi renderer
//!   (`process_dataset/taichi_three/geometry.py`, `render_triangle`) tests each **integer** pixel
//!   index against the projection `K · x / z` (`transform.py`, `Camera.uncook`), so its pixel
//!   centres sit at integers, OpenCV's convention: ours are at `+0.5`, so `cx = K[0,2] + 0.5`,
//!   `cy = K[1,2] + 0.5` (as for PeopleSnapshot and ZJU-MoCap);
//! - SMPL-X parameters `smplx_param.pkl` (THuman2.0's fits: `betas`, `global_orient`,
//!   `body_pose` (1, 63), hands, jaw, eyes, `expression`, `scale`, `translation`), read from
//!   `<root>/../THuman2.0_smplx/<subject>/` where GHG keeps them (`render_image.py`,
//!   `generate_smplx_obj.py`), else from `<root>/smplx/<subject>/`; and GHG's
//!   `<subject>_transform.npy`, from `<root>/transform/` (`CUSTOM_DATASET.md`'s layout), else
//!   `<root>/../THuman2.0_Release/<subject>/` (where `render_image.py` writes it and
//!   `generate_smplx_obj.py` reads it). Together they place the model in the render's world with
//!   no rotation: `x = k · (scale · x_smplx + translation) + (Δx, −offset, Δz)`, `k =
//!   human_height / (vy_max − vy_min)`; kept as [`Similarity`] `{k · scale, I, k · translation +
//!   (Δx, −offset, Δz)}`. A subject without either file has no valid frame and a
//!   [`Dataset::warnings`] entry naming where it was looked for.
//!
//! Frames are subjects (every view of a subject shows one moment). Splits are GHG's test
//! protocol: `inputs` = view 0 of ring positions 0, 6, 11; `targets` = view 0 of 3, 8, 13.

use super::{
    BodyFrame, Dataset, Format, MaskConvention, PoseTrack, Similarity, ViewRecord, camera_from,
    expect_values, read_npy,
};
use crate::DatasetError;
use splatzoo_models::pickle::{Value, load_npy_object, to_array};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

const INPUT_POSITIONS: [usize; 3] = [0, 6, 11];
const TARGET_POSITIONS: [usize; 3] = [3, 8, 13];

fn values(
    file: &Path,
    v: &Value,
    key: &str,
    expected: &str,
    len: usize,
) -> Result<Vec<f64>, DatasetError> {
    let item = v
        .get(key)
        .ok_or_else(|| DatasetError::field(file, key, format!("missing (expected {expected})")))?;
    let a = to_array(item).map_err(|p| DatasetError::field(file, key, p))?;
    expect_values(file, key, &a.shape, expected, &a.values, len)
}

fn scalar(file: &Path, v: &Value, key: &str) -> Result<f64, DatasetError> {
    let item = v
        .get(key)
        .ok_or_else(|| DatasetError::field(file, key, "missing (expected a number)"))?;
    if let Some(x) = item.as_f64() {
        return Ok(x);
    }
    let a = to_array(item).map_err(|p| DatasetError::field(file, key, p))?;
    Ok(expect_values(file, key, &a.shape, "a number or (1,)", &a.values, 1)?[0])
}

/// The folder holding the split folder (`THuman/` for `THuman/val`).
fn thuman_root(root: &Path) -> PathBuf {
    root.parent()
        .filter(|p| !p.as_os_str().is_empty())
        .map_or_else(|| root.join(".."), Path::to_path_buf)
}

/// The subject's SMPL-X frame, when its parameter and transform files exist; otherwise `None`
/// and a warning saying which is missing and where it was looked for.
fn body(
    root: &Path,
    subject: &str,
    warnings: &mut Vec<(String, String)>,
) -> Result<Option<BodyFrame>, DatasetError> {
    let thuman = thuman_root(root);
    let param_candidates = [
        thuman
            .join("THuman2.0_smplx")
            .join(subject)
            .join("smplx_param.pkl"),
        root.join("smplx").join(subject).join("smplx_param.pkl"),
    ];
    let transform_name = format!("{subject}_transform.npy");
    let transform_candidates = [
        root.join("transform").join(&transform_name),
        thuman
            .join("THuman2.0_Release")
            .join(subject)
            .join(&transform_name),
    ];
    let found = |candidates: &[PathBuf]| candidates.iter().find(|p| p.is_file()).cloned();
    let Some(params) = found(&param_candidates[..]) else {
        warnings.push((
            param_candidates[0].display().to_string(),
            format!(
                "missing, nor at {}: subject {subject} has no SMPL-X fit, so its frame is not \
                 valid",
                param_candidates[1].display()
            ),
        ));
        return Ok(None);
    };
    let Some(transform) = found(&transform_candidates[..]) else {
        warnings.push((
            transform_candidates[0].display().to_string(),
            format!(
                "missing, nor at {}: subject {subject}'s SMPL-X fit ({}) cannot be placed in \
                 the renders without GHG's transform, so its frame is not valid",
                transform_candidates[1].display(),
                params.display()
            ),
        ));
        return Ok(None);
    };
    let p = splatzoo_models::pickle::load(&params).map_err(|e| DatasetError::file(&params, e))?;
    let p = p.item();
    let t = load_npy_object(&transform).map_err(|e| DatasetError::file(&transform, e))?;
    let scale = scalar(&params, p, "scale")?;
    let translation = values(&params, p, "translation", "(1, 3)", 3)?;
    let (top, bottom) = (
        scalar(&transform, &t, "vy_max")?,
        scalar(&transform, &t, "vy_min")?,
    );
    let height = scalar(&transform, &t, "human_height")?;
    if top - bottom <= 0.0 {
        return Err(DatasetError::field(
            &transform,
            "vy_max",
            "not above vy_min",
        ));
    }
    let k = height / (top - bottom);
    let shift = [
        scalar(&transform, &t, "move_delta_axis_0")?,
        -scalar(&transform, &t, "offset")?,
        scalar(&transform, &t, "move_delta_axis_2")?,
    ];
    let go = values(&params, p, "global_orient", "(1, 3)", 3)?;
    let mut extra = BTreeMap::new();
    for key in [
        "left_hand_pose",
        "right_hand_pose",
        "jaw_pose",
        "leye_pose",
        "reye_pose",
        "expression",
    ] {
        if let Some(v) = p.get(key) {
            let a = to_array(v).map_err(|e| DatasetError::field(&params, key, e))?;
            let n = a.values.len();
            extra.insert(
                key.to_owned(),
                expect_values(&params, key, &a.shape, "finite values", &a.values, n)?,
            );
        }
    }
    Ok(Some(BodyFrame {
        global_orient: [go[0], go[1], go[2]],
        body_pose: values(&params, p, "body_pose", "(1, 63)", 63)?,
        betas: {
            let item = p
                .get("betas")
                .ok_or_else(|| DatasetError::field(&params, "betas", "missing"))?;
            let a = to_array(item).map_err(|e| DatasetError::field(&params, "betas", e))?;
            let n = a.values.len();
            expect_values(&params, "betas", &a.shape, "(1, B)", &a.values, n)?
        },
        transl: [0.0; 3],
        world_from_smpl: Similarity {
            scale: k * scale,
            rotation: Similarity::IDENTITY.rotation,
            translation: std::array::from_fn(|i| k * translation[i] + shift[i]),
        },
        root_position: None,
        extra,
    }))
}

pub fn load(root: &Path) -> Result<Dataset, DatasetError> {
    let img = root.join("img");
    let mut folders: Vec<String> = std::fs::read_dir(&img)
        .map_err(|e| DatasetError::file(&img, format!("cannot list ({e})")))?
        .filter_map(|e| e.ok())
        .filter(|e| e.path().is_dir())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    folders.sort();
    let mut subjects: Vec<String> = Vec::new();
    let mut views = Vec::new();
    let mut splits: BTreeMap<String, Vec<usize>> = BTreeMap::new();
    for folder in &folders {
        let (subject, position) = folder
            .rsplit_once('_')
            .and_then(|(s, p)| Some((s.to_owned(), p.parse::<usize>().ok()?)))
            .ok_or_else(|| {
                DatasetError::file(
                    &img.join(folder),
                    "expected a folder named <subject>_<position>, e.g. 0004_003",
                )
            })?;
        if subjects.last() != Some(&subject) {
            subjects.push(subject.clone());
        }
        let frame = subjects.len() - 1;
        let mut names: Vec<(usize, std::path::PathBuf)> = std::fs::read_dir(img.join(folder))
            .map_err(|e| DatasetError::file(&img.join(folder), format!("cannot list ({e})")))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter_map(|p| Some((p.file_stem()?.to_str()?.parse().ok()?, p)))
            .collect();
        names.sort();
        for (v, image) in names {
            let parm = root.join("parm").join(folder);
            let k_path = parm.join(format!("{v}_intrinsic.npy"));
            let e_path = parm.join(format!("{v}_extrinsic.npy"));
            let k = read_npy(&k_path)?;
            let k = expect_values(&k_path, "intrinsic", &k.shape, "(3, 3)", &k.values, 9)?;
            let e = read_npy(&e_path)?;
            let e = expect_values(&e_path, "extrinsic", &e.shape, "(3, 4)", &e.values, 12)?;
            let size = image::image_dimensions(&image).map_err(|err| {
                DatasetError::file(&image, format!("cannot read the image header ({err})"))
            })?;
            let mask = root.join("mask").join(folder).join(format!("{v}.png"));
            if v == 0 {
                let role = if INPUT_POSITIONS.contains(&position) {
                    Some("inputs")
                } else if TARGET_POSITIONS.contains(&position) {
                    Some("targets")
                } else {
                    None
                };
                if let Some(role) = role {
                    splits.entry(role.to_owned()).or_default().push(views.len());
                }
            }
            views.push(ViewRecord {
                frame,
                camera_name: format!("{position:03}/{v}"),
                // GHG's renderer: pixel centres at integers → ours at +0.5.
                camera: camera_from(
                    [k[0], k[4], k[2] + 0.5, k[5] + 0.5],
                    size,
                    std::array::from_fn(|i| std::array::from_fn(|j| e[4 * i + j])),
                    [e[3], e[7], e[11]],
                ),
                distortion: Default::default(),
                image,
                mask: mask.is_file().then_some(mask),
                mask_convention: MaskConvention::NonZeroIsPerson,
                other_masks: Default::default(),
                depth: None,
            });
        }
    }
    let mut warnings = Vec::new();
    let mut people = Vec::with_capacity(subjects.len());
    for (f, subject) in subjects.iter().enumerate() {
        let mut frames = vec![None; subjects.len()];
        frames[f] = body(root, subject, &mut warnings)?;
        people.push(PoseTrack {
            person: subject.clone(),
            frames,
        });
    }
    Ok(Dataset {
        format: Format::Ghg,
        frame_times: Vec::new(),
        root: root.to_path_buf(),
        frame_count: subjects.len(),
        views,
        people,
        splits,
        points: Vec::new(),
        boxes: Vec::new(),
        warnings,
        image_downscale: 1,
    })
}
