//! Public datasets, read as released (or in the preprocessed form their main codebase uses) into
//! one set of types: [`ViewRecord`] (an image with its camera in our conventions: OpenCV axes,
//! world-to-camera, metres, pixels; its distortion; its mask), [`PoseTrack`] (SMPL-layout
//! parameters per frame, with the frames where the person is valid), and [`Dataset`].
//!
//! Each format module writes down, beside the code, every conversion from its conventions to
//! ours. So far: NeuMan ([`neuman`], over a COLMAP text model, [`colmap`]; and written by
//! [`neuman_writer`], so a synthetic capture can take NeuMan's path), COLMAP scene
//! folders as 3DGS reads them ([`colmap_scene`], text or binary models, [`colmap_binary`]),
//! ZJU-MoCap in its original and refined layouts ([`zju`]), PeopleSnapshot in InstantAvatar's
//! npz form ([`people_snapshot`]), THuman2.0 renders of the GHG protocol ([`ghg`]),
//! drivestudio's processed Waymo ([`drivestudio`]), nerfstudio folders (with their
//! `ply_file_path` points, [`crate::point_ply`]), and the synthetic generator's own export
//! ([`synthetic`]), so generated scenes arrive in the same types. [`detect`] recognises a
//! folder's format; [`check`] decodes every image and mask in parallel, in bounded batches, and
//! tells problems (unreadable or inconsistent data) from warnings (valid data worth saying:
//! empty dynamic masks, subjects without a fit, extra pose rows).

pub mod check;
pub mod colmap;
pub mod colmap_binary;
pub mod colmap_scene;
pub mod drivestudio;
pub mod ghg;
pub mod neuman;
pub mod neuman_writer;
pub mod people_snapshot;
pub mod synthetic;
pub mod zju;

use crate::DatasetError;
pub use splatzoo_models::rotation_scalar::axis_angle_matrix;
use splatzoo_rasterizer::Camera;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The formats this module reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    /// apple/ml-neuman scene folders (COLMAP text model, segmentations, SMPL, alignments).
    Neuman,
    /// ZJU-MoCap `CoreView_*` folders (`annots.npy`, `params/`, `Camera_B*/`, `mask*/`), and the
    /// refined layout (`images/<cam>/`, `mask/<cam>/`, `smpl_params/`).
    Zju,
    /// PeopleSnapshot as InstantAvatar preprocesses it (`cameras.npz`, `poses.npz`, `images/`,
    /// `masks/*.npy`).
    PeopleSnapshot,
    /// THuman2.0 rendered by the GHG / GPS-Gaussian protocol (`img/`, `mask/`, `parm/`, with
    /// SMPL-X parameters where present).
    Ghg,
    /// drivestudio's processed Waymo scenes (`images/`, `extrinsics/`, `intrinsics/`,
    /// `ego_pose/`, `instances/`, `humanpose/smpl.pkl`).
    Drivestudio,
    /// The synthetic generator's export (`synth` command): nerfstudio cameras plus masks and
    /// pose tracks.
    Synthetic,
    /// A nerfstudio `transforms.json` folder (cameras and images, and the sparse points of its
    /// `ply_file_path` where it names one).
    Nerfstudio,
    /// A COLMAP scene folder as 3DGS, gsplat and Brush read it (`sparse/0/` or `sparse/` with a
    /// binary or text model, `images/`, optionally `images_N/` for a downscale).
    Colmap,
}

/// How [`load_with`] reads a folder.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LoadOptions {
    /// Cameras at `1/downscale` of the capture's resolution (1: as captured). Read by COLMAP
    /// scenes only ([`colmap_scene`]: `images_N/` where present, else
    /// [`Dataset::image_downscale`]); other formats refuse a factor above 1.
    pub downscale: u32,
}

impl Default for LoadOptions {
    fn default() -> Self {
        Self { downscale: 1 }
    }
}

