//! One AAGaussian optimiser step (§3 of the paper, spec §1): B random views of the canonical
//! Gaussians (RGB and accumulated depth), the dual-branch SDS gradient from the score model
//! (Eq. 5), the sparsity term (U4), and from the face-loss start the fixed face view with the
//! facial rendering loss (Eq. 6: `λ₁ L_SDS1 + λ₂ L_SDS2 + λ₃ L_f + λ₄ L_s`), then the
//! avatar's own Adam step and density control (ADC on the schedule, then prune-only).

use crate::cameras::BatchKind;
use crate::config::AagConfig;
use crate::data::PortraitCapture;
use crate::error::AagError;
use crate::face::{LineOfSight, centre_weights, face_colour_loss};
use crate::init::initial_gaussians;
use crate::loss::{depth_branch, rgb_branch, sparsity};
use crate::oracle::{Components, MixtureOracle};
use crate::schedule::NoiseSchedule;
use crate::score::{LatentBatch, ScoreModel};
use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_datasets::synth::rng::Rng;
use splatzoo_models::networks::vae::VaeEncoder;
use splatzoo_rasterizer::{Camera, ColorMode, RasterSettings, Render, Splats, rasterize};
use splatzoo_train::clip_score::ClipScorer;
use splatzoo_train::densify::DensifyReport;
use splatzoo_train::host_f32;
use splatzoo_train::scene::{GaussianNode, SceneNode, StepEnd};

/// The avatar's checkpoint prefix.
pub const AVATAR: &str = "avatar";

/// What one step did (for the log and the tests).
#[derive(Debug, Clone, Default)]
pub struct StepRecord {
    pub loss: f64,
    pub sds_rgb: f64,
    pub sds_depth: f64,
    pub sparsity: f64,
    /// The face term when the face view was drawn this step.
    pub face: Option<f64>,
    pub t: Vec<usize>,
    pub kind: Option<BatchKind>,
    pub nonfinite: usize,
    pub density: Option<DensifyReport>,
}

pub struct AagTrainer {
    pub config: AagConfig,
    pub capture: PortraitCapture,
    pub model: Box<dyn ScoreModel>,
    pub node: GaussianNode,
    pub rng: Rng,
    pub step: usize,
    pub line_of_sight: LineOfSight,
    /// The latent encoder of a latent-space guidance model (`None`: pixel space).
    pub vae: Option<VaeEncoder>,
    /// The CLIP scorer of the held-out views, where `clip` is given.
    pub clip: Option<ClipScorer>,
    face_weights: Vec<f32>,
    /// `[S, S, 3]` the face crop.
    face_crop: Tensor<3>,
}

/// Renders `splats` from each camera over black (SH degree 0).
pub fn render_views(splats: &Splats, cameras: &[Camera]) -> Result<Vec<Render>, AagError> {
    let device = splats.means.device();
    cameras
        .iter()
        .map(|camera| {
            let settings = RasterSettings::new(*camera, ColorMode::Sh { degree: 0 });
            Ok(rasterize(
                splats,
                Tensor::<1>::zeros([3], &device),
                &settings,
            )?)
        })
        .collect()
}

/// A `[3, H, W]` planar host image as an `[H, W, 3]` tensor.
pub fn planar_to_tensor(planar: &[f32], size: usize, device: &Device) -> Tensor<3> {
    Tensor::<3>::from_data(
        TensorData::new(planar.to_vec(), vec![3, size, size]),
        device,
    )
    .permute([1, 2, 0])
}

fn host_batch(tensor: &Tensor<4>) -> LatentBatch {
    LatentBatch {
        shape: tensor.dims(),
        data: host_f32(tensor),
    }
}

/// The oracle the configuration describes over the capture's identities; none for a user's
/// photo (no identities).
pub fn mixture_oracle(config: &AagConfig, capture: &PortraitCapture) -> Option<MixtureOracle> {
    let data = &config.data;
    Some(MixtureOracle {
        schedule: NoiseSchedule::of(config.oracle.schedule),
        prediction: config.oracle.prediction,
        data_noise: config.oracle.data_noise,
        components: Components::labels(data.prompt, data.negative, data.identities),
        branches: config.oracle.branches,
        targets: Box::new(capture.truth.as_ref()?.bank.clone()),
    })
}

impl AagTrainer {
    /// A fresh run on `capture` with `model` as the guidance (training tensors on `device`,
    /// an autodiff device).
    pub fn new(
        config: AagConfig,
        capture: PortraitCapture,
        model: Box<dyn ScoreModel>,
        device: &Device,
    ) -> Self {
        let set = initial_gaussians(
            config.init,
            &capture.canonical,
            &capture.body.faces,
            config.gaussians,
            config.seed,
            device,
        );
        let mut node = GaussianNode::new(
            AVATAR,
            set,
            config.rates,
            &config.densify,
            config.extent,
            config.seed ^ 0xA4A6,
        );
        node.optimizer.config.beta2 = config.adam_beta2;
        let size = config.data.face_size as usize;
        let line_of_sight = LineOfSight {
            camera: capture.face_camera,
            mask: capture.face_mask.clone(),
            depth: capture.face_depth.clone(),
            margin: config.face.margin,
            distance: config.data.face_distance,
        };
        let face_crop = planar_to_tensor(&capture.face_crop, size, device);
        Self {
            vae: None,
            clip: None,
            face_weights: centre_weights(size, config.face.kappa),
            rng: Rng(config.seed.wrapping_mul(0x9E37_79B9).wrapping_add(17)),
            config,
            capture,
            model,
            node,
            step: 0,
            line_of_sight,
            face_crop,
        }
    }

