//! ZJU-MoCap (`CoreView_*`, as neuralbody reads it) and its refined layout (`my_*`, as
//! instant-nvr and GauHuman read it).
//!
//! - `annots.npy` (a pickled dict): `cams` = `{K, D, R, T}`, one entry per camera: `K` (3, 3)
//!   OpenCV intrinsics, `D` (5, 1) `k1 k2 p1 p2 k3`, `R` (3, 3) and `T` (3, 1) world-to-camera
//!   with **`T` in millimetres** (→ metres here). OpenCV puts pixel centres at integers, we at
//!   `+0.5`: `cx = K[0,2] + 0.5`, `cy = K[1,2] + 0.5`. `ims` = one `{ims: [path per camera]}`
//!   per frame: a list of `str` as neuralbody's `tools/custom/get_annots.py` writes it
//!   (`.tolist()` of its sorted, stacked glob), or the numpy string array (`<U…`) that the same
//!   script writes without `.tolist()`; both read alike ([`to_strings`]).
//! - Original layout: `Camera_B1/000000.jpg` (or `Camera (1)/CoreView_313_Camera_(1)_0001_….jpg`
//!   for 313/315, whose frame number is the fifth `_` field, 1-based); masks
//!   `mask_cihp/<same>.png`, else `mask/<same>.png`. Refined layout: `images/<cc>/<ffffff>.jpg`,
//!   masks `mask/<cc>/<ffffff>.png`. Non-zero mask pixels are the person.
//! - Parameters `new_params/{i}.npy` (the 2021 refit; else `params/{i}.npy`; refined:
//!   `smpl_params/{i}.npy`), pickled dicts: `poses` (1, 72) with `poses[0:3] = 0`, `Rh` (1, 3)
//!   axis-angle, `Th` (1, 3) metres, `shapes` (1, 10). EasyMocap places the body with
//!   `x_world = R(Rh) · x_smpl + Th`, a rotation about the **model origin**, not SMPL's
//!   root-joint `global_orient`: kept as [`Similarity`] `{1, R(Rh), Th}`.

use super::{
    BodyFrame, Dataset, Distortion, Format, MaskConvention, PoseTrack, Similarity, ViewRecord,
    axis_angle_matrix, camera_from, expect_values,
};
use crate::DatasetError;
use splatzoo_models::pickle::{Value, load_npy_object, to_array, to_strings};
use std::path::{Path, PathBuf};

fn array(
    file: &Path,
    v: Option<&Value>,
    key: &str,
    shape: &str,
    len: usize,
) -> Result<Vec<f64>, DatasetError> {
    let v =
        v.ok_or_else(|| DatasetError::field(file, key, format!("missing (expected {shape})")))?;
    let a = to_array(v).map_err(|p| DatasetError::field(file, key, p))?;
    expect_values(file, key, &a.shape, shape, &a.values, len)
}

/// The number that names the parameter file of an image path.
pub fn parameter_index(image: &str) -> Option<usize> {
    let stem = Path::new(image).file_stem()?.to_str()?;
    match stem.split('_').nth(4) {
        // CoreView_313_Camera_(1)_0001_2019-…: 1-based frame number, file params/1.npy.
        Some(n) if stem.starts_with("CoreView") => n.parse().ok(),
        _ => stem.parse().ok(),
    }
}

fn body_frame(file: &Path) -> Result<BodyFrame, DatasetError> {
    let v = load_npy_object(file).map_err(|p| DatasetError::file(file, p))?;
    let poses = array(file, v.get("poses"), "poses", "(1, 72)", 72)?;
    let rh = array(file, v.get("Rh"), "Rh", "(1, 3)", 3)?;
    let th = array(file, v.get("Th"), "Th", "(1, 3)", 3)?;
    let betas = array(file, v.get("shapes"), "shapes", "(1, 10)", 10)?;
    Ok(BodyFrame {
        global_orient: [poses[0], poses[1], poses[2]],
        body_pose: poses[3..].to_vec(),
        betas,
        transl: [0.0; 3],
        world_from_smpl: Similarity {
            scale: 1.0,
            rotation: axis_angle_matrix([rh[0], rh[1], rh[2]]),
            translation: [th[0], th[1], th[2]],
        },
        extra: Default::default(),
        root_position: None,
    })
}