/// OpenCV lens distortion (`k1 k2 p1 p2 k3`); zero for undistorted images.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Distortion {
    pub k1: f64,
    pub k2: f64,
    pub p1: f64,
    pub p2: f64,
    pub k3: f64,
}

/// How a mask file marks the person.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MaskConvention {
    /// Non-zero pixels are the person (ZJU-MoCap's `mask/`, `mask_cihp/`).
    NonZeroIsPerson,
    /// 0 is the person and 255 the background (NeuMan's `segmentations/`).
    ZeroIsPerson,
}

/// One image of the dataset.
#[derive(Debug, Clone, PartialEq)]
pub struct ViewRecord {
    /// Index of the moment it shows (into [`PoseTrack::frames`]).
    pub frame: usize,
    /// The sensor that took it (a camera name, or the image name for a moving camera).
    pub camera_name: String,
    /// Our conventions: OpenCV axes, world-to-camera, metres (or the format's world unit, said
    /// by the format), pixels at the image's resolution.
    pub camera: Camera,
    pub distortion: Distortion,
    pub image: PathBuf,
    pub mask: Option<PathBuf>,
    pub mask_convention: MaskConvention,
    /// Further masks by name, non-zero = inside (drivestudio: `sky`, `vehicle`, `dynamic`;
    /// synthetic: `accessory`, `coarse`).
    pub other_masks: BTreeMap<String, PathBuf>,
    /// A depth map, where the format gives one: a 16-bit PNG in millimetres (0 = none;
    /// nerfstudio's `depth_file_path`) or a `.npy` of metres, `(H, W)` at the image's size.
    pub depth: Option<PathBuf>,
}

/// `x_world = scale · R · x + t`: where a format's SMPL output lives in its world.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Similarity {
    pub scale: f64,
    pub rotation: [[f64; 3]; 3],
    pub translation: [f64; 3],
}

impl Similarity {
    pub const IDENTITY: Similarity = Similarity {
        scale: 1.0,
        rotation: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        translation: [0.0; 3],
    };

    pub fn apply(&self, x: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|i| {
            self.scale * (0..3).map(|j| self.rotation[i][j] * x[j]).sum::<f64>()
                + self.translation[i]
        })
    }
}

/// SMPL-layout parameters of one person in one frame. The body is posed by the model with
/// `global_orient` (axis-angle, about the root joint), `body_pose` (axis-angle per non-root
/// joint), `betas` and `transl`, as SMPL does; then placed in the world by `world_from_smpl`.
/// Formats whose global rotation is not SMPL's (ZJU-MoCap's `Rh` rotates about the model origin;
/// NeuMan's alignment carries a scale) keep it there, so no conversion needs the body model.
#[derive(Debug, Clone, PartialEq)]
pub struct BodyFrame {
    pub global_orient: [f64; 3],
    pub body_pose: Vec<f64>,
    pub betas: Vec<f64>,
    pub transl: [f64; 3],
    pub world_from_smpl: Similarity,
    /// Where the format puts the root joint in the world, for formats that give that instead
    /// of a translation (drivestudio: the person's 3D box centre). Then `transl` is 0 and the
    /// SMPL translation follows from the body model's root joint `J0`:
    /// `transl = R⁻¹ (root − t) / s − J0` for `world_from_smpl = {s, R, t}`.
    pub root_position: Option<[f64; 3]>,
    /// Further parameters by their SMPL-X names (`left_hand_pose`, `jaw_pose`, `expression`, …),
    /// as the format stores them.
    pub extra: BTreeMap<String, Vec<f64>>,
}

impl BodyFrame {
    /// SMPL's `transl` for a body model whose root joint rests at `j0` (for these betas): the
    /// stored `transl`, or, where the format gives the root's world position instead, the one
    /// that puts the root there (SMPL rotates about the root, so the root lands at
    /// `world_from_smpl(j0 + transl)`).
    pub fn smpl_transl(&self, j0: [f64; 3]) -> [f64; 3] {
        let Some(root) = self.root_position else {
            return self.transl;
        };
        let m = &self.world_from_smpl;
        let d: [f64; 3] = std::array::from_fn(|i| (root[i] - m.translation[i]) / m.scale);
        std::array::from_fn(|j| (0..3).map(|i| m.rotation[i][j] * d[i]).sum::<f64>() - j0[j])
    }
}