    /// Whether SDS has its depth branch (Eq. 5): only where the guidance model denoises depth
    /// beside RGB. A one-branch model's renders are never depth-encoded (with a VAE, one
    /// encoder pass of every view a step saved).
    pub fn depth_branch(&self) -> bool {
        self.model.branches() == 2
    }

    /// Whether the face term is on at step `step` (Eq. 6's λ₃ = 0 before its start).
    pub fn face_active(&self, step: usize) -> bool {
        self.config.face.weight > 0.0 && step >= self.config.face.start
    }

    /// L_f (U5 + λ_los U6) on the leaves' face view.
    pub fn face_loss(&self, splats: &Splats) -> Result<(Tensor<1>, Render), AagError> {
        let render = render_views(splats, &[self.capture.face_camera])?.remove(0);
        let crop = if render.color.is_autodiff() {
            self.face_crop.clone().autodiff()
        } else {
            self.face_crop.clone()
        };
        let colour = face_colour_loss(
            render.color.clone(),
            crop,
            &self.face_weights,
            self.config.face.norm,
        );
        let mut loss = colour;
        if self.config.face.line_of_sight > 0.0 {
            let los = self
                .line_of_sight
                .loss(splats.means.clone(), splats.opacity_logits.clone())?;
            loss = loss + los.mul_scalar(self.config.face.line_of_sight);
        }
        Ok((loss, render))
    }

    /// One optimiser step.
    pub fn train_step(&mut self) -> Result<StepRecord, AagError> {
        if self.node.gaussians() == 0 {
            return Err(AagError::input(
                "avatar",
                format!(
                    "every Gaussian has been pruned by step {} (densify.min_opacity {}, \
                     prune_only_min_opacity {}): lower them",
                    self.step,
                    self.config.densify.min_opacity,
                    self.config.densify.prune_only_min_opacity
                ),
            ));
        }
        let config = &self.config;
        let step = self.step;
        let views = config.cameras.sample(
            step,
            config.batch,
            config.render_size,
            self.capture.head_height,
            &mut self.rng,
        );
        self.node.begin_step();
        let splats = self
            .node
            .leaves()
            .expect("leaves between begin_step and end_step")
            .splats();
        let cameras: Vec<Camera> = views.iter().map(|v| v.camera).collect();
        let mut renders = render_views(&splats, &cameras)?;
        // z = latent_scale · E(x): the VAE (its scaling factor is the model's) or the identity.
        // The depth branch is encoded only where the guidance model denoises depth (Eq. 5).
        let scale = self.model.latent_scale();
        let z_rgb = match &self.vae {
            Some(vae) => vae.encode(rgb_branch(&renders)),
            None => rgb_branch(&renders).mul_scalar(scale),
        };
        let z_depth = self.depth_branch().then(|| match &self.vae {
            Some(vae) => vae.encode(depth_branch(&renders).repeat_dim(1, 3)),
            None => depth_branch(&renders).mul_scalar(scale),
        });
        let mut inputs = vec![host_batch(&z_rgb)];
        if let Some(z) = &z_depth {
            inputs.push(host_batch(z));
        }
        let sds_views: Vec<_> = views.iter().map(|v| v.sds_view()).collect();
        let guidance = config.sds.guidance(
            self.model.as_ref(),
            &inputs,
            &sds_views,
            step,
            &mut self.rng,
        )?;
        let sds_rgb = crate::sds::surrogate(z_rgb, &guidance.grads[0], config.sds.lambda_rgb)?;
        let mut record = StepRecord {
            t: guidance.t.clone(),
            kind: views.first().map(|v| v.kind),
            nonfinite: guidance.nonfinite,
            sds_rgb: splatzoo_train::loss::scalar(sds_rgb.clone()),
            ..StepRecord::default()
        };
        let mut loss = sds_rgb;
        if let (Some(g), Some(z_depth)) = (guidance.grads.get(1), z_depth) {
            let sds_depth = crate::sds::surrogate(z_depth, g, config.sds.lambda_depth)?;
            record.sds_depth = splatzoo_train::loss::scalar(sds_depth.clone());
            loss = loss + sds_depth;
        }
        if config.sparsity > 0.0 {
            let s = sparsity(&renders, config.sparsity_kind);
            record.sparsity = splatzoo_train::loss::scalar(s.clone());
            loss = loss + s.mul_scalar(config.sparsity);
        }
        if self.face_active(step) && self.rng.next() < config.face.probability {
            let (face, render) = self.face_loss(&splats)?;
            record.face = Some(splatzoo_train::loss::scalar(face.clone()));
            loss = loss + face.mul_scalar(config.face.weight);
            renders.push(render);
        }
        record.loss = splatzoo_train::loss::scalar(loss.clone());
        let grads = loss.backward();
        let rows = 0..self.node.gaussians();
        let progress = step as f64 / config.iterations.max(1) as f64;
        record.density = self.node.end_step(&StepEnd {
            grads: &grads,
            renders: renders.iter().map(|r| (r, rows.clone())).collect(),
            step,
            progress,
        });
        self.step += 1;
        Ok(record)
    }
}
