//! `train-apf`'s trainer (the [`splatzoo_train::harness::Method`] is in `method.rs`): the scene
//! graph of a driving capture trained view by view with Eq. 6's objective; stage S1 (LBS with
//! pose refinement) for `warmup` steps, then S2 (the residual field, the gate and the accessory
//! network). Its whole state (every node with its
//! optimiser and density statistics, the networks and their Adam moments, the view order) is
//! one checkpoint, so a resumed run continues bit for bit on the CPU.

use crate::config::ApfConfig;
use crate::data::ApfCapture;
use crate::error::ApfError;
use crate::guide::guide;
use crate::loss::{TermWeights, sparse_depth_l1, weighted_bce};
use crate::networks::ApfNetworks;
use crate::scene::{ApfScene, Composed, FrameInputs, Guided, Stage};
use burn::module::Module;
use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_datasets::masks::Mask;
use splatzoo_models::body::{BodyModel, builtin_body};
use splatzoo_rasterizer::{Camera, ColorMode, RasterSettings, Render, Splats, rasterize};
use splatzoo_train::TrainError;
use splatzoo_train::harness::{EpochOrder, MethodConfig, StepReport};
use splatzoo_train::loss::{photometric, scalar};
use splatzoo_train::module_adam::{ModuleAdam, NETWORK_ADAM};
use splatzoo_train::scene::StepEnd;

/// `train-apf`'s shorthands.
#[derive(clap::Args, Debug)]
pub struct ApfArgs {
    /// Table II's "w/o decoupling" (shorthand for `--set decouple.enabled=false`).
    #[arg(long)]
    pub no_decoupling: bool,
    /// Fix σ (Table II: 1 is the strong prior, 0 the weak prior).
    #[arg(long)]
    pub fixed_sigma: Option<f64>,
    /// A drivestudio processed-Waymo scene folder instead of the synthetic driving preset
    /// (shorthand for `--set data.path=…`).
    #[arg(long)]
    pub data: Option<std::path::PathBuf>,
}

/// One Adam per network, each with its own learning rate.
pub struct NetworkOptimizers {
    pub encoder: ModuleAdam,
    pub guidance: ModuleAdam,
    pub residual: ModuleAdam,
    pub accessory: ModuleAdam,
    pub embeddings: ModuleAdam,
}

impl NetworkOptimizers {
    pub fn new() -> Self {
        Self {
            encoder: ModuleAdam::new(NETWORK_ADAM),
            guidance: ModuleAdam::new(NETWORK_ADAM),
            residual: ModuleAdam::new(NETWORK_ADAM),
            accessory: ModuleAdam::new(NETWORK_ADAM),
            embeddings: ModuleAdam::new(NETWORK_ADAM),
        }
    }
}

impl Default for NetworkOptimizers {
    fn default() -> Self {
        Self::new()
    }
}

pub struct ApfTrainer {
    pub config: ApfConfig,
    pub capture: ApfCapture,
    pub scene: ApfScene,
    pub model: BodyModel,
    /// The networks, trainable (autodiff parameters).
    pub nets: ApfNetworks,
    pub optimizers: NetworkOptimizers,
    pub step: usize,
    pub(crate) order: EpochOrder,
    pub(crate) background: Tensor<1>,
    /// The kinematic meshes of the last `M_kine` refresh ([`crate::refresh`]).
    pub(crate) refreshed: Option<crate::refresh::PeopleMeshes>,
}

/// The node-alpha pass's targets for one view: human and accessory targets and the pixel
/// weights (inside the people's boxes, outside the band around `M_kine`'s edge).
struct MaskTargets {
    human: Mask,
    accessory: Mask,
    weight: Mask,
}

impl ApfTrainer {
    pub fn duration(&self) -> f64 {
        self.capture.frames as f64 / self.capture.fps
    }

    /// What is switched on at `step` (S1 before `warmup`, S2 after).
    pub fn stage(&self, step: usize) -> Stage {
        let s2 = step >= self.config.warmup;
        Stage {
            residual: s2 && self.config.residual.enabled,
            deform: s2 && self.config.attach.deform,
        }
    }

    pub fn sh_degree(&self) -> u32 {
        let every = self.config.sh_degree_every.max(1);
        ((self.step / every) as u32).min(self.config.sh_degree)
    }

