//! The CLIP score of renders against a text prompt (Hessel et al., "CLIPScore", 2021, in
//! torchmetrics' scaling): `100 · max(cos(E_I(x), e_T), 0)`, with `E_I` the user's CLIP image
//! encoder as an ONNX graph run in tract and `e_T` the prompt's text embedding, computed by the
//! user's CLIP text encoder beforehand and stored in safetensors. Nothing ships or is
//! downloaded: a TOML file names both (paths relative to it):
//!
//! ```toml
//! image_encoder = "clip_visual.onnx"   # [1, 3, S, S] f32 → [1, D] (the projected embedding)
//! text_embedding = "prompt.safetensors" # key "text_embedding", [D] or [1, D]
//! size = 224                            # S (CLIP ViT-B/32, ViT-L/14: 224)
//! mean = [0.48145466, 0.4578275, 0.40821073]   # CLIP's normalisation (the defaults)
//! std = [0.26862954, 0.26130258, 0.27577711]
//! ```
//!
//! An image `[H, W, 3]` in [0, 1] is resized to `S × S` by bilinear sampling (half-pixel
//! centres; CLIP's own preprocessing resizes the short side bicubically and crops the centre,
//! which is the same for the square renders scored here up to the filter), normalised per
//! channel and laid out NCHW. The graph's plan is built once, for that one input shape.

use crate::checkpoint::Checkpoint;
use crate::onnx::OnnxError;
use burn::tensor::Tensor;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use tract_onnx::prelude::{
    Datum, Framework, InferenceFact, InferenceModelExt, IntoRunnable, IntoTValue,
    Tensor as TractTensor, TypedRunnableModel, tvec,
};

/// The safetensors key of the prompt's text embedding.
pub const TEXT_EMBEDDING: &str = "text_embedding";

/// The TOML above.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClipConfig {
    pub image_encoder: PathBuf,
    pub text_embedding: PathBuf,
    #[serde(default = "clip_size")]
    pub size: usize,
    #[serde(default = "clip_mean")]
    pub mean: [f32; 3],
    #[serde(default = "clip_std")]
    pub std: [f32; 3],
}

fn clip_size() -> usize {
    224
}

fn clip_mean() -> [f32; 3] {
    [0.481_454_66, 0.457_827_5, 0.408_210_73]
}

fn clip_std() -> [f32; 3] {
    [0.268_629_54, 0.261_302_6, 0.275_777_1]
}

/// A loaded image encoder and prompt embedding.
pub struct ClipScorer {
    pub config: ClipConfig,
    graph: PathBuf,
    plan: Arc<TypedRunnableModel>,
    /// The prompt's embedding, unit length.
    text: Vec<f32>,
}

impl std::fmt::Debug for ClipScorer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ClipScorer")
            .field("config", &self.config)
            .field("dimension", &self.text.len())
            .finish()
    }
}

fn unit(values: &[f32]) -> Option<Vec<f32>> {
    let norm = values
        .iter()
        .map(|v| f64::from(*v).powi(2))
        .sum::<f64>()
        .sqrt();
    (norm.is_finite() && norm > 0.0).then(|| {
        values
            .iter()
            .map(|v| (f64::from(*v) / norm) as f32)
            .collect()
    })
}

