//! Stage B, the avatar prior (§3.2 of Prior-4D; ExAvatar on the human-scan video in the paper):
//! the avatar's canonical Gaussians, shape and per-view pose fitted to the scan's person pixels.
//! Each step renders the avatar alone over a random background `b` against `I ⊙ M + b (1 − M)`
//! (ExAvatar's human term: anything the avatar puts outside the mask costs), `0.8 L1 + 0.2
//! D-SSIM`, plus the node's pose smoothness.

use crate::avatar::posed_avatar;
use crate::camera::RigidFrame;
use crate::config::AvatarStageConfig;
use crate::data::Prior4dCapture;
use crate::error::Prior4dError;
use crate::render::render_layers;
use burn::tensor::{Device, Tensor};
use splatzoo_datasets::synth::rng::Rng;
use splatzoo_models::body::BodyModel;
use splatzoo_rasterizer::{ColorMode, RasterSettings};
use splatzoo_train::densify::{DensifyConfig, Strategy};
use splatzoo_train::harness::EpochOrder;
use splatzoo_train::loss::{masked_psnr, photometric, scalar};
use splatzoo_train::ply::read_ply;
use splatzoo_train::scene::{SceneNode, SkinnedGaussianNode, StepEnd};

/// The scan avatar's checkpoint prefix.
pub const SCAN_AVATAR: &str = "scan_avatar";

/// A background colour for step `step` of a run seeded `seed`, the same on every resume.
pub fn random_background(seed: u64, step: usize) -> [f32; 3] {
    let mut rng = Rng(seed ^ (step as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15));
    [0, 1, 2].map(|_| rng.range(0.0, 1.0) as f32)
}

/// `image ⊙ mask + b (1 − mask)`.
pub fn over_background(image: Tensor<3>, mask: Tensor<2>, background: [f32; 3]) -> Tensor<3> {
    let [h, w, _] = image.dims();
    let device = image.device();
    let m = mask.reshape([h, w, 1]);
    let b = Tensor::<1>::from_floats(background, &device).reshape([1, 1, 3]);
    image * m.clone() + b * (m.neg().add_scalar(1.0))
}

pub struct AvatarStage {
    pub node: SkinnedGaussianNode,
    pub order: EpochOrder,
    pub train: Vec<usize>,
    pub test: Vec<usize>,
    faces: Vec<u32>,
    seed: u64,
}

impl AvatarStage {
    pub fn new(
        capture: &Prior4dCapture,
        model: &BodyModel,
        config: &AvatarStageConfig,
        seed: u64,
        device: &Device,
    ) -> Result<Self, Prior4dError> {
        let views = capture.human_scan.len();
        let (test, train): (Vec<usize>, Vec<usize>) =
            (0..views).partition(|k| k % config.holdout_every == config.holdout_every - 1);
        let trained = (0..views).map(|k| !test.contains(&k)).collect();
        let mut node = SkinnedGaussianNode::new(
            SCAN_AVATAR,
            model,
            &capture.scan_prior,
            trained,
            &config.node,
            config.rates,
            &DensifyConfig {
                strategy: Strategy::None,
                ..DensifyConfig::default()
            },
            1.0,
            seed ^ 0xA7A7_0001,
            device,
        )?;
        if let Some(path) = &config.initial_ply {
            let what = format!("avatar.initial_ply {}", path.display());
            let set = read_ply(path, device)
                .map_err(|e| Prior4dError::input(what.clone(), e.to_string()))?;
            node.replace_canonical(set, &what)?;
        }
        if node.gaussians() != model.vertex_count() {
            return Err(Prior4dError::input(
                "avatar body",
                format!(
                    "{} Gaussians for {} vertices: every vertex must lie on a face",
                    node.gaussians(),
                    model.vertex_count()
                ),
            ));
        }
        Ok(Self {
            node,
            order: EpochOrder::new(seed ^ 0xA7A7_0002),
            train,
            test,
            faces: model.faces.clone(),
            seed,
        })
    }

    /// One optimiser step at stage step `step` of `steps`; returns the photometric loss.
    pub fn step(
        &mut self,
        capture: &Prior4dCapture,
        step: usize,
        steps: usize,
    ) -> Result<f64, Prior4dError> {
        let k = self.train[self.order.next(self.train.len())];
        let view = &capture.human_scan[k];
        self.node.begin_step();
        let device = view.image.device().autodiff();
        let avatar = posed_avatar(&self.node, k, &view.camera, &self.faces);
        let background = random_background(self.seed, step);
        let frame = RigidFrame::of_camera(&view.camera, &device);
        let settings = RasterSettings::new(view.camera, ColorMode::Features);
        let layers = render_layers(None, Some(&avatar), &frame, &settings, background)
            .map_err(|e| Prior4dError::Train(e.into()))?;
        let target = over_background(
            view.image.clone().autodiff(),
            view.mask.clone().autodiff(),
            background,
        );
        let photo = photometric(layers.color.clone(), target, 0.2);
        let loss = match self.node.regulariser() {
            Some(r) => photo.clone() + r,
            None => photo.clone(),
        };
        let grads = loss.backward();
        let rows = 0..self.node.gaussians();
        self.node.end_step(&StepEnd {
            grads: &grads,
            renders: vec![(&layers.render, rows)],
            step,
            progress: step as f64 / steps.max(1) as f64,
        });
        Ok(scalar(photo.inner()))
    }

    /// PSNR inside the person masks of the held-out scan views (poses interpolated).
    pub fn evaluate(&self, capture: &Prior4dCapture) -> Result<f64, Prior4dError> {
        let mut sum = 0.0;
        for &k in &self.test {
            let view = &capture.human_scan[k];
            let avatar = posed_avatar(&self.node, k, &view.camera, &self.faces);
            let frame = RigidFrame::of_camera(&view.camera, &view.image.device());
            let settings = RasterSettings::new(view.camera, ColorMode::Features);
            let layers = render_layers(None, Some(&avatar), &frame, &settings, [0.0; 3])
                .map_err(|e| Prior4dError::Train(e.into()))?;
            let target = over_background(view.image.clone(), view.mask.clone(), [0.0; 3]);
            sum += masked_psnr(layers.color.clamp(0.0, 1.0), target, view.mask.clone());
        }
        Ok(sum / self.test.len().max(1) as f64)
    }
}