    pub(crate) fn raster(
        &self,
        splats: &Splats,
        camera: Camera,
        features: bool,
        in_step: bool,
    ) -> Result<Render, TrainError> {
        let (color, background) = if features {
            let [n, _, c] = splats.colors.dims();
            debug_assert_eq!(n, splats.len());
            (
                ColorMode::Features,
                Tensor::<1>::zeros([c], &self.background.device()),
            )
        } else {
            (
                ColorMode::Sh {
                    degree: self.sh_degree(),
                },
                self.background.clone(),
            )
        };
        let background = if in_step {
            background.autodiff()
        } else {
            background
        };
        Ok(rasterize(
            splats,
            background,
            &RasterSettings::new(camera, color),
        )?)
    }

    /// `splats` coloured by node type: channel 0 on human rows, 1 on accessory rows.
    pub(crate) fn node_features(composed: &Composed) -> Splats {
        let n = composed.splats.len();
        let mut values = vec![0.0f32; 2 * n];
        for i in composed.human_rows.clone() {
            values[2 * i] = 1.0;
        }
        for i in composed.accessory_rows.clone() {
            values[2 * i + 1] = 1.0;
        }
        let device = composed.splats.means.device();
        let mut colors = Tensor::<3>::from_data(TensorData::new(values, [n, 1, 2]), &device);
        if composed.splats.means.is_autodiff() {
            colors = colors.autodiff();
        }
        Splats {
            colors,
            ..composed.splats.clone()
        }
    }

    /// The guidance output of every person visible in `view` when the residual is on.
    pub(crate) fn guided(
        &self,
        nets: &ApfNetworks,
        frame: usize,
        visible: &[bool],
        stage: Stage,
    ) -> Vec<Option<Guided>> {
        visible
            .iter()
            .enumerate()
            .map(|(h, &v)| {
                (stage.residual && v).then(|| guide(nets, &self.capture, &self.config, h, frame))
            })
            .collect()
    }

    fn mask_targets(&self, view: usize) -> MaskTargets {
        let v = &self.capture.views[view];
        let (w, h) = (v.coarse.width, v.coarse.height);
        let mut human = Mask::empty(w, h);
        let mut accessory = Mask::empty(w, h);
        let mut region = Mask::empty(w, h);
        let with_accessory: Vec<usize> = self.scene.accessories.iter().map(|a| a.person).collect();
        for (p, masks) in v.people.iter().enumerate() {
            if !masks.visible() {
                continue;
            }
            human = human.or(if self.config.decouple.enabled {
                &masks.kine
            } else {
                &masks.coarse
            });
            if with_accessory.contains(&p) {
                accessory = accessory.or(&masks.accessory);
            }
            if let Some(r) = masks.rectangle {
                let mut data = vec![false; w * h];
                for y in r[1]..r[3] {
                    for x in r[0]..r[2] {
                        data[y * w + x] = true;
                    }
                }
                region = region.or(&Mask::new(w, h, data));
            }
        }
        let band = human.dilate(2).minus(&human.erode(2));
        MaskTargets {
            weight: region.minus(&band),
            human,
            accessory,
        }
    }