impl ClipScorer {
    /// Reads the TOML at `path`, its graph and its text embedding; every problem names the file.
    pub fn load(path: &Path) -> Result<Self, OnnxError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| OnnxError::new(path, format!("cannot read ({e})")))?;
        let config: ClipConfig =
            toml::from_str(&text).map_err(|e| OnnxError::new(path, e.to_string()))?;
        let folder = path.parent().unwrap_or(Path::new("."));
        Self::with_config(config, folder)
    }

    /// `config` with its files relative to `folder`.
    pub fn with_config(config: ClipConfig, folder: &Path) -> Result<Self, OnnxError> {
        let graph = folder.join(&config.image_encoder);
        if config.size == 0 || config.std.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
            return Err(OnnxError::new(
                &graph,
                format!(
                    "size {} and std {:?} must be positive",
                    config.size, config.std
                ),
            ));
        }
        let embedding_file = folder.join(&config.text_embedding);
        let checkpoint = Checkpoint::read(&embedding_file)
            .map_err(|e| OnnxError::new(&embedding_file, e.to_string()))?;
        let (shape, values) = checkpoint.tensors.get(TEXT_EMBEDDING).ok_or_else(|| {
            OnnxError::new(
                &embedding_file,
                format!("no `{TEXT_EMBEDDING}` tensor ([D] or [1, D])"),
            )
        })?;
        if !matches!(shape.as_slice(), [_] | [1, _]) {
            return Err(OnnxError::new(
                &embedding_file,
                format!("`{TEXT_EMBEDDING}` has shape {shape:?}, expected [D] or [1, D]"),
            ));
        }
        let text = unit(values).ok_or_else(|| {
            OnnxError::new(
                &embedding_file,
                format!("`{TEXT_EMBEDDING}` is zero or not finite"),
            )
        })?;
        let fail = |e: tract_onnx::prelude::TractError| OnnxError::new(&graph, format!("{e:#}"));
        let mut model = tract_onnx::onnx().model_for_path(&graph).map_err(fail)?;
        let inputs = model.input_outlets().map_err(fail)?.len();
        if inputs != 1 {
            return Err(OnnxError::new(
                &graph,
                format!("{inputs} graph inputs; an image encoder takes one image"),
            ));
        }
        let s = config.size;
        model
            .set_input_fact(0, InferenceFact::dt_shape(f32::datum_type(), [1, 3, s, s]))
            .map_err(fail)?;
        let plan = model
            .into_optimized()
            .and_then(|m| m.into_runnable())
            .map_err(|e| {
                OnnxError::new(
                    &graph,
                    format!("cannot prepare for a [1, 3, {s}, {s}] image ({e:#})"),
                )
            })?;
        let scorer = Self {
            config,
            graph,
            plan,
            text,
        };
        // One probe image checks the output's width against the text embedding now, not at
        // the first evaluation.
        scorer.image_embedding(&vec![0.5; 3 * s * s])?;
        Ok(scorer)
    }

    /// The embedding's width.
    pub fn dimension(&self) -> usize {
        self.text.len()
    }

    /// `[3, S, S]` planar, normalised: what the graph takes for an `[H, W, 3]` image in [0, 1].
    pub fn preprocess(&self, image: &[f32], height: usize, width: usize) -> Vec<f32> {
        let s = self.config.size;
        let mut out = vec![0.0f32; 3 * s * s];
        let sample = |y: f64, x: f64, c: usize| -> f32 {
            let y = y.clamp(0.0, (height - 1) as f64);
            let x = x.clamp(0.0, (width - 1) as f64);
            let (y0, x0) = (y.floor() as usize, x.floor() as usize);
            let (y1, x1) = ((y0 + 1).min(height - 1), (x0 + 1).min(width - 1));
            let (fy, fx) = ((y - y0 as f64) as f32, (x - x0 as f64) as f32);
            let at = |yy: usize, xx: usize| image[(yy * width + xx) * 3 + c];
            let top = at(y0, x0) * (1.0 - fx) + at(y0, x1) * fx;
            let bottom = at(y1, x0) * (1.0 - fx) + at(y1, x1) * fx;
            top * (1.0 - fy) + bottom * fy
        };
        let (sy, sx) = (height as f64 / s as f64, width as f64 / s as f64);
        for c in 0..3 {
            for i in 0..s {
                for j in 0..s {
                    let v = sample((i as f64 + 0.5) * sy - 0.5, (j as f64 + 0.5) * sx - 0.5, c);
                    out[(c * s + i) * s + j] = (v - self.config.mean[c]) / self.config.std[c];
                }
            }
        }
        out
    }

    /// The graph's embedding of one preprocessed image `[3, S, S]`, unit length.
    pub fn image_embedding(&self, planar: &[f32]) -> Result<Vec<f32>, OnnxError> {
        let s = self.config.size;
        let fail =
            |e: tract_onnx::prelude::TractError| OnnxError::new(&self.graph, format!("{e:#}"));
        let input = TractTensor::from_shape(&[1, 3, s, s], planar).map_err(fail)?;
        let outputs = self.plan.run(tvec![input.into_tvalue()]).map_err(fail)?;
        let first = outputs
            .first()
            .ok_or_else(|| OnnxError::new(&self.graph, "the graph gave no output"))?;
        let view = first.to_plain_array_view::<f32>().map_err(fail)?;
        let values: Vec<f32> = view.iter().copied().collect();
        if values.len() != self.text.len() {
            return Err(OnnxError::new(
                &self.graph,
                format!(
                    "the image embedding has shape {:?}; the text embedding has {} values",
                    view.shape(),
                    self.text.len()
                ),
            ));
        }
        unit(&values)
            .ok_or_else(|| OnnxError::new(&self.graph, "the image embedding is zero or not finite"))
    }

    /// `100 · max(cos, 0)` of an `[H, W, 3]` image in [0, 1] against the prompt.
    pub fn score(&self, image: Tensor<3>) -> Result<f64, OnnxError> {
        let [h, w, c] = image.dims();
        if c != 3 || h == 0 || w == 0 {
            return Err(OnnxError::new(
                &self.graph,
                format!("an image of [{h}, {w}, {c}]; CLIP scores [H, W, 3]"),
            ));
        }
        let pixels = crate::host_f32(&image.clamp(0.0, 1.0));
        let embedding = self.image_embedding(&self.preprocess(&pixels, h, w))?;
        let cos: f64 = embedding
            .iter()
            .zip(&self.text)
            .map(|(a, b)| f64::from(*a) * f64::from(*b))
            .sum();
        Ok(100.0 * cos.max(0.0))
    }
}

