//! NLF-GS training across synthetic identities (section 3.7 of NLF-GS): each step generates one
//! training identity's avatar from its three input views, renders it into the three target
//! views and descends the Eq. 5–7 loss with Adam. The state (network, Adam moments by parameter
//! path, step) goes into one [`Checkpoint`]; [`NlfTrainer::resume`] continues bit-exactly on the
//! CPU backends, because identities are visited in a fixed order and nothing else is random.

use crate::backend::Backend;
use crate::checkpoint::{Checkpoint, CheckpointError};
use crate::config;
use crate::loss::scalar;
use crate::module_adam::{ModuleAdam, NETWORK_ADAM};
use crate::nlf_data::{NlfSubject, posed_splats};
use crate::nlf_loss::{NlfLossInputs, NlfLossWeights, nlf_loss};
use burn::module::Module;
use burn::tensor::{Device, Tensor};
use serde::{Deserialize, Serialize};
use splatzoo_models::anchor::MeshAnchors;
use splatzoo_models::body::builtin_body;
use splatzoo_models::networks::nlf::{NlfConfig, NlfGs, NlfInputs, PosedGaussians};
use splatzoo_models::networks::query::Views;
use splatzoo_models::networks::weights::{WeightFile, load_module};
use splatzoo_rasterizer::{ColorMode, RasterSettings, rasterize};
use std::path::PathBuf;

/// Everything `train-nlf` reads from its TOML configuration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NlfTrainConfig {
    pub backend: Backend,
    /// Image side in pixels.
    pub size: u32,
    /// Training identities are seeds `0..train_subjects`; held-out ones start at `test_seed`.
    pub train_subjects: usize,
    pub test_subjects: usize,
    pub test_seed: u64,
    pub iterations: usize,
    pub learning_rate: f64,
    /// Seeds the network's random initialisation.
    pub seed: u64,
    /// Pretrained ResNet weights in torchvision naming (safetensors; `conv1.weight`,
    /// `layer1.0.bn1.running_mean`, …) to start the encoder from; the FPN and decoder start
    /// random. Without it the encoder starts random too.
    pub encoder_weights: Option<PathBuf>,
    pub eval_every: usize,
    /// Steps between checkpoints (0: only at the end and on Ctrl-C).
    pub checkpoint_every: usize,
    /// AlexNet or VGG-16 weights in torchvision naming (safetensors): adds LPIPS to the metrics.
    pub lpips_weights: Option<PathBuf>,
    /// Export the encoder and decoder to ONNX (`onnx/`) at the end.
    pub onnx: bool,
    pub network: NlfConfig,
    pub loss: NlfLossWeights,
}

impl Default for NlfTrainConfig {
    fn default() -> Self {
        Self {
            backend: Backend::Flex,
            size: 96,
            train_subjects: 12,
            test_subjects: 3,
            test_seed: 10_000,
            iterations: 500,
            learning_rate: 5e-4,
            seed: 0,
            encoder_weights: None,
            eval_every: 100,
            checkpoint_every: 100,
            lpips_weights: None,
            onnx: true,
            network: NlfConfig::default(),
            loss: NlfLossWeights::default(),
        }
    }
}

impl NlfTrainConfig {
    pub fn check(&self) -> Result<(), String> {
        if self.iterations == 0 || self.train_subjects == 0 || self.test_subjects == 0 {
            return Err("iterations, train_subjects and test_subjects must be ≥ 1".into());
        }
        if self.size < 32 {
            return Err(format!("size {} is below the minimum of 32", self.size));
        }
        if !(self.learning_rate > 0.0 && self.learning_rate.is_finite()) {
            return Err(format!(
                "learning_rate {} must be positive",
                self.learning_rate
            ));
        }
        Ok(())
    }
}

/// The checkpoint format this trainer writes (and `drive-nlf` reads).
pub const FORMAT: &str = "splatzoo-nlf-1";

pub struct NlfTrainer {
    pub config: NlfTrainConfig,
    /// The network, on the autodiff device.
    model: NlfGs,
    optimizer: ModuleAdam,
    /// Steps taken.
    pub step: usize,
    pub train: Vec<NlfSubject>,
    pub test: Vec<NlfSubject>,
    pub faces: Vec<u32>,
    pub anchors: MeshAnchors,
}

impl NlfTrainer {
    /// A fresh network (seeded by `config.seed`) and the identities.
    pub fn new(config: NlfTrainConfig, device: &Device) -> Result<Self, String> {
        config.check()?;
        device.seed(config.seed);
        let mut model = NlfGs::new(&config.network, device);
        if let Some(path) = &config.encoder_weights {
            let file = WeightFile::read(path).map_err(|e| e.to_string())?;
            model
                .encoder
                .load_backbone(&file)
                .map_err(|e| e.to_string())?;
        }
        let model = model.train();
        Ok(Self::with_model(
            config,
            model,
            ModuleAdam::new(NETWORK_ADAM),
            0,
            device,
        ))
    }

    /// The configuration a checkpoint was trained with.
    pub fn checkpoint_config(checkpoint: &Checkpoint) -> Result<NlfTrainConfig, String> {
        let format = checkpoint.meta("format").map_err(|e| e.to_string())?;
        if format != FORMAT {
            return Err(format!(
                "{}: format `{format}`, expected `{FORMAT}`",
                checkpoint.origin
            ));
        }
        let text = checkpoint.meta("config").map_err(|e| e.to_string())?;
        toml::from_str(text).map_err(|e| format!("{}: metadata `config`: {e}", checkpoint.origin))
    }