/// One person's parameters over the dataset's frames; `None` where the person is not valid.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseTrack {
    pub person: String,
    pub frames: Vec<Option<BodyFrame>>,
}

/// A sparse point: position, sRGB colour in [0, 1].
pub type SparsePoint = ([f64; 3], [f32; 3]);

/// What a loader found.
#[derive(Debug, Clone)]
pub struct Dataset {
    pub format: Format,
    pub root: PathBuf,
    pub frame_count: usize,
    /// Each frame's time, normalised to [0, 1] over the sequence (nerfstudio's `time`, or the
    /// frame index over the last one, as drivestudio normalises its timestamps; 0 for one frame).
    pub frame_times: Vec<f64>,
    pub views: Vec<ViewRecord>,
    pub people: Vec<PoseTrack>,
    /// Named splits of view indices (e.g. NeuMan's train/val/test files).
    pub splits: BTreeMap<String, Vec<usize>>,
    /// Sparse points with sRGB colours in [0, 1], where the format has them.
    pub points: Vec<SparsePoint>,
    /// 3D boxes of annotated objects, where the format has them.
    pub boxes: Vec<InstanceBox>,
    /// What loading found that is valid data but worth saying, as (file, fact): e.g. more pose
    /// rows than frames (PeopleSnapshot), a subject without a body fit (GHG). Not problems: the
    /// dataset loaded; [`check::check`] carries these into its report's warnings.
    pub warnings: Vec<(String, String)>,
    /// How much each image (and mask) file must be shrunk to match its view's camera: 1 when
    /// the files are at the cameras' size (always, but for a COLMAP scene loaded with a
    /// downscale and no `images_N/` folder: then the cameras are already scaled and the files
    /// are full resolution, `round(size / N)` → the camera's size,
    /// [`colmap_scene::downscaled_size`]).
    pub image_downscale: u32,
}

/// One object's box in one frame.
#[derive(Debug, Clone, PartialEq)]
pub struct InstanceBox {
    /// The format's instance key.
    pub instance: String,
    pub class: String,
    pub frame: usize,
    /// Object to world (box centre, x along its heading, z up), rows of a rigid 4×4.
    pub object_to_world: [[f64; 4]; 4],
    /// Length, width, height in metres (along the object's x, y, z).
    pub size: [f64; 3],
}

/// A decoded mask: width, height, person per pixel (row-major).
pub type Mask = (u32, u32, Vec<bool>);

impl ViewRecord {
    /// The mask as (width, height, person per pixel), from a PNG/JPEG or a `.npy` array
    /// `(H, W)`, read with this view's convention.
    pub fn read_mask(&self) -> Option<Result<Mask, DatasetError>> {
        let path = self.mask.as_ref()?;
        let person = |v: f64| match self.mask_convention {
            MaskConvention::NonZeroIsPerson => v != 0.0,
            MaskConvention::ZeroIsPerson => v == 0.0,
        };
        if path.extension().is_some_and(|e| e == "npy") {
            return Some(read_npy(path).and_then(|a| match a.shape[..] {
                [h, w] => Ok((
                    w as u32,
                    h as u32,
                    a.values.iter().map(|&v| person(v)).collect(),
                )),
                _ => Err(DatasetError::file(
                    path,
                    format!("shape {:?}, expected (H, W)", a.shape),
                )),
            }));
        }
        Some(
            image::open(path)
                .map_err(|e| DatasetError::file(path, format!("cannot decode ({e})")))
                .map(|img| {
                    let grey = img.to_luma8();
                    let values = grey.pixels().map(|p| person(p[0] as f64)).collect();
                    (grey.width(), grey.height(), values)
                }),
        )
    }
}

