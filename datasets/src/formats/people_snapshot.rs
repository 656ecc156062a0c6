//! PeopleSnapshot in InstantAvatar's npz preprocessing (also read unchanged by GART), which is
//! what current methods train on. The released HDF5 files (`masks.hdf5`,
//! `reconstructed_poses.hdf5`) are LZF-compressed, a filter only one young pure-Rust HDF5 crate
//! decodes; we read the npz form instead and say so (InstantAvatar's
//! `scripts/peoplesnapshot/preprocess_PeopleSnapshot.py` converts a release).
//!
//! - `cameras.npz`: `intrinsic` (3, 3) OpenCV K (pixel centres at integers → ours `+0.5`),
//!   `extrinsic` (4, 4) world-to-camera (identity in practice: the world is the camera's),
//!   `height`, `width` (0-d).
//! - `images/image_XXXX.png` (undistorted), `masks/mask_XXXX.npy` (H, W) `u1` **0/1**, not
//!   0/255; sorted by name, frame = position.
//! - `poses.npz`: `thetas` (R, 72) SMPL axis-angle (global orientation first, in the camera
//!   frame), `transl` (R, 3) metres, `betas` (10,), float32, copied unchanged by the script from
//!   the release's `reconstructed_poses.hdf5` (`pose`, `trans`, `betas`). The release holds
//!   **one more pose than there are frames** (e.g. 835 poses for male-1-casual's 834 frames;
//!   thmoa/videoavatars issue #78), so any R ≥ N is accepted and row i is frame i: the first N
//!   rows are used, as InstantAvatar's `instant_avatar/datasets/peoplesnapshot.py` indexes them
//!   by frame (neuralbody's `tools/process_snapshot.py` keeps the last N instead), and the extra
//!   rows are reported in [`Dataset::warnings`]. Where `poses/anim_nerf_{train,val,test}.npz`
//!   exist (`global_orient` (M, 3), `body_pose` (M, 69), `transl` (M, 3), `betas` (1, 10): the
//!   refined poses, row j = the j-th frame of the split), they replace `poses.npz` on their
//!   frames.
//! - Splits: InstantAvatar's per-subject `[start, end (inclusive), step]` frame ranges, by the
//!   folder's name (e.g. `male-3-casual`); none for other names.

use super::{
    BodyFrame, Dataset, Format, MaskConvention, PoseTrack, Similarity, ViewRecord, camera_from,
    expect_values, read_npz_key,
};
use crate::DatasetError;
use npyz::npz::NpzArchive;
use std::collections::BTreeMap;
use std::path::Path;

/// A frame range `(start, end inclusive, step)`.
type Range = (usize, usize, usize);

/// InstantAvatar's frame ranges for train, val, test.
const SPLITS: [(&str, [Range; 3]); 8] = [
    (
        "female-3-casual",
        [(0, 445, 4), (446, 446, 4), (446, 647, 4)],
    ),
    (
        "female-4-casual",
        [(0, 335, 4), (335, 335, 4), (335, 523, 4)],
    ),
    ("male-3-casual", [(0, 455, 4), (456, 456, 4), (456, 675, 4)]),
    ("male-4-casual", [(0, 659, 6), (660, 660, 6), (660, 872, 6)]),
    (
        "female-4-sport",
        [(1, 336, 4), (336, 336, 8), (336, 524, 4)],
    ),
    ("male-3-sport", [(1, 230, 2), (230, 230, 6), (230, 460, 6)]),
    ("male-2-casual", [(1, 455, 4), (455, 455, 8), (1, 455, 20)]),
    ("male-2-sport", [(1, 455, 4), (455, 455, 8), (1, 455, 20)]),
];

fn sorted_files(
    dir: &Path,
    prefix: &str,
    extension: &str,
) -> Result<Vec<std::path::PathBuf>, DatasetError> {
    let entries = std::fs::read_dir(dir)
        .map_err(|e| DatasetError::file(dir, format!("cannot list ({e})")))?;
    let mut files: Vec<_> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            let name = p
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            name.starts_with(prefix) && name.ends_with(extension)
        })
        .collect();
    files.sort();
    Ok(files)
}

fn open(path: &Path) -> Result<NpzArchive<std::io::BufReader<std::fs::File>>, DatasetError> {
    NpzArchive::open(path)
        .map_err(|e| DatasetError::file(path, format!("cannot open as .npz ({e})")))
}

/// `key` of `archive` as at least `rows` rows of `width` values; the first `rows` (finite) and
/// how many the file holds.
fn leading_rows(
    path: &Path,
    archive: &mut NpzArchive<std::io::BufReader<std::fs::File>>,
    key: &str,
    rows: usize,
    width: usize,
) -> Result<(Vec<Vec<f64>>, usize), DatasetError> {
    let a = read_npz_key(path, archive, key)?;
    let expected = format!("(at least {rows}, {width})");
    let held = match a.shape[..] {
        [m, w] if w == width && m >= rows => m,
        _ => {
            return Err(DatasetError::field(
                path,
                key,
                format!("shape {:?}, expected {expected}", a.shape),
            ));
        }
    };
    let n = rows * width;
    let values = expect_values(path, key, &a.shape, &expected, &a.values[..n], n)?;
    Ok((values.chunks(width).map(<[f64]>::to_vec).collect(), held))
}