    /// Continues from `checkpoint` (network, Adam moments, step) with `config`, which may
    /// change the schedule but not the network.
    pub fn resume(
        config: NlfTrainConfig,
        checkpoint: &Checkpoint,
        device: &Device,
    ) -> Result<Self, String> {
        config.check()?;
        let saved = Self::checkpoint_config(checkpoint)?;
        if saved.network != config.network {
            return Err(format!(
                "{}: the network configuration differs from the checkpoint's",
                checkpoint.origin
            ));
        }
        let step: usize = checkpoint
            .meta_parsed("step")
            .map_err(|e: CheckpointError| e.to_string())?;
        let file = WeightFile::new(checkpoint.origin.clone(), checkpoint.tensors.clone());
        let model = load_module(NlfGs::new(&config.network, device), &file)
            .map_err(|e| e.to_string())?
            .train();
        let optimizer =
            ModuleAdam::load(NETWORK_ADAM, &model, checkpoint).map_err(|e| e.to_string())?;
        Ok(Self::with_model(config, model, optimizer, step, device))
    }

    fn with_model(
        config: NlfTrainConfig,
        model: NlfGs,
        optimizer: ModuleAdam,
        step: usize,
        device: &Device,
    ) -> Self {
        let train = (0..config.train_subjects as u64)
            .map(|s| NlfSubject::synthetic(s, config.size, device))
            .collect();
        let test = (0..config.test_subjects as u64)
            .map(|s| NlfSubject::synthetic(config.test_seed + s, config.size, device))
            .collect();
        let faces = builtin_body().model.faces.clone();
        let anchors = MeshAnchors::per_face(faces.len() / 3, config.network.gaussians_per_face);
        Self {
            config,
            model,
            optimizer,
            step,
            train,
            test,
            faces,
            anchors,
        }
    }

    /// The network without autodiff, for evaluation and export.
    pub fn model(&self) -> NlfGs {
        self.model.valid()
    }

    /// `subject`'s avatar from `model`, posed as in its images.
    pub fn avatar(&self, model: &NlfGs, subject: &NlfSubject) -> PosedGaussians {
        let network = &self.config.network;
        model
            .generate(
                &subject.nlf_inputs(&self.faces, &self.anchors),
                network.fusion,
                network.occlusion_tolerance,
            )
            .drive(subject.vertices.clone(), &self.faces, &self.anchors)
    }

    /// One step on the next training identity; returns the loss.
    pub fn step(&mut self) -> Result<f64, String> {
        self.step += 1;
        let subject = &self.train[(self.step * 7) % self.train.len()];
        let (images, views, centres) = subject.input_tensors();
        let inputs = NlfInputs {
            images: images.autodiff(),
            views: Views {
                intrinsics: views.intrinsics.autodiff(),
                world_to_camera: views.world_to_camera.autodiff(),
                size: views.size,
            },
            camera_centres: centres.autodiff(),
            vertices: subject.vertices.clone().autodiff(),
            faces: &self.faces,
            anchors: &self.anchors,
            depth: Some(subject.input_depth.clone().autodiff()),
        };
        let network = &self.config.network;
        let avatar = self
            .model
            .generate(&inputs, network.fusion, network.occlusion_tolerance);
        let posed = avatar.drive(
            subject.vertices.clone().autodiff(),
            &self.faces,
            &self.anchors,
        );
        let splats = posed_splats(posed);
        let device = subject.vertices.device();
        let background =
            Tensor::<1>::from_floats(subject.background.as_slice(), &device).autodiff();
        let mut total: Option<Tensor<1>> = None;
        for view in &subject.targets {
            let settings = RasterSettings::new(view.camera, ColorMode::Sh { degree: 0 });
            let render =
                rasterize(&splats, background.clone(), &settings).map_err(|e| e.to_string())?;
            let loss = nlf_loss(
                NlfLossInputs {
                    image: render.color,
                    target: view.image.clone().autodiff(),
                    alpha: render.alpha,
                    mask: view.mask.clone().autodiff(),
                    log_scales: avatar.attributes.log_scales.clone(),
                    offsets: avatar.attributes.offset.clone(),
                    opacity_logits: avatar.attributes.opacity_logits.clone(),
                },
                &self.config.loss,
            )
            .total;
            total = Some(match total {
                Some(t) => t + loss,
                None => loss,
            });
        }
        let loss = total.ok_or("no target views")? / subject.targets.len() as f64;
        let value = scalar(loss.clone().inner());
        if !value.is_finite() {
            return Err(format!("step {}: the loss is {value}", self.step));
        }
        let grads = loss.backward();
        let model = self.model.clone();
        self.model = self
            .optimizer
            .step(model, &grads, self.config.learning_rate);
        Ok(value)
    }

    /// The network by parameter path, the Adam moments (`optimizer.<path>.exp_avg[_sq]`), the
    /// step, and the configuration (whole, and the network's part for `drive-nlf`).
    pub fn checkpoint(&self) -> Checkpoint {
        let mut checkpoint = Checkpoint {
            tensors: splatzoo_models::networks::weights::module_tensors(&self.model),
            ..Default::default()
        };
        self.optimizer.save(&self.model, &mut checkpoint);
        checkpoint.put_meta("format", FORMAT);
        checkpoint.put_meta("network", config::to_toml(&self.config.network));
        checkpoint.put_meta("config", config::to_toml(&self.config));
        checkpoint.put_meta("step", self.step);
        checkpoint
    }
}