/// A numeric `.npy` file as `f64` in C order.
pub fn read_npy(path: &Path) -> Result<splatzoo_models::body::npz::Array, DatasetError> {
    let file = std::fs::File::open(path)
        .map_err(|e| DatasetError::file(path, format!("cannot read ({e})")))?;
    let npy = npyz::NpyFile::new(std::io::BufReader::new(file))
        .map_err(|e| DatasetError::file(path, format!("not a .npy file ({e})")))?;
    splatzoo_models::body::npz::decode_npy(npy).map_err(|p| DatasetError::file(path, p))
}

/// Array `key` of an `.npz` archive.
pub fn read_npz_key(
    path: &Path,
    archive: &mut npyz::npz::NpzArchive<std::io::BufReader<std::fs::File>>,
    key: &str,
) -> Result<splatzoo_models::body::npz::Array, DatasetError> {
    let npy = archive
        .by_name(key)
        .map_err(|e| DatasetError::field(path, key, format!("cannot read ({e})")))?
        .ok_or_else(|| DatasetError::field(path, key, "missing"))?;
    splatzoo_models::body::npz::decode_npy(npy).map_err(|p| DatasetError::field(path, key, p))
}

impl Dataset {
    /// Distinct camera names.
    pub fn camera_names(&self) -> Vec<&str> {
        let mut names: Vec<&str> = self.views.iter().map(|v| v.camera_name.as_str()).collect();
        names.sort_unstable();
        names.dedup();
        names
    }
}

/// Recognises a dataset folder's format by the files it holds (NeuMan before COLMAP: its
/// scenes hold a COLMAP text model too; a COLMAP scene before a `transforms.json` beside it).
pub fn detect(root: &Path) -> Option<Format> {
    if root.join("sparse/images.txt").is_file() && root.join("alignments.npy").is_file() {
        Some(Format::Neuman)
    } else if colmap_scene::is_colmap_scene(root) {
        Some(Format::Colmap)
    } else if root.join("annots.npy").is_file() {
        Some(Format::Zju)
    } else if root.join("cameras.npz").is_file() && root.join("poses.npz").is_file() {
        Some(Format::PeopleSnapshot)
    } else if root.join("parm").is_dir() && root.join("img").is_dir() {
        Some(Format::Ghg)
    } else if root.join("ego_pose").is_dir() && root.join("extrinsics").is_dir() {
        Some(Format::Drivestudio)
    } else if root.join("transforms.json").is_file() && root.join("scene.json").is_file() {
        Some(Format::Synthetic)
    } else if root.join("transforms.json").is_file() {
        Some(Format::Nerfstudio)
    } else {
        None
    }
}

/// Loads `root` as `format` (detected when `None`), at the capture's resolution.
pub fn load(root: &Path, format: Option<Format>) -> Result<Dataset, DatasetError> {
    load_with(root, format, &LoadOptions::default())
}

/// Loads `root` as `format` (detected when `None`) with `options`.
pub fn load_with(
    root: &Path,
    format: Option<Format>,
    options: &LoadOptions,
) -> Result<Dataset, DatasetError> {
    let format = match format.or_else(|| detect(root)) {
        Some(f) => f,
        None => {
            return Err(DatasetError::file(
                root,
                "format not recognised (NeuMan: sparse/images.txt + alignments.npy; \
                 COLMAP: sparse/0/ or sparse/ with cameras.{bin,txt}, + images/; \
                 ZJU-MoCap: annots.npy; PeopleSnapshot: cameras.npz + poses.npz; \
                 GHG: img/ + parm/; drivestudio: ego_pose/ + extrinsics/; \
                 nerfstudio: transforms.json); name it with --format",
            ));
        }
    };
    if options.downscale != 1 && format != Format::Colmap {
        return Err(DatasetError::file(
            root,
            format!(
                "downscale {} is read for COLMAP scenes only ({format:?} loads at the capture's \
                 resolution; downscale in the consumer)",
                options.downscale
            ),
        ));
    }
    let mut dataset = match format {
        Format::Neuman => neuman::load(root),
        Format::Zju => zju::load(root),
        Format::PeopleSnapshot => people_snapshot::load(root),
        Format::Ghg => ghg::load(root),
        Format::Drivestudio => drivestudio::load(root),
        Format::Synthetic => synthetic::load(root),
        Format::Nerfstudio => nerfstudio(root),
        Format::Colmap => colmap_scene::load(root, options.downscale),
    }?;
    if dataset.frame_times.len() != dataset.frame_count {
        let last = dataset.frame_count.saturating_sub(1).max(1) as f64;
        dataset.frame_times = (0..dataset.frame_count).map(|f| f as f64 / last).collect();
    }
    Ok(dataset)
}

