//! Training images decoded on demand, with a bounded cache, so a capture of any length trains
//! without holding every image in memory.
//!
//! A view's pixels come from an [`ImageSource`]: tensors already in memory (scenes rendered at
//! start-up), or a [`FileImage`], decoded when asked for: the image composited over the
//! background where it has alpha, its person mask read in the dataset's convention, both
//! undistorted onto the pinhole camera ([`super::undistort`]) and box-filtered down by the
//! configured factor. The [`ImageStore`] keeps the most recently used decoded frames up to a
//! byte budget (`data.cache_mib`) and drops the least recently used beyond it.

use super::DataError;
use super::undistort::{is_distorted, remap_bilinear, remap_nearest, source_coordinates};
use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_datasets::formats::{Distortion, ViewRecord};
use splatzoo_rasterizer::Camera;
use std::collections::{HashMap, VecDeque};
use std::path::PathBuf;
use std::sync::Mutex;

/// What a person mask means to the loss.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MaskRole {
    /// Marks the person (every format but nerfstudio).
    Person,
    /// Marks the pixels to train on (nerfstudio's `mask_path`: 0 = ignore).
    Valid,
}

/// One decoded frame: what a loss needs of a view.
#[derive(Clone)]
pub struct Frame {
    /// `[H, W, 3]` sRGB in [0, 1].
    pub image: Tensor<3>,
    /// `[H, W]` 1 on the person, where the view has a person mask.
    pub person: Option<Tensor<2>>,
    /// `[H, W]` 1 where the pixel is real data (inside the undistorted image, inside a
    /// nerfstudio mask); `None` when every pixel is.
    pub valid: Option<Tensor<2>>,
}

/// A view's pixels on disk and how to turn them into a [`Frame`].
#[derive(Debug, Clone)]
pub struct FileImage {
    pub image: PathBuf,
    pub mask: Option<PathBuf>,
    pub mask_role: MaskRole,
    /// The record the paths came from (its mask convention).
    pub record: ViewRecord,
    /// The camera at the file's resolution (the image must be this size).
    pub full_camera: Camera,
    pub distortion: Distortion,
    /// Box-filter factor down to the training resolution.
    pub downscale: u32,
    /// sRGB colour behind transparent pixels.
    pub background: [f32; 3],
}

/// Host-side pixels of a decoded file, at training resolution.
pub struct HostFrame {
    pub width: usize,
    pub height: usize,
    pub srgb: Vec<f32>,
    pub person: Option<Vec<f32>>,
    pub valid: Option<Vec<f32>>,
}

impl FileImage {
    /// Decodes the image and its mask (errors name the file and the size expected).
    pub fn decode(&self) -> Result<HostFrame, DataError> {
        let path = &self.image;
        let image = image::open(path)
            .map_err(|e| super::file_error(path, format!("cannot decode ({e})")))?;
        let camera = &self.full_camera;
        let (w, h) = (image.width() as usize, image.height() as usize);
        if (w as u32, h as u32) != (camera.width, camera.height) {
            return Err(super::file_error(
                path,
                format!(
                    "image is {w}×{h}, but its camera is {}×{}",
                    camera.width, camera.height
                ),
            ));
        }
        let rgba = image.to_rgba32f();
        let bg = self.background;
        let mut srgb = Vec::with_capacity(3 * w * h);
        for p in rgba.pixels() {
            let a = p[3];
            for k in 0..3 {
                srgb.push(p[k] * a + bg[k] * (1.0 - a));
            }
        }
        let mut mask = match self.record.read_mask() {
            None => None,
            Some(read) => {
                let (mw, mh, values) = read?;
                if (mw as usize, mh as usize) != (w, h) {
                    let file = self.mask.as_ref().unwrap_or(path);
                    return Err(super::file_error(
                        file,
                        format!("mask is {mw}×{mh}, expected {w}×{h} (its image's size)"),
                    ));
                }
                Some(values)
            }
        };
        let mut valid: Option<Vec<bool>> = None;
        if is_distorted(&self.distortion) {
            let coordinates = source_coordinates(camera, &self.distortion);
            let (remapped, inside) = remap_bilinear(&srgb, w, h, 3, &coordinates);
            srgb = remapped;
            mask = mask.map(|m| remap_nearest(&m, w, h, &coordinates));
            valid = Some(inside);
        }
        let (mut person, mut keep) = (None, valid);
        if let Some(m) = mask {
            match self.mask_role {
                MaskRole::Person => person = Some(m),
                MaskRole::Valid => {
                    keep = Some(match keep {
                        Some(v) => v.iter().zip(&m).map(|(&a, &b)| a && b).collect(),
                        None => m,
                    })
                }
            }
        }
        let flags = |v: Vec<bool>| v.into_iter().map(f32::from).collect::<Vec<f32>>();
        let f = self.downscale as usize;
        let (person, valid) = (person.map(flags), keep.map(flags));
        if f == 1 {
            return Ok(HostFrame {
                width: w,
                height: h,
                srgb,
                person,
                valid,
            });
        }
        Ok(HostFrame {
            width: w / f,
            height: h / f,
            srgb: box_filter(&srgb, w, h, 3, f),
            // A downscaled mask is the covered fraction; a pixel counts as valid only when
            // all of its footprint is.
            person: person.map(|m| box_filter(&m, w, h, 1, f)),
            valid: valid.map(|m| {
                box_filter(&m, w, h, 1, f)
                    .into_iter()
                    .map(|v| if v > 0.999 { 1.0 } else { 0.0 })
                    .collect()
            }),
        })
    }
}