    /// One optimiser step on the next training view.
    pub fn train_step(&mut self) -> Result<StepReport, ApfError> {
        self.refresh_if_due()?;
        let stage = self.stage(self.step);
        let index = self.capture.train[self.order.next(self.capture.train.len())];
        self.scene.begin_step();
        let view = &self.capture.views[index];
        let visible: Vec<bool> = view.people.iter().map(|m| m.visible()).collect();
        let guided = self.guided(&self.nets, view.frame, &visible, stage);
        let composed = self.scene.compose(
            &FrameInputs {
                camera: &view.camera,
                frame: view.frame,
                time: view.frame as f64 / self.capture.fps,
                guided: &guided,
                nets: &self.nets,
                stage,
                duration: self.duration(),
                in_step: true,
            },
            &self.config,
        );
        let render = self.raster(&composed.splats, view.camera, false, true)?;
        let photo = photometric(
            render.color.clone(),
            view.image.clone().autodiff(),
            self.config.loss.lambda_dssim,
        );
        let mut loss = photo.clone();
        let device = self.background.device();
        let image = |m: &Mask| crate::eval::mask_tensor(m, &device).autodiff();
        if self.config.loss.mask > 0.0 && visible.iter().any(|&v| v) {
            let targets = self.mask_targets(index);
            if targets.weight.area() > 0 {
                let features =
                    self.raster(&Self::node_features(&composed), view.camera, true, true)?;
                let [hh, ww, _] = features.color.dims();
                let alpha = |c: usize| {
                    features
                        .color
                        .clone()
                        .slice([0..hh, 0..ww, c..c + 1])
                        .reshape([hh, ww])
                };
                let weight = image(&targets.weight);
                let mut mask = weighted_bce(alpha(0), image(&targets.human), weight.clone());
                if !self.scene.accessories.is_empty() {
                    mask = mask + weighted_bce(alpha(1), image(&targets.accessory), weight);
                }
                loss = loss + mask * self.config.loss.mask;
            }
        }
        if self.config.loss.depth > 0.0
            && let Some(lidar) = &view.lidar
        {
            let [hh, ww] = render.depth.dims();
            let valid: Vec<f32> = lidar.iter().map(|d| f32::from(d.is_finite())).collect();
            let target: Vec<f32> = lidar
                .iter()
                .map(|d| if d.is_finite() { *d } else { 0.0 })
                .collect();
            let valid =
                Tensor::<2>::from_data(TensorData::new(valid, [hh, ww]), &device).autodiff();
            let target =
                Tensor::<2>::from_data(TensorData::new(target, [hh, ww]), &device).autodiff();
            loss = loss
                + sparse_depth_l1(render.depth.clone(), render.alpha.clone(), target, valid)
                    * self.config.loss.depth;
        }
        let weights = TermWeights {
            sparse: self.config.loss.sparse,
            kine: self.config.loss.kine,
            bone: self.config.loss.bone,
            limit: self.config.loss.limit,
            sigma_reads_limit: self.config.loss.sigma_reads_limit,
            sigma_prior: self.config.loss.sigma_prior,
            sigma_start: self.config.network.initial_sigma,
        };
        for (_, terms) in &composed.terms {
            loss = loss + terms.total(&weights);
        }
        for node in self.scene.nodes() {
            if let Some(r) = node.regulariser() {
                loss = loss + r;
            }
        }
        let value = scalar(loss.clone().inner());
        if !value.is_finite() {
            return Err(TrainError::NonFinite {
                step: self.step + 1,
                value,
            }
            .into());
        }
        let grads = loss.backward();
        let progress = self.step as f64 / self.config.iterations as f64;
        let step = self.step;
        let rows = composed.rows.clone();
        let mut notes = Vec::new();
        for (k, node) in self.scene.nodes_mut().into_iter().enumerate() {
            let end = StepEnd {
                grads: &grads,
                renders: vec![(&render, rows[k].clone())],
                step,
                progress,
            };
            if let Some(report) = node.end_step(&end) {
                notes.push(format!("{} {report:?}", node.name()));
            }
        }
        let decay = 0.1f64.powf(progress);
        let r = &self.config.network_rates;
        let nets = &mut self.nets;
        let opt = &mut self.optimizers;
        nets.encoder = opt
            .encoder
            .step(nets.encoder.clone(), &grads, r.encoder * decay);
        nets.guidance = opt
            .guidance
            .step(nets.guidance.clone(), &grads, r.guidance * decay);
        nets.residual = opt
            .residual
            .step(nets.residual.clone(), &grads, r.residual * decay);
        nets.accessory = opt
            .accessory
            .step(nets.accessory.clone(), &grads, r.accessory * decay);
        nets.embeddings =
            opt.embeddings
                .step(nets.embeddings.clone(), &grads, r.embeddings * decay);
        self.step += 1;
        Ok(StepReport {
            loss: scalar(photo.inner()),
            note: (!notes.is_empty()).then(|| notes.join("; ")),
        })
    }

    /// Builds the capture, the scene graph and fresh networks.
    pub fn assemble(config: ApfConfig, device: &Device) -> Result<Self, ApfError> {
        config.validate()?;
        device.seed(config.seed);
        let model = builtin_body().model.clone();
        let capture: ApfCapture =
            config
                .data
                .build(&config.decouple, config.network.crop, device)?;
        let scene = ApfScene::build(&config, &capture, &model, device)?;
        let nets = ApfNetworks::new(
            &config.network,
            config.gate.residual_columns(),
            capture.people.len(),
            scene.accessories.len(),
            device,
        )
        .train();
        let background = Tensor::<1>::from_floats(capture.background.as_slice(), device);
        Ok(Self {
            order: EpochOrder::new(config.seed ^ 0xA9F_0000),
            config,
            capture,
            scene,
            model,
            nets,
            optimizers: NetworkOptimizers::new(),
            step: 0,
            background,
            refreshed: None,
        })
    }
}
