//! Training data for static scenes: posed views, the held-out split, initial points and the
//! scene extent, from the synthetic static preset or from any capture the dataset loaders read
//! (COLMAP, nerfstudio, NeuMan, ZJU-MoCap, PeopleSnapshot, THuman2.0/GHG, drivestudio Waymo, the
//! `synth` command's output; [`dataset`] is the one bridge from `formats::Dataset`).
//!
//! Images are decoded on demand through a bounded cache ([`image_store`]), undistorted onto
//! the pinhole camera where the lens model has distortion ([`undistort`]). Initial points are
//! the capture's sparse points where it has them, else depth back-projected from the training
//! views, else random ([`init_points`]).

pub mod dataset;
pub mod image_store;
pub mod init_points;
pub mod people;
pub mod undistort;

pub use image_store::{Frame, ImageSource, ImageStore, MaskRole};
pub use init_points::InitPoints;

use burn::tensor::{Device, Tensor, TensorData};
use serde::{Deserialize, Serialize};
use splatzoo_datasets::image_io::linear_to_srgb;
use splatzoo_datasets::synth::{Preset, SceneConfig};
use splatzoo_rasterizer::Camera;
use std::path::{Path, PathBuf};

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum DataSource {
    /// The synthetic static preset (a yard seen by 48 cameras), rendered at start-up.
    Synthetic,
    /// A capture folder in any format the loaders read (`data.path`, `data.format`).
    #[serde(alias = "nerfstudio")]
    Dataset,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DataConfig {
    pub source: DataSource,
    /// A capture folder (a nerfstudio `transforms.json` file is accepted too).
    pub path: Option<PathBuf>,
    /// The capture's format (`colmap`, `nerfstudio`, `neuman`, `zju`, `people-snapshot`,
    /// `ghg`, `drivestudio`, `synthetic`); detected from the files when absent.
    pub format: Option<String>,
    /// Synthetic: scene seed and image side in pixels.
    pub seed: u64,
    pub size: u32,
    /// Every `test_every`-th view is held out (3DGS's "LLFF hold" of 8), unless the capture
    /// names its own train/test split.
    pub test_every: usize,
    /// Captures: images are box-filtered down by this integer factor.
    pub downscale: u32,
    /// Depth initialisation: back-project every `init_stride`-th pixel of each training view.
    pub init_stride: usize,
    /// Random initialisation (no sparse points, no depth): this many points.
    pub random_points: usize,
    /// Captures: the colour behind transparent pixels, sRGB (synthetic scenes know theirs).
    pub background: [f32; 3],
    /// Whether person pixels are left out of a static scene's loss. Absent: where the capture
    /// has person masks and more than one moment (people move; a static scene cannot hold
    /// them), as drivestudio's background model does.
    pub mask_people: Option<bool>,
    /// Decoded images kept in memory, MiB (least recently used dropped beyond it).
    pub cache_mib: usize,
    /// Train on this many of the training views, evenly spread (a few-view scene); the synthetic
    /// preset then initialises from those views' depth alone. Absent: every training view.
    pub train_views: Option<usize>,
    /// Scales the world: camera centres, near/far planes, initial points and the extent
    /// (the images are unchanged, so a run is the same up to float rounding). Tests the
    /// extremes of world units (millimetres, kilometres).
    pub world_scale: f64,
}

impl Default for DataConfig {
    fn default() -> Self {
        Self {
            source: DataSource::Synthetic,
            path: None,
            format: None,
            seed: 0,
            size: 96,
            test_every: 8,
            downscale: 1,
            init_stride: 4,
            random_points: 20_000,
            background: [0.0; 3],
            mask_people: None,
            cache_mib: 4096,
            train_views: None,
            world_scale: 1.0,
        }
    }
}

/// `--data` and `--format`, as every trainer that reads captures takes them.
#[derive(clap::Args, Debug)]
pub struct CaptureArgs {
    /// A capture folder (COLMAP, nerfstudio, NeuMan, ZJU-MoCap, PeopleSnapshot, GHG,
    /// drivestudio, a `synth` export) instead of the synthetic default.
    #[arg(long)]
    pub data: Option<PathBuf>,
    /// The capture's format (detected from its files when absent).
    #[arg(long, value_enum)]
    pub format: Option<splatzoo_datasets::formats::Format>,
}

impl CaptureArgs {
    /// The `--set` lines they stand for: `data.path` and `data.format`.
    pub fn overrides(&self) -> Vec<String> {
        let mut sets = Vec::new();
        if let Some(path) = &self.data {
            let path = toml::Value::from(path.display().to_string());
            sets.push(format!("data.path={path}"));
        }
        if let Some(format) = self.format {
            let name = clap::ValueEnum::to_possible_value(&format)
                .map(|v| v.get_name().to_owned())
                .unwrap_or_default();
            sets.push(format!("data.format={}", toml::Value::from(name)));
        }
        sets
    }
}

#[derive(Debug, thiserror::Error)]
pub enum DataError {
    #[error(transparent)]
    Dataset(#[from] splatzoo_datasets::DatasetError),
    #[error("{file}: {problem}")]
    File { file: String, problem: String },
    #[error("data configuration: {0}")]
    Config(String),
}

fn file_error(path: &Path, problem: impl Into<String>) -> DataError {
    DataError::File {
        file: path.display().to_string(),
        problem: problem.into(),
    }
}

/// One training or held-out image.
pub struct View {
    pub name: String,
    /// At training resolution, pinhole.
    pub camera: Camera,
    /// The moment it shows (0 for a static capture).
    pub frame: usize,
    /// Its pixels in the view set's [`ImageStore`].
    pub key: usize,
}

pub struct ViewSet {
    pub train: Vec<View>,
    pub test: Vec<View>,
    /// sRGB.
    pub background: [f32; 3],
    pub points: InitPoints,
    /// 3DGS's scene extent: 1.1 × the largest distance of a camera from the cameras' centroid.
    pub extent: f64,
    /// Whether person pixels are left out of the loss.
    pub mask_people: bool,
    /// What the loader decided and why (printed at start, kept in `metrics.json`).
    pub decisions: Vec<String>,
    pub store: ImageStore,
}

impl ViewSet {
    pub fn load(config: &DataConfig, device: &Device) -> Result<Self, DataError> {
        if config.test_every < 2 || config.init_stride == 0 || config.downscale == 0 {
            return Err(DataError::Config(
                "test_every ≥ 2, init_stride ≥ 1 and downscale ≥ 1".into(),
            ));
        }
        if config.train_views == Some(0) {
            return Err(DataError::Config("data.train_views ≥ 1 (or absent)".into()));
        }
        let scale = config.world_scale;
        if !(scale.is_finite() && scale > 0.0) {
            return Err(DataError::Config(format!(
                "data.world_scale must be finite and > 0, got {scale}"
            )));
        }
        let mut set = Self::load_unscaled(config, device)?;
        if scale != 1.0 {
            set.scale_world(scale);
        }
        Ok(set)
    }

    /// Multiplies every world length by `s` (see [`DataConfig::world_scale`]).
    fn scale_world(&mut self, s: f64) {
        let sf = s as f32;
        for view in self.train.iter_mut().chain(self.test.iter_mut()) {
            let camera = &mut view.camera;
            for row in &mut camera.world_to_camera {
                row[3] *= sf;
            }
            camera.near *= sf;
            camera.far *= sf;
        }
        for p in &mut self.points.positions {
            *p = p.map(|v| v * sf);
        }
        for sigma in &mut self.points.sigmas {
            *sigma *= sf;
        }
        self.extent *= s;
        self.decisions.push(format!(
            "world scaled by {s} (data.world_scale): cameras, points, extent"
        ));
    }

    fn load_unscaled(config: &DataConfig, device: &Device) -> Result<Self, DataError> {
        match config.source {
            DataSource::Synthetic => synthetic(config, device),
            DataSource::Dataset => {
                let path = config.path.as_ref().ok_or_else(|| {
                    DataError::Config("source = \"dataset\" needs data.path".into())
                })?;
                let mut set = dataset::static_views(path, config, device)?;
                if let Some(n) = config.train_views {
                    let all = set.train.len();
                    let keep = evenly_spread(all, n);
                    set.train = std::mem::take(&mut set.train)
                        .into_iter()
                        .enumerate()
                        .filter_map(|(k, view)| keep.contains(&k).then_some(view))
                        .collect();
                    set.decisions.push(format!(
                        "training on {} of {all} training views (data.train_views); the \
                         initial points still come from the whole capture",
                        set.train.len()
                    ));
                }
                Ok(set)
            }
        }
    }

    /// A view's decoded pixels.
    pub fn frame(&self, view: &View) -> Result<Frame, DataError> {
        self.store.frame(view.key)
    }

    /// The pixels a static scene's loss counts (`[H, W]`, 1 = counted): the valid pixels,
    /// without the people where they are masked; `None` when every pixel counts.
    pub fn loss_weight(&self, frame: &Frame) -> Option<Tensor<2>> {
        let people = frame
            .person
            .as_ref()
            .filter(|_| self.mask_people)
            .map(|p| p.clone() * -1.0 + 1.0);
        match (frame.valid.clone(), people) {
            (Some(v), Some(p)) => Some(v * p),
            (v, p) => v.or(p),
        }
    }
}

/// 3DGS's extent (`getNerfppNorm`): 1.1 × the largest camera distance from their centroid.
pub fn camera_extent(cameras: &[Camera]) -> f64 {
    let centres: Vec<[f32; 3]> = cameras.iter().map(|c| c.position()).collect();
    let n = centres.len().max(1) as f64;
    let centroid: [f64; 3] =
        std::array::from_fn(|k| centres.iter().map(|c| c[k] as f64).sum::<f64>() / n);
    let radius = centres
        .iter()
        .map(|c| {
            (0..3)
                .map(|k| (c[k] as f64 - centroid[k]).powi(2))
                .sum::<f64>()
                .sqrt()
        })
        .fold(0.0, f64::max);
    1.1 * radius.max(1e-3)
}

/// `n` of the indices `0..count`, evenly spread, each the middle of its share (all of them
/// when `n ≥ count`).
pub fn evenly_spread(count: usize, n: usize) -> Vec<usize> {
    if n >= count {
        (0..count).collect()
    } else {
        (0..n).map(|i| (2 * i + 1) * count / (2 * n)).collect()
    }
}

pub fn split<T>(items: Vec<T>, test_every: usize) -> (Vec<T>, Vec<T>) {
    let (mut train, mut test) = (Vec::new(), Vec::new());
    for (k, item) in items.into_iter().enumerate() {
        if k % test_every == 0 {
            test.push(item)
        } else {
            train.push(item)
        }
    }
    (train, test)
}

fn synthetic(config: &DataConfig, device: &Device) -> Result<ViewSet, DataError> {
    if config.size < 16 {
        return Err(DataError::Config("data.size ≥ 16".into()));
    }
    let scene = SceneConfig {
        width: config.size,
        height: config.size,
        ..SceneConfig::new(Preset::Static, config.seed)
    }
    .build(device);
    let mut points = InitPoints::default();
    let mut store = ImageStore::new(config.cache_mib, device);
    // The training views kept (all, or `train_views` of them evenly spread); only those and
    // the held-out ones are rendered.
    let count = scene.tracks.len();
    let training: Vec<usize> = (0..count).filter(|k| k % config.test_every != 0).collect();
    let kept: Vec<usize> = match config.train_views {
        Some(n) => evenly_spread(training.len(), n)
            .into_iter()
            .map(|i| training[i])
            .collect(),
        None => training.clone(),
    };
    let wanted: Vec<usize> = (0..count)
        .filter(|k| k % config.test_every == 0 || kept.contains(k))
        .collect();
    let rendered = scene.render_tracks(0, &wanted, true);
    let (mut train, mut test) = (Vec::new(), Vec::new());
    for (&k, truth) in wanted.iter().zip(&rendered) {
        let held_out = k % config.test_every == 0;
        let r = &truth.render;
        let srgb: Vec<f32> = r.color.iter().flat_map(|c| c.map(linear_to_srgb)).collect();
        if !held_out {
            init_points::back_project(
                &truth.camera,
                &r.depth,
                &srgb,
                config.init_stride,
                &mut points,
            );
        }
        let image = Tensor::from_data(TensorData::new(srgb, [r.height, r.width, 3]), device);
        let key = store.push(ImageSource::Memory(Box::new(Frame {
            image,
            person: None,
            valid: None,
        })));
        let view = View {
            name: format!("view_{k:03}"),
            camera: truth.camera,
            frame: 0,
            key,
        };
        if held_out {
            test.push(view);
        } else {
            train.push(view);
        }
    }
    let cameras: Vec<Camera> = scene.tracks.iter().map(|t| t.cameras[0]).collect();
    let extent = camera_extent(&cameras);
    let mut decisions =
        vec!["synthetic static preset: depth-initialised, every pixel trained".to_owned()];
    if kept.len() < training.len() {
        decisions.push(format!(
            "training on {} of {} training views (data.train_views), initialised from their \
             depth alone",
            kept.len(),
            training.len()
        ));
    }
    Ok(ViewSet {
        train,
        test,
        background: scene.environment.background.map(linear_to_srgb),
        points,
        extent,
        mask_people: false,
        decisions,
        store,
    })
}

/// Running sums of sRGB over pixels, for a capture's mean background colour.
#[derive(Debug, Default)]
pub struct ColourSum {
    sum: [f64; 3],
    count: usize,
}

impl ColourSum {
    /// Adds `pixels` (`[N · 3]`) off `person` (every pixel where `person` is `None`).
    pub fn add(&mut self, pixels: &[f32], person: Option<&splatzoo_datasets::masks::Mask>) {
        for (k, rgb) in pixels.chunks(3).enumerate() {
            if person.is_none_or(|m| !m.data[k]) {
                (0..3).for_each(|c| self.sum[c] += f64::from(rgb[c]));
                self.count += 1;
            }
        }
    }

    pub fn mean(&self) -> [f32; 3] {
        let n = self.count.max(1) as f64;
        self.sum.map(|v| (v / n) as f32)
    }
}