/// A stand-in CLIP for tests (no real weights ship): [`fixture::write_tiny_clip`] writes a
/// random small convolutional image encoder (3×3 convolution, stride 2, 4 channels, ReLU, one
/// linear layer to the embedding's width) exported to ONNX, a text embedding, and the TOML
/// naming both, and returns the TOML's path and the encoder, whose
/// [`fixture::TinyImageEncoder::forward`] is the graph's Burn twin.
pub mod fixture {
    use super::TEXT_EMBEDDING;
    use crate::checkpoint::Checkpoint;
    use crate::onnx::{OnnxError, write_graph};
    use burn::module::Module;
    use burn::nn::conv::{Conv2d, Conv2dConfig};
    use burn::nn::{Linear, LinearConfig};
    use burn::tensor::activation::relu;
    use burn::tensor::{Device, Tensor};
    use std::path::{Path, PathBuf};

    #[derive(Module, Debug)]
    pub struct TinyImageEncoder {
        conv: Conv2d,
        head: Linear,
        #[module(skip)]
        features: usize,
    }

    impl TinyImageEncoder {
        /// For `[1, 3, size, size]` images (`size` ≥ 3), embeddings of width `dim`.
        pub fn new(size: usize, dim: usize, device: &Device) -> Self {
            let side = (size - 3) / 2 + 1;
            let features = 4 * side * side;
            Self {
                conv: Conv2dConfig::new([3, 4], [3, 3])
                    .with_stride([2, 2])
                    .init(device),
                head: LinearConfig::new(features, dim).init(device),
                features,
            }
        }

        pub fn forward(&self, image: Tensor<4>) -> Tensor<2> {
            let x = relu(self.conv.forward(image));
            self.head.forward(x.reshape([1, self.features]))
        }
    }

    /// Writes `visual.onnx`, `prompt.safetensors` (`text`) and `clip.toml` into `dir`.
    pub fn write_tiny_clip(
        dir: &Path,
        size: usize,
        text: &[f32],
        device: &Device,
    ) -> Result<(PathBuf, TinyImageEncoder), OnnxError> {
        let encoder = TinyImageEncoder::new(size, text.len(), device);
        let graph = dir.join("visual.onnx");
        let sample = Tensor::<4>::zeros([1, 3, size, size], device);
        let model = burn_onnx::export::OnnxExporter::new()
            .export(&encoder, sample, TinyImageEncoder::forward)
            .map_err(|e| OnnxError::new(&graph, format!("export failed ({e})")))?;
        write_graph(model.as_bytes(), &["image"], &["embedding"], &graph)?;
        let prompt = dir.join("prompt.safetensors");
        let mut file = Checkpoint::default();
        file.tensors
            .insert(TEXT_EMBEDDING.into(), (vec![text.len()], text.to_vec()));
        file.write(&prompt)
            .map_err(|e| OnnxError::new(&prompt, e.to_string()))?;
        let toml = dir.join("clip.toml");
        let body = format!(
            "image_encoder = \"visual.onnx\"\ntext_embedding = \"prompt.safetensors\"\nsize = {size}\n"
        );
        splatzoo_models::files::write_atomically(&toml, |tmp| std::fs::write(tmp, &body))
            .map_err(|e| OnnxError::new(&toml, e.to_string()))?;
        Ok((toml, encoder))
    }
}
