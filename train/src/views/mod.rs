//! Training data for static scenes: posed views (camera + sRGB image), the held-out split,
//! initial points and the scene extent, from the synthetic static preset or from a nerfstudio
//! `transforms.json` folder.
//!
//! Initial points come from depth where there is depth (the synthetic ground truth, or a
//! nerfstudio `depth_file_path`: 16-bit PNG in millimetres, 0 = none; an RGB-D stand-in for SfM
//! points) and otherwise from uniform random points in the cameras' bounding box (3DGS's random
//! initialisation).

use burn::tensor::{Device, Tensor, TensorData};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use splatzoo_datasets::image_io::linear_to_srgb;
use splatzoo_datasets::nerfstudio::read_transforms;
use splatzoo_datasets::synth::rng::Rng;
use splatzoo_datasets::synth::{Preset, SceneConfig};
use splatzoo_rasterizer::Camera;
use std::path::{Path, PathBuf};

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum DataSource {
    /// The synthetic static preset (a yard seen by 48 cameras), rendered at start-up.
    Synthetic,
    /// A nerfstudio `transforms.json` (the file, or the folder holding it).
    Nerfstudio,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DataConfig {
    pub source: DataSource,
    /// nerfstudio: the folder or its `transforms.json`.
    pub path: Option<PathBuf>,
    /// Synthetic: scene seed and image side in pixels.
    pub seed: u64,
    pub size: u32,
    /// Every `test_every`-th view is held out (3DGS's "LLFF hold" of 8).
    pub test_every: usize,
    /// nerfstudio: images are box-filtered down by this integer factor.
    pub downscale: u32,
    /// Depth initialisation: back-project every `init_stride`-th pixel of each training view.
    pub init_stride: usize,
    /// Random initialisation (no depth): this many points.
    pub random_points: usize,
    /// nerfstudio: the colour behind the scene, sRGB (synthetic scenes know theirs).
    pub background: [f32; 3],
}

impl Default for DataConfig {
    fn default() -> Self {
        Self {
            source: DataSource::Synthetic,
            path: None,
            seed: 0,
            size: 96,
            test_every: 8,
            downscale: 1,
            init_stride: 4,
            random_points: 20_000,
            background: [0.0; 3],
        }
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

pub struct View {
    pub name: String,
    pub camera: Camera,
    /// `[H, W, 3]` sRGB in [0, 1].
    pub image: Tensor<3>,
}

/// Points to initialise Gaussians from.
#[derive(Debug, Clone, Default)]
pub struct InitPoints {
    pub positions: Vec<[f32; 3]>,
    /// sRGB in [0, 1].
    pub colours: Vec<[f32; 3]>,
    /// Isotropic standard deviation per point, metres.
    pub sigmas: Vec<f32>,
}

pub struct ViewSet {
    pub train: Vec<View>,
    pub test: Vec<View>,
    /// sRGB.
    pub background: [f32; 3],
    pub points: InitPoints,
    /// 3DGS's scene extent: 1.1 × the largest distance of a camera from the cameras' centroid.
    pub extent: f64,
}

impl ViewSet {
    pub fn load(config: &DataConfig, device: &Device) -> Result<Self, DataError> {
        if config.test_every < 2 || config.init_stride == 0 || config.downscale == 0 {
            return Err(DataError::Config(
                "test_every ≥ 2, init_stride ≥ 1 and downscale ≥ 1".into(),
            ));
        }
        match config.source {
            DataSource::Synthetic => synthetic(config, device),
            DataSource::Nerfstudio => {
                let path = config.path.as_ref().ok_or_else(|| {
                    DataError::Config("source = \"nerfstudio\" needs data.path".into())
                })?;
                nerfstudio(path, config, device)
            }
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

/// Back-projects every `stride`-th pixel with finite positive depth (camera z, metres).
fn back_project(
    camera: &Camera,
    depth: &[f32],
    srgb: &[f32],
    stride: usize,
    points: &mut InitPoints,
) {
    let (w, h) = (camera.width as usize, camera.height as usize);
    let m = camera.world_to_camera;
    for y in (0..h).step_by(stride) {
        for x in (0..w).step_by(stride) {
            let d = depth[y * w + x];
            if !(d.is_finite() && d > 0.0) {
                continue;
            }
            let c = [
                d * (x as f32 + 0.5 - camera.cx) / camera.fx,
                d * (y as f32 + 0.5 - camera.cy) / camera.fy,
                d,
            ];
            // World = Rᵀ (c − t).
            points.positions.push(std::array::from_fn(|j| {
                (0..3).map(|i| m[i][j] * (c[i] - m[i][3])).sum()
            }));
            let p = 3 * (y * w + x);
            points.colours.push([srgb[p], srgb[p + 1], srgb[p + 2]]);
            points.sigmas.push(0.5 * stride as f32 * d / camera.fx);
        }
    }
}

fn split<T>(items: Vec<T>, test_every: usize) -> (Vec<T>, Vec<T>) {
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
    let rendered = scene.render_frame(0);
    let mut points = InitPoints::default();
    let mut views = Vec::new();
    for (k, truth) in rendered.iter().enumerate() {
        let r = &truth.render;
        let srgb: Vec<f32> = r.color.iter().flat_map(|c| c.map(linear_to_srgb)).collect();
        if k % config.test_every != 0 {
            back_project(
                &truth.camera,
                &r.depth,
                &srgb,
                config.init_stride,
                &mut points,
            );
        }
        views.push(View {
            name: format!("view_{k:03}"),
            camera: truth.camera,
            image: Tensor::from_data(TensorData::new(srgb, [r.height, r.width, 3]), device),
        });
    }
    let extent = camera_extent(&views.iter().map(|v| v.camera).collect::<Vec<_>>());
    let (train, test) = split(views, config.test_every);
    Ok(ViewSet {
        train,
        test,
        background: scene.environment.background.map(linear_to_srgb),
        points,
        extent,
    })
}

/// Box-filters `[h, w, c]` values by an integer factor (dropping any remainder).
fn downscale(values: &[f32], w: usize, h: usize, c: usize, f: usize) -> Vec<f32> {
    let (ow, oh) = (w / f, h / f);
    let mut out = vec![0.0f32; ow * oh * c];
    for y in 0..oh * f {
        for x in 0..ow * f {
            for k in 0..c {
                out[((y / f) * ow + x / f) * c + k] += values[(y * w + x) * c + k];
            }
        }
    }
    let norm = 1.0 / (f * f) as f32;
    out.iter_mut().for_each(|v| *v *= norm);
    out
}

struct Decoded {
    srgb: Vec<f32>,
    depth: Option<Vec<f32>>,
}

fn decode(
    folder: &Path,
    file_path: &str,
    depth_path: Option<&str>,
    camera: &Camera,
    config: &DataConfig,
) -> Result<Decoded, DataError> {
    let path = folder.join(file_path);
    let image =
        image::open(&path).map_err(|e| file_error(&path, format!("cannot decode ({e})")))?;
    let (w, h) = (image.width(), image.height());
    if (w, h) != (camera.width, camera.height) {
        return Err(file_error(
            &path,
            format!(
                "image is {w}×{h}, but transforms.json gives {}×{}",
                camera.width, camera.height
            ),
        ));
    }
    let rgba = image.to_rgba32f();
    let bg = config.background;
    let mut srgb = Vec::with_capacity(3 * (w * h) as usize);
    for p in rgba.pixels() {
        let a = p[3];
        for k in 0..3 {
            srgb.push(p[k] * a + bg[k] * (1.0 - a));
        }
    }
    let depth = match depth_path {
        None => None,
        Some(d) => {
            let path = folder.join(d);
            let image = image::open(&path)
                .map_err(|e| file_error(&path, format!("cannot decode ({e})")))?;
            let image::DynamicImage::ImageLuma16(depth) = image else {
                return Err(file_error(
                    &path,
                    "expected a 16-bit greyscale PNG of depth in millimetres",
                ));
            };
            if depth.dimensions() != (w, h) {
                return Err(file_error(&path, format!("depth is not {w}×{h}")));
            }
            Some(
                depth
                    .pixels()
                    .map(|p| {
                        if p[0] == 0 {
                            f32::NAN
                        } else {
                            p[0] as f32 * 1e-3
                        }
                    })
                    .collect(),
            )
        }
    };
    let f = config.downscale as usize;
    if f == 1 {
        return Ok(Decoded { srgb, depth });
    }
    let (w, h) = (w as usize, h as usize);
    Ok(Decoded {
        srgb: downscale(&srgb, w, h, 3, f),
        // Depth is subsampled, not averaged (averaging mixes surfaces at edges).
        depth: depth.map(|d| {
            (0..(h / f) * (w / f))
                .map(|i| d[((i / (w / f)) * f + f / 2) * w + (i % (w / f)) * f + f / 2])
                .collect()
        }),
    })
}

fn nerfstudio(path: &Path, config: &DataConfig, device: &Device) -> Result<ViewSet, DataError> {
    let transforms = if path.is_dir() {
        path.join("transforms.json")
    } else {
        path.to_path_buf()
    };
    let folder = transforms.parent().unwrap_or(Path::new(".")).to_path_buf();
    let frames = read_transforms(&transforms)?;
    if frames.len() < 2 {
        return Err(file_error(
            &transforms,
            "needs at least two frames (one to train on, one held out)",
        ));
    }
    // Decoded in parallel; each image is turned into a tensor before the next batch is read,
    // so at most one batch of decoded images is in memory beside the tensors.
    let f = config.downscale;
    let mut cameras = Vec::with_capacity(frames.len());
    let mut views = Vec::with_capacity(frames.len());
    let mut points = InitPoints::default();
    let batch = rayon::current_num_threads().max(1) * 2;
    for (chunk_index, chunk) in frames.chunks(batch).enumerate() {
        let decoded: Vec<Result<Decoded, DataError>> = chunk
            .par_iter()
            .map(|frame| {
                decode(
                    &folder,
                    &frame.file_path,
                    frame.depth_file_path.as_deref(),
                    &frame.camera,
                    config,
                )
            })
            .collect();
        for (k, (frame, decoded)) in chunk.iter().zip(decoded).enumerate() {
            let index = chunk_index * batch + k;
            let decoded = decoded?;
            let mut camera = frame.camera;
            if f > 1 {
                let s = 1.0 / f as f32;
                camera.width /= f;
                camera.height /= f;
                camera.fx *= s;
                camera.fy *= s;
                camera.cx *= s;
                camera.cy *= s;
            }
            if let Some(depth) = &decoded.depth
                && !index.is_multiple_of(config.test_every)
            {
                back_project(
                    &camera,
                    depth,
                    &decoded.srgb,
                    config.init_stride,
                    &mut points,
                );
            }
            cameras.push(camera);
            let name = Path::new(&frame.file_path).file_stem().map_or_else(
                || format!("frame_{index:05}"),
                |s| s.to_string_lossy().into_owned(),
            );
            let shape = [camera.height as usize, camera.width as usize, 3];
            views.push(View {
                name,
                camera,
                image: Tensor::from_data(TensorData::new(decoded.srgb, shape), device),
            });
        }
    }
    let extent = camera_extent(&cameras);
    if points.positions.is_empty() {
        points = random_points(&cameras, config.random_points, config.seed);
    }
    let (train, test) = split(views, config.test_every);
    Ok(ViewSet {
        train,
        test,
        background: config.background,
        points,
        extent,
    })
}

/// Uniform random points with random colours in the box spanned by the cameras and the points
/// 1 m in front of each (3DGS's initialisation where no SfM points exist).
fn random_points(cameras: &[Camera], count: usize, seed: u64) -> InitPoints {
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for c in cameras {
        let p = c.position();
        let m = c.world_to_camera;
        let ahead: [f32; 3] = std::array::from_fn(|k| p[k] + m[2][k]);
        for q in [p, ahead] {
            for k in 0..3 {
                lo[k] = lo[k].min(q[k]);
                hi[k] = hi[k].max(q[k]);
            }
        }
    }
    let mut rng = Rng(seed ^ 0x4A4D_0000);
    let diagonal = (0..3).map(|k| (hi[k] - lo[k]).powi(2)).sum::<f32>().sqrt();
    let sigma = 0.5 * diagonal / (count.max(1) as f32).cbrt();
    let mut points = InitPoints::default();
    for _ in 0..count {
        points.positions.push(std::array::from_fn(|k| {
            rng.range(lo[k] as f64, hi[k] as f64) as f32
        }));
        points
            .colours
            .push(std::array::from_fn(|_| rng.next() as f32));
        points.sigmas.push(sigma);
    }
    points
}