/// `key` of `archive` as `rows` rows of `width` finite values.
fn rows(
    path: &Path,
    archive: &mut NpzArchive<std::io::BufReader<std::fs::File>>,
    key: &str,
    rows: usize,
    width: usize,
) -> Result<Vec<Vec<f64>>, DatasetError> {
    let a = read_npz_key(path, archive, key)?;
    let expected = format!("({rows}, {width})");
    let values = expect_values(path, key, &a.shape, &expected, &a.values, rows * width)?;
    Ok(values.chunks(width).map(<[f64]>::to_vec).collect())
}

pub fn load(root: &Path) -> Result<Dataset, DatasetError> {
    let cameras_path = root.join("cameras.npz");
    let mut cameras = open(&cameras_path)?;
    let k = read_npz_key(&cameras_path, &mut cameras, "intrinsic")?;
    let k = expect_values(&cameras_path, "intrinsic", &k.shape, "(3, 3)", &k.values, 9)?;
    let e = read_npz_key(&cameras_path, &mut cameras, "extrinsic")?;
    let e = expect_values(
        &cameras_path,
        "extrinsic",
        &e.shape,
        "(4, 4)",
        &e.values,
        16,
    )?;
    let size = |key: &str, cameras: &mut NpzArchive<_>| -> Result<u32, DatasetError> {
        let a = read_npz_key(&cameras_path, cameras, key)?;
        match a.values[..] {
            [v] if v >= 1.0 => Ok(v as u32),
            _ => Err(DatasetError::field(
                &cameras_path,
                key,
                format!("shape {:?}, expected one positive integer", a.shape),
            )),
        }
    };
    let (w, h) = (size("width", &mut cameras)?, size("height", &mut cameras)?);
    let camera = camera_from(
        [k[0], k[4], k[2] + 0.5, k[5] + 0.5],
        (w, h),
        std::array::from_fn(|i| std::array::from_fn(|j| e[4 * i + j])),
        [e[3], e[7], e[11]],
    );
    let images = sorted_files(&root.join("images"), "image_", ".png")?;
    let masks = sorted_files(&root.join("masks"), "mask_", ".npy").unwrap_or_default();
    if !masks.is_empty() && masks.len() != images.len() {
        return Err(DatasetError::file(
            &root.join("masks"),
            format!("{} masks for {} images", masks.len(), images.len()),
        ));
    }
    let n = images.len();
    let views: Vec<ViewRecord> = images
        .iter()
        .enumerate()
        .map(|(f, image)| ViewRecord {
            frame: f,
            camera_name: "camera".into(),
            camera,
            distortion: Default::default(),
            image: image.clone(),
            mask: masks.get(f).cloned(),
            mask_convention: MaskConvention::NonZeroIsPerson,
            other_masks: Default::default(),
            depth: None,
        })
        .collect();

    let poses_path = root.join("poses.npz");
    let mut poses = open(&poses_path)?;
    let (thetas, theta_rows) = leading_rows(&poses_path, &mut poses, "thetas", n, 72)?;
    let (transl, transl_rows) = leading_rows(&poses_path, &mut poses, "transl", n, 3)?;
    let betas = rows(&poses_path, &mut poses, "betas", 1, 10)?.remove(0);
    let mut warnings = Vec::new();
    if theta_rows > n || transl_rows > n {
        warnings.push((
            poses_path.display().to_string(),
            format!(
                "`thetas` has {theta_rows} rows and `transl` {transl_rows} for {n} frames \
                 (the release's reconstructed_poses.hdf5 holds one more pose than frames); \
                 the first {n} are used, row i for frame i"
            ),
        ));
    }
    let mut frames: Vec<Option<BodyFrame>> = (0..n)
        .map(|f| {
            Some(BodyFrame {
                global_orient: [thetas[f][0], thetas[f][1], thetas[f][2]],
                body_pose: thetas[f][3..].to_vec(),
                betas: betas.clone(),
                transl: [transl[f][0], transl[f][1], transl[f][2]],
                world_from_smpl: Similarity::IDENTITY,
                extra: Default::default(),
                root_position: None,
            })
        })
        .collect();

    let subject = root
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let mut splits = BTreeMap::new();
    if let Some((_, ranges)) = SPLITS.iter().find(|(name, _)| *name == subject) {
        for (split, &(start, end, step)) in ["train", "val", "test"].iter().zip(ranges) {
            let indices: Vec<usize> = (start..=end.min(n.saturating_sub(1)))
                .step_by(step)
                .collect();
            let refined = root.join(format!("poses/anim_nerf_{split}.npz"));
            if refined.is_file() {
                let m = indices.len();
                let mut a = open(&refined)?;
                let go = rows(&refined, &mut a, "global_orient", m, 3)?;
                let body = rows(&refined, &mut a, "body_pose", m, 69)?;
                let tr = rows(&refined, &mut a, "transl", m, 3)?;
                let b = rows(&refined, &mut a, "betas", 1, 10)?.remove(0);
                for (j, &f) in indices.iter().enumerate() {
                    frames[f] = Some(BodyFrame {
                        global_orient: [go[j][0], go[j][1], go[j][2]],
                        body_pose: body[j].clone(),
                        betas: b.clone(),
                        transl: [tr[j][0], tr[j][1], tr[j][2]],
                        world_from_smpl: Similarity::IDENTITY,
                        extra: Default::default(),
                        root_position: None,
                    });
                }
            }
            splits.insert(split.to_string(), indices);
        }
    }
    Ok(Dataset {
        format: Format::PeopleSnapshot,
        frame_times: Vec::new(),
        root: root.to_path_buf(),
        frame_count: n,
        views,
        people: vec![PoseTrack {
            person: subject,
            frames,
        }],
        splits,
        points: Vec::new(),
        boxes: Vec::new(),
        warnings,
        image_downscale: 1,
    })
}
