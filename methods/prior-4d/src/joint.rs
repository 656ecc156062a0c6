//! Stage D, joint optimisation on the acting video (§4.3–4.4 of Prior-4D): the acting cameras
//! (refinement `ω_t, τ_t`), the body motion and shape (the skinned node's pose table and β), the
//! global scale `s = ln σ`, the avatar's colours, radii and cloth offsets (its canonical
//! Gaussians), the pose-dependent offsets (Eq. 2) and the scene's SH only (its geometry frozen:
//! zero learning rates on means, rotations, scales and opacity, no density control), under
//!
//! `L = L_photo(comp) + L_photo(h) + L_photo(s) + λ_n L_normal + λ_c L_contact + λ_r L_Huber`
//!
//! with the photometric terms `0.8 L1 + 0.2 D-SSIM` on the composite, on the avatar alone over a
//! random background against `I ⊙ M + b (1 − M)`, and on the scene alone off the person mask.
//! The contact term sees the acting camera detached (spec Eq. 7 (vi)), so cameras answer to the
//! scene's pixels only.

use crate::avatar::{canonical_appearance, posed_avatar};
use crate::avatar_stage::{over_background, random_background};
use crate::camera::RigidFrame;
use crate::config::Prior4dConfig;
use crate::contact::{contact_loss, foot_vertices};
use crate::data::Prior4dCapture;
use crate::error::Prior4dError;
use crate::init::{Initialisation, fit_floor, sigma_from_plane};
use crate::locate::place;
use crate::loss::{huber_prior, normal_loss};
use crate::offsets::{PoseOffsetNet, PoseOffsets};
use crate::plane::Plane;
use crate::render::{AvatarSplats, Layers, SceneSplats, render_layers};
use burn::module::Module;
use burn::tensor::{Device, Int, Tensor, TensorData};
use splatzoo_models::body::BodyModel;
use splatzoo_rasterizer::{ColorMode, RasterSettings, Splats};
use splatzoo_train::adam::{AdamConfig, AdamState};
use splatzoo_train::checkpoint::Checkpoint;
use splatzoo_train::densify::{DensifyConfig, Strategy};
use splatzoo_train::harness::EpochOrder;
use splatzoo_train::host_f32;
use splatzoo_train::loss::{l1, masked_l1, masked_ssim, scalar, ssim};
use splatzoo_train::module_adam::{ModuleAdam, NETWORK_ADAM};
use splatzoo_train::scene::skinned::SkinnedConfig;
use splatzoo_train::scene::{
    FrameContext, FrameQuery, GaussianNode, SceneNode, SkinnedGaussianNode, StepEnd,
};

/// Checkpoint prefixes of stage D's nodes.
pub const JOINT_SCENE: &str = "joint_scene";
pub const AVATAR: &str = "avatar";

/// Adam for the scalar and per-frame tables (ε 1e-8).
pub const TABLE_ADAM: AdamConfig = NETWORK_ADAM;

/// The parts of a stage-D step's loss, for the log.
#[derive(Debug, Clone, Copy, Default)]
pub struct JointTerms {
    pub photo: f64,
    pub normal: f64,
    pub contact: f64,
    pub huber: f64,
}

pub struct JointStage {
    pub scene: GaussianNode,
    pub avatar: SkinnedGaussianNode,
    pub offsets: PoseOffsetNet,
    pub offsets_adam: ModuleAdam,
    /// `[1]` s = ln σ.
    pub log_sigma: Tensor<1>,
    pub sigma_adam: AdamState<1>,
    /// `[F, 3]` camera refinement per acting frame: rotation (axis-angle) and translation (per
    /// unit of `extent`).
    pub camera_rotation: Tensor<2>,
    pub camera_translation: Tensor<2>,
    pub rotation_adam: AdamState<2>,
    pub translation_adam: AdamState<2>,
    pub init: Initialisation,
    pub order: EpochOrder,
    /// The acting frames stage D samples (all but a real capture's held-out ones).
    trained: Vec<usize>,
    /// Scene units per unit of camera translation.
    pub extent: f64,
    pub sh_degree: u32,
    prior_colours: Tensor<2>,
    prior_log_radii: Tensor<1>,
    pub feet: Vec<usize>,
    pub(crate) faces: Vec<u32>,
    seed: u64,
}