pub fn load(root: &Path) -> Result<Dataset, DatasetError> {
    let annots_path = root.join("annots.npy");
    let annots = load_npy_object(&annots_path).map_err(|p| DatasetError::file(&annots_path, p))?;
    let cams = annots
        .get("cams")
        .ok_or_else(|| DatasetError::field(&annots_path, "cams", "missing"))?;
    let list = |key: &str| -> Result<Vec<&Value>, DatasetError> {
        cams.get(key).and_then(|v| v.items()).ok_or_else(|| {
            DatasetError::field(
                &annots_path,
                &format!("cams.{key}"),
                "expected a list with one entry per camera",
            )
        })
    };
    let (ks, ds, rs, ts) = (list("K")?, list("D")?, list("R")?, list("T")?);
    let cameras = ks.len();
    if ds.len() != cameras || rs.len() != cameras || ts.len() != cameras {
        return Err(DatasetError::field(
            &annots_path,
            "cams",
            format!(
                "K, D, R, T have {}, {}, {}, {} entries; expected one per camera each",
                ks.len(),
                ds.len(),
                rs.len(),
                ts.len()
            ),
        ));
    }
    let ims = annots.get("ims").and_then(|v| v.items()).ok_or_else(|| {
        DatasetError::field(
            &annots_path,
            "ims",
            "expected a list of {ims: [path per camera]} per frame",
        )
    })?;
    let frame_paths: Vec<Vec<String>> = ims
        .iter()
        .enumerate()
        .map(|(f, entry)| {
            let field = format!("ims[{f}].ims");
            let paths = entry.get("ims").ok_or_else(|| {
                DatasetError::field(&annots_path, &field, "missing (expected the image paths)")
            })?;
            to_strings(paths).map_err(|p| {
                DatasetError::field(
                    &annots_path,
                    &field,
                    format!("expected a list or numpy array of image paths ({p})"),
                )
            })
        })
        .collect::<Result<_, _>>()?;
    let refined = frame_paths
        .first()
        .and_then(|paths| paths.first())
        .is_some_and(|p| p.starts_with("images/"));
    let mut intrinsics = Vec::with_capacity(cameras);
    for c in 0..cameras {
        let key = |k: &str| format!("cams.{k}[{c}]");
        let k = array(&annots_path, Some(ks[c]), &key("K"), "(3, 3)", 9)?;
        let d = array(&annots_path, Some(ds[c]), &key("D"), "(5, 1)", 5)?;
        let r = array(&annots_path, Some(rs[c]), &key("R"), "(3, 3)", 9)?;
        let t = array(&annots_path, Some(ts[c]), &key("T"), "(3, 1)", 3)?;
        intrinsics.push((
            [k[0], k[4], k[2] + 0.5, k[5] + 0.5],
            Distortion {
                k1: d[0],
                k2: d[1],
                p1: d[2],
                p2: d[3],
                k3: d[4],
            },
            std::array::from_fn::<[f64; 3], 3, _>(|i| std::array::from_fn(|j| r[3 * i + j])),
            [t[0] / 1000.0, t[1] / 1000.0, t[2] / 1000.0],
        ));
    }
    let params_dir = if refined {
        root.join("smpl_params")
    } else if root.join("new_params").is_dir() {
        root.join("new_params")
    } else {
        root.join("params")
    };
    let mut views = Vec::new();
    let mut frames = Vec::with_capacity(ims.len());
    let mut sizes: Vec<Option<(u32, u32)>> = vec![None; cameras];
    for (f, paths) in frame_paths.iter().enumerate() {
        if paths.len() > cameras {
            return Err(DatasetError::field(
                &annots_path,
                &format!("ims[{f}].ims"),
                format!("{} paths for {cameras} cameras", paths.len()),
            ));
        }
        let mut index = None;
        for (c, rel) in paths.iter().enumerate() {
            let image = root.join(rel);
            let size = match sizes[c] {
                Some(s) => s,
                None => {
                    let s = image::image_dimensions(&image).map_err(|e| {
                        DatasetError::file(&image, format!("cannot read the image header ({e})"))
                    })?;
                    sizes[c] = Some(s);
                    s
                }
            };
            let (k, distortion, r, t) = intrinsics[c];
            let mask = mask_path(root, rel, refined);
            let camera_name = Path::new(rel)
                .parent()
                .and_then(|d| d.file_name())
                .map_or_else(|| c.to_string(), |d| d.to_string_lossy().into_owned());
            views.push(ViewRecord {
                frame: f,
                camera_name,
                camera: camera_from(k, size, r, t),
                distortion,
                image,
                mask,
                mask_convention: MaskConvention::NonZeroIsPerson,
                other_masks: Default::default(),
                depth: None,
            });
            index = index.or_else(|| parameter_index(rel));
        }
        let params = index.map(|i| params_dir.join(format!("{i}.npy")));
        frames.push(match params {
            Some(p) if p.is_file() => Some(body_frame(&p)?),
            _ => None,
        });
    }
    Ok(Dataset {
        format: Format::Zju,
        frame_times: Vec::new(),
        root: root.to_path_buf(),
        frame_count: frames.len(),
        views,
        people: vec![PoseTrack {
            person: "0".into(),
            frames,
        }],
        splits: Default::default(),
        points: Vec::new(),
        boxes: Vec::new(),
        warnings: Vec::new(),
        image_downscale: 1,
    })
}

fn mask_path(root: &Path, image: &str, refined: bool) -> Option<PathBuf> {
    let png = Path::new(image).with_extension("png");
    let candidates: Vec<PathBuf> = if refined {
        let rest = png.strip_prefix("images").ok()?;
        vec![root.join("mask").join(rest)]
    } else {
        vec![
            root.join("mask_cihp").join(&png),
            root.join("mask").join(&png),
        ]
    };
    candidates.into_iter().find(|p| p.is_file())
}