pub(crate) fn nerfstudio(root: &Path) -> Result<Dataset, DatasetError> {
    let transforms = crate::nerfstudio::read_transforms_with_points(&root.join("transforms.json"))?;
    // `ply_file_path` is relative to the transforms.json, as nerfstudio resolves it.
    let points = match &transforms.ply_file_path {
        Some(ply) => crate::point_ply::read_points(&root.join(ply))?,
        None => Vec::new(),
    };
    let frames = transforms.frames;
    let mut times: Vec<f64> = frames.iter().filter_map(|f| f.time).collect();
    times.sort_by(f64::total_cmp);
    times.dedup();
    let views = frames
        .iter()
        .enumerate()
        .map(|(k, f)| ViewRecord {
            frame: f
                .time
                .and_then(|t| times.iter().position(|&x| x == t))
                .unwrap_or(k),
            camera_name: f.file_path.clone(),
            camera: f.camera,
            distortion: Distortion::default(),
            image: root.join(&f.file_path),
            mask: f.mask_path.as_ref().map(|m| root.join(m)),
            mask_convention: MaskConvention::NonZeroIsPerson,
            other_masks: Default::default(),
            depth: f.depth_file_path.as_ref().map(|d| root.join(d)),
        })
        .collect::<Vec<_>>();
    let frame_count = views.iter().map(|v| v.frame + 1).max().unwrap_or(0);
    Ok(Dataset {
        format: Format::Nerfstudio,
        root: root.to_path_buf(),
        frame_times: if times.len() == frame_count {
            times
        } else {
            Vec::new()
        },
        frame_count,
        views,
        people: Vec::new(),
        splits: BTreeMap::new(),
        points,
        boxes: Vec::new(),
        warnings: Vec::new(),
        image_downscale: 1,
    })
}

/// A finite array of exactly `len` values from `values`, or an error naming `file`, `key` and
/// the expected shape.
pub(crate) fn expect_values(
    file: &Path,
    key: &str,
    shape: &[usize],
    expected: &str,
    values: &[f64],
    len: usize,
) -> Result<Vec<f64>, DatasetError> {
    if values.len() != len {
        return Err(DatasetError::field(
            file,
            key,
            format!("shape {shape:?}, expected {expected}"),
        ));
    }
    if let Some(i) = values.iter().position(|v| !v.is_finite()) {
        return Err(DatasetError::field(
            file,
            key,
            format!("non-finite value at flat index {i} (expected {expected}, finite)"),
        ));
    }
    Ok(values.to_vec())
}

/// A camera from OpenCV intrinsics and a world-to-camera `R`, `t`.
pub(crate) fn camera_from(
    k: [f64; 4],
    size: (u32, u32),
    rotation: [[f64; 3]; 3],
    translation: [f64; 3],
) -> Camera {
    let mut world_to_camera = [[0.0f32; 4]; 3];
    for i in 0..3 {
        for j in 0..3 {
            world_to_camera[i][j] = rotation[i][j] as f32;
        }
        world_to_camera[i][3] = translation[i] as f32;
    }
    Camera {
        fx: k[0] as f32,
        fy: k[1] as f32,
        cx: k[2] as f32,
        cy: k[3] as f32,
        width: size.0,
        height: size.1,
        near: 0.01,
        far: 1e4,
        world_to_camera,
    }
}