impl HostFrame {
    pub fn upload(self, device: &Device) -> Frame {
        let (h, w) = (self.height, self.width);
        let plane = |v: Vec<f32>| Tensor::<2>::from_data(TensorData::new(v, [h, w]), device);
        Frame {
            image: Tensor::from_data(TensorData::new(self.srgb, [h, w, 3]), device),
            person: self.person.map(plane),
            valid: self.valid.map(plane),
        }
    }
}

/// Box-filters `[h, w, c]` values by an integer factor (dropping any remainder).
pub fn box_filter(values: &[f32], w: usize, h: usize, c: usize, f: usize) -> Vec<f32> {
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

/// Where a view's pixels come from.
pub enum ImageSource {
    Memory(Box<Frame>),
    File(Box<FileImage>),
}

/// Decoded frames by view key, least recently used dropped beyond the byte budget.
struct Cache {
    frames: HashMap<usize, (Frame, usize)>,
    order: VecDeque<usize>,
    bytes: usize,
}

/// Every view's [`ImageSource`] and the bounded cache of decoded files.
pub struct ImageStore {
    sources: Vec<ImageSource>,
    budget_bytes: usize,
    cache: Mutex<Cache>,
    device: Device,
}

fn frame_bytes(frame: &Frame) -> usize {
    let [h, w, _] = frame.image.dims();
    4 * h * w * (3 + usize::from(frame.person.is_some()) + usize::from(frame.valid.is_some()))
}

impl ImageStore {
    pub fn new(budget_mib: usize, device: &Device) -> Self {
        Self {
            sources: Vec::new(),
            budget_bytes: budget_mib << 20,
            cache: Mutex::new(Cache {
                frames: HashMap::new(),
                order: VecDeque::new(),
                bytes: 0,
            }),
            device: device.clone(),
        }
    }

    /// Adds a source; returns its key.
    pub fn push(&mut self, source: ImageSource) -> usize {
        self.sources.push(source);
        self.sources.len() - 1
    }

    pub fn source(&self, key: usize) -> &ImageSource {
        &self.sources[key]
    }

    /// Decoded frames held now and their bytes.
    pub fn cached(&self) -> (usize, usize) {
        let cache = self.cache.lock().expect("the cache lock is never poisoned");
        (cache.frames.len(), cache.bytes)
    }

    /// The frame of view `key`, decoding it if it is not cached.
    pub fn frame(&self, key: usize) -> Result<Frame, DataError> {
        let file = match &self.sources[key] {
            ImageSource::Memory(frame) => return Ok(frame.as_ref().clone()),
            ImageSource::File(file) => file,
        };
        {
            let mut cache = self.cache.lock().expect("the cache lock is never poisoned");
            if let Some((frame, _)) = cache.frames.get(&key) {
                let frame = frame.clone();
                cache.order.retain(|&k| k != key);
                cache.order.push_back(key);
                return Ok(frame);
            }
        }
        let frame = file.decode()?.upload(&self.device);
        self.insert(key, frame.clone());
        Ok(frame)
    }

    /// Caches a decoded frame (the loader's first pass fills the cache this way).
    pub fn insert(&self, key: usize, frame: Frame) {
        let bytes = frame_bytes(&frame);
        if bytes > self.budget_bytes {
            return;
        }
        let mut cache = self.cache.lock().expect("the cache lock is never poisoned");
        while cache.bytes + bytes > self.budget_bytes {
            let Some(old) = cache.order.pop_front() else {
                break;
            };
            if let Some((_, b)) = cache.frames.remove(&old) {
                cache.bytes -= b;
            }
        }
        if cache.frames.insert(key, (frame, bytes)).is_none() {
            cache.bytes += bytes;
            cache.order.push_back(key);
        }
    }
}