/// The avatar node of stage D: the acting video's camera-space body prior, stage D's rates,
/// every frame refined.
fn acting_avatar(
    capture: &Prior4dCapture,
    model: &BodyModel,
    config: &Prior4dConfig,
    device: &Device,
) -> Result<SkinnedGaussianNode, Prior4dError> {
    let j = &config.joint;
    let node_config = SkinnedConfig {
        rotation_rate: j.rates.rotation,
        translation_rate: j.rates.translation,
        shape_rate: j.rates.shape,
        ..config.avatar.node.clone()
    };
    Ok(SkinnedGaussianNode::new(
        AVATAR,
        model,
        &capture.acting_prior,
        vec![true; capture.acting.len()],
        &node_config,
        j.rates.avatar,
        &DensifyConfig {
            strategy: Strategy::None,
            ..DensifyConfig::default()
        },
        1.0,
        config.seed ^ 0xD0D0_0001,
        device,
    )?)
}

impl JointStage {
    /// Stage C then a fresh stage D: the scene prior's Gaussians (SH degree `sh_degree`), the
    /// scan avatar carried onto the acting prior, π and σ₀.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        capture: &Prior4dCapture,
        model: &BodyModel,
        config: &Prior4dConfig,
        scene: &Splats,
        scene_extent: f64,
        sh_degree: u32,
        scan_avatar: &SkinnedGaussianNode,
        device: &Device,
    ) -> Result<Self, Prior4dError> {
        let j = &config.joint;
        let set = splatzoo_train::gaussians::GaussianSet::from_splats(scene);
        let rates = if j.free_scene {
            config.scene.rates
        } else {
            j.rates.scene
        };
        let scene_node = GaussianNode::new(
            JOINT_SCENE,
            set,
            rates,
            &DensifyConfig {
                strategy: Strategy::None,
                ..DensifyConfig::default()
            },
            scene_extent,
            config.seed ^ 0xD0D0_0002,
        );
        let mut avatar = acting_avatar(capture, model, config, device)?;
        let mut carried = Checkpoint::default();
        scan_avatar.save(&mut carried, "scan");
        avatar
            .load_avatar(&carried, "scan", device)
            .map_err(|e| Prior4dError::Train(e.into()))?;
        let (prior_colours, prior_log_radii) = canonical_appearance(&avatar);
        let feet = foot_vertices(model);
        let (fit, candidates) = fit_floor(scene, capture, &config.plane, scene_extent)?;
        let sigma0 = if j.sigma_from_plane {
            let canonical = avatar.canonical_set().splats();
            let per_frame: Vec<Vec<[f64; 3]>> = (0..capture.acting.len())
                .map(|t| {
                    let means = host_f32(&avatar.posed(canonical.clone(), t).splats.means);
                    feet.iter()
                        .map(|&k| [0, 1, 2].map(|c| f64::from(means[3 * k + c])))
                        .collect()
                })
                .collect();
            sigma_from_plane(&fit.plane, capture, &per_frame, j.contact_rule.count)?
        } else {
            j.initial_sigma
        } * j.sigma_scale;
        let frames = capture.acting.len();
        // Its own seed, so the network does not depend on what drew from the device before.
        device.seed(config.seed ^ 0xD0D0_0004 ^ j.seed);
        let offsets = PoseOffsetNet::new(&j.offset_network, model.joint_count(), device).train();
        let log_sigma = Tensor::<1>::from_floats([sigma0.ln() as f32], device);
        let zeros = Tensor::<2>::zeros([frames, 3], device);
        let mut stage = Self {
            scene: scene_node,
            avatar,
            offsets,
            offsets_adam: ModuleAdam::new(NETWORK_ADAM),
            sigma_adam: AdamState::new(&log_sigma),
            log_sigma,
            rotation_adam: AdamState::new(&zeros),
            translation_adam: AdamState::new(&zeros),
            camera_rotation: zeros.clone(),
            camera_translation: zeros,
            init: Initialisation {
                fit,
                candidates,
                sigma0,
            },
            order: EpochOrder::new(config.seed ^ 0xD0D0_0003 ^ j.seed.wrapping_mul(0x9E37_79B9)),
            trained: capture.trained_indices(),
            extent: scene_extent,
            sh_degree,
            prior_colours,
            prior_log_radii,
            feet,
            faces: model.faces.clone(),
            seed: config.seed ^ j.seed.wrapping_mul(0x85EB_CA6B),
        };
        stage.attach_offsets(config, false);
        Ok(stage)
    }

    pub fn plane(&self) -> &Plane {
        &self.init.fit.plane
    }

    pub fn sigma(&self) -> f64 {
        f64::from(host_f32(&self.log_sigma)[0]).exp()
    }

    /// Hands the offset network's current parameters to the avatar node: the autodiff ones for
    /// a training step, plain ones otherwise (a forward pass on autodiff parameters that no
    /// backward pass consumes would keep its graph alive).
    pub fn attach_offsets(&mut self, config: &Prior4dConfig, training: bool) {
        let field = config.joint.pose_offsets.then(|| {
            Box::new(PoseOffsets {
                net: if training {
                    self.offsets.clone()
                } else {
                    self.offsets.valid()
                },
                levels: config.joint.offset_network.position_levels,
            }) as Box<dyn splatzoo_train::scene::skinned::NonRigidField>
        });
        self.avatar.set_non_rigid(field);
    }

    /// Acting camera `t` in the scene frame, refined when `refine` (autodiff tables inside a
    /// step are passed in `tables`).
    pub fn acting_view(
        &self,
        capture: &Prior4dCapture,
        t: usize,
        refine: bool,
        tables: Option<(&Tensor<2>, &Tensor<2>)>,
    ) -> RigidFrame {
        let (rotation, translation) =
            tables.unwrap_or((&self.camera_rotation, &self.camera_translation));
        let device = rotation.device();
        let frame = RigidFrame::of_camera(&capture.acting[t].camera, &device);
        if !refine {
            return frame;
        }
        let row = |table: &Tensor<2>| table.clone().slice([t..t + 1, 0..3]).reshape([3]);
        frame.refined(row(rotation), row(translation) * self.extent)
    }

    /// The avatar at acting frame `t` placed in the scene through `view` with `log_sigma`.
    pub fn placed_avatar(
        &self,
        capture: &Prior4dCapture,
        t: usize,
        view: &RigidFrame,
        log_sigma: Tensor<1>,
    ) -> AvatarSplats {
        let posed = posed_avatar(&self.avatar, t, &capture.acting[t].camera, &self.faces);
        AvatarSplats {
            splats: place(posed.splats, log_sigma, view),
            normals: view.rotate_to_world(posed.normals),
        }
    }

    /// The scene's splats now (the step's leaves inside a step).
    pub fn scene_splats(&self, capture: &Prior4dCapture) -> Splats {
        let camera = capture.acting[0].camera;
        let query = FrameQuery {
            camera: &camera,
            frame: 0,
            time: 0.0,
        };
        self.scene
            .render(&query, &FrameContext { outputs: &[] })
            .splats
    }

    /// Renders scene and/or avatar from `view` with `intrinsics`' camera model.
    pub fn layers(
        &self,
        scene: Option<&Splats>,
        avatar: Option<&AvatarSplats>,
        view: &RigidFrame,
        intrinsics: &splatzoo_rasterizer::Camera,
        background: [f32; 3],
    ) -> Result<Layers, Prior4dError> {
        let scene = scene.map(|splats| SceneSplats {
            splats,
            degree: self.sh_degree,
        });
        let settings = RasterSettings::new(*intrinsics, ColorMode::Features);
        render_layers(scene.as_ref(), avatar, view, &settings, background)
            .map_err(|e| Prior4dError::Train(e.into()))
    }

    /// One optimiser step at stage-D step `step` of `steps`.
    pub fn step(
        &mut self,
        capture: &Prior4dCapture,
        config: &Prior4dConfig,
        step: usize,
        steps: usize,
    ) -> Result<JointTerms, Prior4dError> {
        let j = &config.joint;
        let t = self.trained[self.order.next(self.trained.len())];
        let frame = &capture.acting[t];
        self.attach_offsets(config, true);
        self.scene.begin_step();
        self.avatar.begin_step();
        let device = self.log_sigma.device().autodiff();
        let s = self.log_sigma.clone().autodiff().require_grad();
        let rotation = self.camera_rotation.clone().autodiff().require_grad();
        let translation = self.camera_translation.clone().autodiff().require_grad();
        let view = self.acting_view(
            capture,
            t,
            j.refines_cameras(),
            Some((&rotation, &translation)),
        );
        let avatar = self.placed_avatar(capture, t, &view, s.clone());
        let scene = self.scene_splats(capture);
        let background = capture.scene_background;
        let layers = self.layers(
            Some(&scene),
            Some(&avatar),
            &view,
            &frame.camera,
            background,
        )?;
        let image = frame.image.clone().autodiff();
        let mask = frame.mask.clone().autodiff();
        let photometric = |rendered: Tensor<3>, target: Tensor<3>| {
            l1(rendered.clone(), target.clone()) * j.l1
                + (ssim(rendered, target) - 1.0) * (-j.dssim)
        };
        let mut photo = photometric(layers.color.clone(), image.clone());
        if j.human_term {
            let b = random_background(self.seed ^ 0xD0D0, step);
            let human = self.layers(None, Some(&avatar), &view, &frame.camera, b)?;
            photo =
                photo + photometric(human.color, over_background(image.clone(), mask.clone(), b));
        }
        if j.scene_term {
            let alone = self.layers(Some(&scene), None, &view, &frame.camera, background)?;
            let off = mask.clone().neg().add_scalar(1.0);
            photo = photo
                + masked_l1(alone.color.clone(), image.clone(), off.clone()) * j.l1
                + (masked_ssim(alone.color, image, off) - 1.0) * (-j.dssim);
        }
        let mut terms = JointTerms {
            photo: scalar(photo.clone().inner()),
            ..JointTerms::default()
        };
        let mut loss = photo;
        if let (true, Some(given)) = (j.normal > 0.0, &frame.normals) {
            let normal = normal_loss(layers.normal.clone(), given.clone().autodiff(), mask);
            terms.normal = scalar(normal.clone().inner());
            loss = loss + normal * j.normal;
        }
        if j.contact > 0.0 {
            // E^t detached: the cameras answer to the scene's pixels only.
            let detached = RigidFrame {
                rotation: view.rotation.clone().detach(),
                centre: view.centre.clone().detach(),
            };
            let posed = posed_avatar(&self.avatar, t, &frame.camera, &self.faces);
            let idx: Vec<i64> = self.feet.iter().map(|&k| k as i64).collect();
            let idx = Tensor::<1, Int>::from_data(TensorData::new(idx, [self.feet.len()]), &device);
            let feet_cam = posed.splats.means.select(0, idx);
            let sigma = s.clone().exp().reshape([1, 1]);
            let feet = detached.to_world(feet_cam * sigma);
            let contact = contact_loss(feet, self.plane(), &j.contact_rule, self.sigma())?.loss;
            terms.contact = scalar(contact.clone().inner());
            loss = loss + contact * j.contact;
        }
        if j.huber > 0.0 {
            let (colours, log_radii) = canonical_appearance(&self.avatar);
            let huber = huber_prior(
                colours,
                self.prior_colours.clone().autodiff(),
                log_radii,
                self.prior_log_radii.clone().autodiff(),
                &j.huber_deltas,
            );
            terms.huber = scalar(huber.clone().inner());
            loss = loss + huber * j.huber;
        }
        for r in [self.avatar.regulariser(), self.scene.regulariser()]
            .into_iter()
            .flatten()
        {
            loss = loss + r;
        }
        let grads = loss.backward();
        let scene_rows = 0..self.scene.gaussians();
        let avatar_rows = scene_rows.end..scene_rows.end + self.avatar.gaussians();
        let progress = step as f64 / steps.max(1) as f64;
        self.scene.end_step(&StepEnd {
            grads: &grads,
            renders: vec![(&layers.render, scene_rows)],
            step,
            progress,
        });
        self.avatar.end_step(&StepEnd {
            grads: &grads,
            renders: vec![(&layers.render, avatar_rows)],
            step,
            progress,
        });
        let rates = &j.rates;
        if let Some(g) = s.grad(&grads) {
            self.log_sigma =
                self.sigma_adam
                    .step(self.log_sigma.clone(), g, rates.log_scale, &TABLE_ADAM);
        }
        if j.refines_cameras() {
            if let Some(g) = rotation.grad(&grads) {
                self.camera_rotation = self.rotation_adam.step(
                    self.camera_rotation.clone(),
                    g,
                    rates.camera_rotation,
                    &TABLE_ADAM,
                );
            }
            if let Some(g) = translation.grad(&grads) {
                self.camera_translation = self.translation_adam.step(
                    self.camera_translation.clone(),
                    g,
                    rates.camera_translation,
                    &TABLE_ADAM,
                );
            }
        }
        if j.pose_offsets {
            self.offsets = self
                .offsets_adam
                .step(self.offsets.clone(), &grads, rates.offsets);
        }
        self.attach_offsets(config, false);
        Ok(terms)
    }
}
