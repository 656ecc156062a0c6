//! Illum's training state (§3): the static scene node, the stage-1 refined body, the stage-2
//! PBR human, the light volume with its shadow decoder, F_m and F_vis, each with its own
//! optimiser; how they are built from the capture and handed from stage 1 to stage 2. The steps
//! themselves are in [`crate::steps`].
//!
//! - The scene: an INRIA 3DGS node ([`GaussianNode`]) from the capture's back-projected points,
//!   with ADC.
//! - The light volume covers every training pose of the person (the union of their posed
//!   bounds), padded by `light.pad` body heights, probes `light.spacing` body heights apart,
//!   at most `light.max_per_axis` per axis.
//! - The stage-2 human is a [`GaussianNode`] of its own in canonical space: its colour slot
//!   holds the linear albedo `b` (or, without the light volume, the display colour), its
//!   position rate is per metre of body height, and its density control is ADC; after every
//!   edit its skinning weights and [`KnnTransfer`] are rebuilt from the `stage2.knn` nearest
//!   refined canonical vertices (the spec's KNN re-binding).

use crate::IllumError;
use crate::config::{IllumConfig, PoseTrack};
use crate::data::IllumCapture;
use crate::human::{BodyMesh, RefinedBody};
use crate::light_volume::{LightVolume, ProbeGrid};
use crate::lighting::KnnTransfer;
use crate::needs::shadow_decoder;
use crate::shadow::ShadowDecoder;
use crate::stage2::{Binding, PbrHuman};
use crate::visibility::VisibilityNet;
use burn::module::Module;
use burn::tensor::{Device, Int, Tensor, TensorData};
use splatzoo_datasets::pose_sequence::PoseSequence;
use splatzoo_models::body::lbs::pose;
use splatzoo_models::body::{BodyTensors, PoseInput, Posed, builtin_body};
use splatzoo_models::closest_face::FaceIndex;
use splatzoo_models::knn::PointIndex;
use splatzoo_models::laplacian::UniformLaplacian;
use splatzoo_models::networks::hash_grid::HashQueries;
use splatzoo_models::networks::hash_mlp::HashMlp;
use splatzoo_models::networks::initialised;
use splatzoo_train::adam::{AdamConfig, AdamState};
use splatzoo_train::densify::kl::{KlDensity, SurfacePrune};
use splatzoo_train::densify::{DensityStats, Strategy};
use splatzoo_train::gaussians::{GaussianSet, SH_REST};
use splatzoo_train::harness::{EpochOrder, ModuleChoice};
use splatzoo_train::host_f32;
use splatzoo_train::module_adam::{ModuleAdam, NETWORK_ADAM};
use splatzoo_train::scene::GaussianNode;
use splatzoo_train::scene::skinned::JointTransforms;
use splatzoo_train::views::camera_extent;

/// Checkpoint prefixes of the two Gaussian nodes.
pub const SCENE: &str = "scene";
pub const HUMAN: &str = "human";

/// One frame's body: posed by the frame's parameters, with its joint transforms and its
/// F_vis pose vector (axis-angle, global orientation zeroed).
pub struct FramePose {
    pub posed: Posed,
    pub transforms: JointTransforms,
    /// `[3, 3]` world rotation of the root (turns world directions into the root frame).
    pub root: Tensor<2>,
    pub pose_vector: Tensor<1>,
}

/// Stage 2's human and the networks that shade it.
pub struct Stage2State {
    pub human: GaussianNode,
    pub binding: Binding,
    /// F_Δ's offsets `[V, 3]` (plain) and the refined canonical vertices: F_Δ is frozen in
    /// stage 2, so both are computed once at the hand-over instead of every step.
    pub offsets: Tensor<2>,
    pub canonical: Vec<[f32; 3]>,
}

pub struct IllumTrainer {
    pub config: IllumConfig,
    pub capture: IllumCapture,
    /// The plain device (data, nodes between steps) and its autodiff twin (networks).
    pub device: Device,
    pub autodiff: Device,
    pub mesh: BodyMesh,
    pub laplacian: UniformLaplacian,
    tensors: BodyTensors,
    tensors_autodiff: BodyTensors,
    /// The frames trained on (indices into `capture.frames`).
    pub train: Vec<usize>,
    pub scene: GaussianNode,
    /// `[M, K]` each scene Gaussian's nearest scene Gaussians (L_shadows), rebuilt after the
    /// scene's density edits.
    pub scene_neighbours: Tensor<2, Int>,
    pub body: RefinedBody,
    pub body_queries: HashQueries,
    pub offset_adam: ModuleAdam,
    pub colour_adam: ModuleAdam,
    pub in_plane_adam: AdamState<2>,
    pub volume: LightVolume,
    pub sh_adam: AdamState<3>,
    pub environment_adam: AdamState<2>,
    pub latent_adam: AdamState<2>,
    pub decoder: ShadowDecoder,
    pub decoder_adam: ModuleAdam,
    pub visibility: VisibilityNet,
    pub visibility_adam: ModuleAdam,
    /// F_m on the template vertices' fixed queries (built with the other networks, so a run
    /// resumed before the hand-over draws the same initial weights).
    pub materials: HashMlp,
    pub material_queries: HashQueries,
    pub materials_adam: ModuleAdam,
    pub stage2: Option<Stage2State>,
    pub order: EpochOrder,
    pub step: usize,
    /// Whether the capture called for the shadow decoder, and why ([`crate::needs`]); the
    /// decision is also in `config.ablation.shadow`.
    pub shadow_choice: ModuleChoice,
}

/// `[M, K]` nearest neighbours (self excluded) of every point, as Burn indices.
pub fn neighbour_table(positions: &Tensor<2>, k: usize) -> Tensor<2, Int> {
    let host = host_f32(positions);
    let points: Vec<[f32; 3]> = host.chunks(3).map(|p| [p[0], p[1], p[2]]).collect();
    let m = points.len();
    let index = PointIndex::new(&points);
    let mut rows = Vec::with_capacity(m * k);
    for (i, p) in points.iter().enumerate() {
        let near = index.k_nearest(*p, k, Some(i));
        for slot in 0..k {
            // Fewer neighbours than k: pad with the point itself (its pair costs nothing).
            rows.push(near.get(slot).map_or(i, |&(j, _)| j) as i64);
        }
    }
    Tensor::<2, Int>::from_data(TensorData::new(rows, [m, k]), &positions.device())
}

fn as_points(host: &[f32]) -> Vec<[f32; 3]> {
    host.chunks(3).map(|p| [p[0], p[1], p[2]]).collect()
}

impl IllumTrainer {
    /// The body track the config names: the true motion where the capture knows it and
    /// `poses = "true"`, else the capture's prior track (a capture on disk has only its own).
    pub fn track(&self) -> &PoseSequence {
        match (self.config.poses, &self.capture.truth) {
            (PoseTrack::True, Some(truth)) => truth.motion(),
            _ => &self.capture.prior,
        }
    }

    pub fn new(config: IllumConfig, device: &Device) -> Result<Self, IllumError> {
        device.seed(config.seed);
        let capture = config.data.build(device)?;
        Self::from_capture(config, capture, device)
    }

    /// A fresh trainer on a capture already built from `config.data` (benches and ablations
    /// share one); the networks' initial weights depend only on `config.seed`.
    pub fn from_capture(
        mut config: IllumConfig,
        capture: IllumCapture,
        device: &Device,
    ) -> Result<Self, IllumError> {
        if capture.config != config.data {
            return Err(IllumError::input(
                "capture",
                "built from another data configuration than the run's `data`",
            ));
        }
        let shadow_choice = shadow_decoder(config.ablation.shadow, &capture);
        config.ablation.shadow = Some(shadow_choice.enabled);
        device.seed(config.seed ^ 0x111_0000);
        let autodiff = device.clone().autodiff();
        let mesh = BodyMesh::new(&builtin_body().model, config.stage1.body.subdivisions)?;
        let laplacian = UniformLaplacian::new(mesh.vertex_count(), &mesh.model.faces);
        let tensors = BodyTensors::new(&mesh.model, device);
        let tensors_autodiff = BodyTensors::new(&mesh.model, &autodiff);
        let train: Vec<usize> = (0..capture.frames.len())
            .filter(|&k| !capture.frames[k].held_out)
            .collect();
        if train.is_empty() {
            return Err(IllumError::input("capture", "no training frames"));
        }
        let points = &capture.scene_points;
        if points.is_empty() {
            return Err(IllumError::input(
                "capture",
                "no scene points to start the scene from",
            ));
        }
        let cameras: Vec<_> = train.iter().map(|&k| capture.frames[k].camera).collect();
        let extent = camera_extent(&cameras).max(1e-3);
        let set =
            GaussianSet::from_points(&points.positions, &points.colours, &points.sigmas, device);
        let scene = GaussianNode::new(
            SCENE,
            set,
            config.scene.rates,
            &config.scene.densify,
            extent,
            config.seed ^ 0x111_0001,
        );
        let scene_neighbours = neighbour_table(
            &scene.set.means.clone().autodiff(),
            config.light.shadow_neighbours,
        );
        let body = initialised(RefinedBody::new(
            &mesh,
            &config.stage1.body,
            config.seed ^ 0x111_0002,
            &autodiff,
        ));
        let body_queries = mesh.queries(&body.offset, &autodiff);
        let in_plane_adam = AdamState::new(&body.in_plane.val().inner());
        let decoder = initialised(ShadowDecoder::new(config.light.latent_dim, &autodiff));
        let visibility = initialised(VisibilityNet::new(
            config.visibility.net,
            3 * mesh.model.joint_count(),
            &autodiff,
        ));
        let materials = initialised(HashMlp::new(
            config.stage2.materials,
            2,
            false,
            config.seed ^ 0x111_0006,
            &autodiff,
        ));
        let material_queries = mesh.queries(&materials, &autodiff);

        let mut trainer = Self {
            scene,
            scene_neighbours,
            in_plane_adam,
            body,
            body_queries,
            offset_adam: ModuleAdam::new(NETWORK_ADAM),
            colour_adam: ModuleAdam::new(NETWORK_ADAM),
            // Placeholders replaced below once the poses are known.
            volume: LightVolume::new(
                ProbeGrid {
                    origin: [0.0; 3],
                    spacing: 1.0,
                    dims: [1, 1, 1],
                },
                config.light.degree,
                config.light.latent_dim,
                config.seed,
                &autodiff,
            )?,
            sh_adam: AdamState::new(&Tensor::<3>::zeros([1, 1, 3], device)),
            environment_adam: AdamState::new(&Tensor::<2>::zeros([1, 3], device)),
            latent_adam: AdamState::new(&Tensor::<2>::zeros([1, 1], device)),
            decoder,
            decoder_adam: ModuleAdam::new(NETWORK_ADAM),
            visibility,
            visibility_adam: ModuleAdam::new(NETWORK_ADAM),
            materials,
            material_queries,
            materials_adam: ModuleAdam::new(NETWORK_ADAM),
            stage2: None,
            order: EpochOrder::new(config.seed ^ 0x111_0003),
            step: 0,
            shadow_choice,
            train,
            mesh,
            laplacian,
            tensors,
            tensors_autodiff,
            capture,
            device: device.clone(),
            autodiff: autodiff.clone(),
            config,
        };
        let grid = trainer.probe_grid()?;
        trainer.volume = LightVolume::new(
            grid,
            trainer.config.light.degree,
            trainer.config.light.latent_dim,
            trainer.config.seed ^ 0x111_0004,
            &autodiff,
        )?;
        if trainer.config.light.shared_environment {
            trainer.volume = trainer.volume.split_environment().train();
        }
        trainer.sh_adam = AdamState::new(&trainer.volume.sh.val().inner());
        trainer.environment_adam = AdamState::new(&trainer.volume.environment.val().inner());
        trainer.latent_adam = AdamState::new(&trainer.volume.latent.val().inner());
        if !trainer.config.ablation.two_stage {
            trainer.stage2 = Some(trainer.hand_over());
        }
        Ok(trainer)
    }

    /// The probe grid over every training pose's bounds, padded.
    fn probe_grid(&self) -> Result<ProbeGrid, IllumError> {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for &k in &self.train {
            let frame = self.capture.frames[k].frame;
            let posed = self.frame_pose(frame, false).posed;
            for p in host_f32(&posed.vertices).chunks(3) {
                for a in 0..3 {
                    lo[a] = lo[a].min(f64::from(p[a]));
                    hi[a] = hi[a].max(f64::from(p[a]));
                }
            }
        }
        let h = self.mesh.height;
        ProbeGrid::covering(
            lo,
            hi,
            self.config.light.pad * h,
            self.config.light.spacing * h,
            self.config.light.max_per_axis,
        )
    }

    /// The body of frame `frame` of the configured track (on the autodiff device or not).
    pub fn frame_pose(&self, frame: usize, autodiff: bool) -> FramePose {
        self.pose_of(self.track(), frame, autodiff)
    }

    /// The body of frame `frame` of `track`.
    pub fn pose_of(&self, track: &PoseSequence, frame: usize, autodiff: bool) -> FramePose {
        let (tensors, device) = if autodiff {
            (&self.tensors_autodiff, &self.autodiff)
        } else {
            (&self.tensors, &self.device)
        };
        let f32s = |v: &[f64]| v.iter().map(|&x| x as f32).collect::<Vec<_>>();
        let axis_angles = track.pose(frame);
        let betas = track.frame_betas(frame);
        let j = self.mesh.model.joint_count();
        let s = betas.len().min(self.mesh.model.shape_count());
        let posed = pose(
            tensors,
            &PoseInput::from_axis_angle(
                Tensor::<2>::from_data(TensorData::new(f32s(&betas[..s]), [1, s]), device),
                Tensor::<2>::from_data(
                    TensorData::new(f32s(axis_angles), [1, axis_angles.len()]),
                    device,
                ),
                Tensor::<2>::from_data(
                    TensorData::new(f32s(&track.translation(frame)), [1, 3]),
                    device,
                ),
            ),
        );
        let transforms = JointTransforms {
            rotations: posed.joint_rotations.clone().reshape([j, 3, 3]),
            translations: posed.skinning_translations.clone().reshape([j, 3]),
        };
        let root = posed
            .joint_rotations
            .clone()
            .slice([0..1, 0..1, 0..3, 0..3])
            .reshape([3, 3]);
        let mut vector = f32s(axis_angles);
        vector[..3].fill(0.0);
        let width = vector.len();
        FramePose {
            root,
            transforms,
            pose_vector: Tensor::<1>::from_data(TensorData::new(vector, [width]), device),
            posed,
        }
    }

    /// F_Δ's offsets `[V, 3]` now, without autodiff.
    pub fn frozen_offsets(&self) -> Tensor<2> {
        self.body
            .clone()
            .no_grad()
            .offsets(&self.body_queries)
            .inner()
    }

    /// The refined canonical vertices (the shaped rest body of frame 0 plus F_Δ), host.
    pub fn canonical_vertices(&self) -> Vec<[f32; 3]> {
        let v = self.mesh.vertex_count();
        let first = self.capture.frames[self.train[0]].frame;
        let shaped = self.frame_pose(first, false).posed.shaped.reshape([v, 3]);
        as_points(&host_f32(&(shaped + self.frozen_offsets())))
    }

    /// Stage 2's start: the stage-1 face Gaussians freed in canonical space (Eq. 1 → §3.2).
    pub fn hand_over(&self) -> Stage2State {
        let v = self.mesh.vertex_count();
        let first = self.capture.frames[self.train[0]].frame;
        let shaped = self.frame_pose(first, true).posed.shaped.reshape([v, 3]);
        let (human, binding) =
            PbrHuman::from_stage1(&self.body, &self.mesh, &self.body_queries, shaped);
        let n = human.len();
        // Without the light volume the colour slot keeps the display colour c = sRGB(b).
        let colour = if self.config.ablation.light_volume {
            human.albedo.val().inner()
        } else {
            crate::pbr::linear_to_srgb(human.albedo.val().inner())
        };
        let set = GaussianSet {
            means: human.means.val().inner(),
            quats: human.quats.val().inner(),
            log_scales: human.log_scales.val().inner(),
            opacity_logits: human.opacity_logits.val().inner(),
            sh_dc: colour.reshape([n, 1, 3]),
            sh_rest: Tensor::zeros([n, SH_REST, 3], &self.device),
        };
        let densify = &self.config.stage2.densify;
        let node = GaussianNode::new(
            HUMAN,
            set,
            self.config.stage2.rates,
            densify,
            self.mesh.height,
            self.config.seed ^ 0x111_0005,
        );
        let canonical = self.canonical_vertices();
        let node = match self.surface_prune(&canonical) {
            Some(surface) => node.with_density(Box::new(KlDensity {
                config: densify.clone(),
                stats: DensityStats::new(n, &self.device),
                extent: self.mesh.height,
                surface: Some(surface),
            })),
            None => node,
        };
        Stage2State {
            human: node,
            binding,
            offsets: self.frozen_offsets(),
            canonical,
        }
    }

    /// GauHuman's distance-to-mesh prune for the stage-2 human under KL density control: the
    /// refined canonical mesh (`canonical` vertices, the body's faces) and
    /// `stage2.mesh_prune_distance · H / 1.7`; `None` under another strategy or at distance 0.
    pub fn surface_prune(&self, canonical: &[[f32; 3]]) -> Option<SurfacePrune> {
        let distance = self.config.stage2.mesh_prune_distance;
        (self.config.stage2.densify.strategy == Strategy::Kl && distance > 0.0).then(|| {
            let faces: Vec<[u32; 3]> = self
                .mesh
                .model
                .faces
                .chunks_exact(3)
                .map(|f| [f[0], f[1], f[2]])
                .collect();
            SurfacePrune {
                mesh: FaceIndex::new(canonical, &faces),
                max_distance: distance * self.mesh.height / 1.7,
            }
        })
    }

    /// Rebinds the stage-2 human after a density edit: skinning weights and the transfer from
    /// the nearest refined canonical vertices of each Gaussian's canonical centre.
    pub fn rebind(&mut self) {
        let joints = self.mesh.model.joint_count();
        let weights = Tensor::<2>::from_data(
            TensorData::new(
                self.mesh.model.skin_weights.clone(),
                [self.mesh.vertex_count(), joints],
            ),
            &self.autodiff,
        );
        let Some(stage2) = self.stage2.as_mut() else {
            return;
        };
        let centres = as_points(&host_f32(&stage2.human.set.means));
        let transfer = KnnTransfer::new(
            &centres,
            &stage2.canonical,
            self.config.stage2.knn,
            &self.autodiff,
        );
        stage2.binding = Binding {
            skin_weights: transfer.apply(weights),
            transfer,
        };
    }

    /// One Adam step of the light volume's SH (DC at `light.sh_lr`, the higher bands at
    /// `light.sh_rest_ratio` of it: R3DG's `light_lr` and `light_rest_lr`) and latents: the
    /// shared environment only when `light.shared_environment`, the probes' own coefficients
    /// only from `light.probes_from_step`.
    pub fn step_volume(&mut self, grads: &burn::tensor::Gradients) {
        let config = AdamConfig::default();
        let light = &self.config.light;
        let k = self.volume.sh.val().dims()[1];
        let mut rates = vec![(light.sh_lr * light.sh_rest_ratio) as f32; k];
        rates[0] = light.sh_lr as f32;
        let rates = Tensor::<2>::from_data(TensorData::new(rates, [k, 1]), &self.device);
        if light.shared_environment
            && let Some(grad) = self.volume.environment.val().grad(grads)
        {
            let value = self.volume.environment.val().inner();
            let unit = self
                .environment_adam
                .step(value.clone(), grad, 1.0, &config);
            let updated = value.clone() - (value - unit) * rates.clone().expand([k, 3]);
            self.volume.environment =
                burn::module::Param::from_tensor(updated.autodiff().require_grad());
        }
        if self.step >= light.probes_from_step
            && let Some(grad) = self.volume.sh.val().grad(grads)
        {
            let value = self.volume.sh.val().inner();
            let [p, k, c] = value.dims();
            let unit = self.sh_adam.step(value.clone(), grad, 1.0, &config);
            let rates = rates.reshape([1, k, 1]).expand([p, k, c]);
            let updated = value.clone() - (value - unit) * rates;
            self.volume.sh = burn::module::Param::from_tensor(updated.autodiff().require_grad());
        }
        if let Some(grad) = self.volume.latent.val().grad(grads) {
            let value = self.volume.latent.val().inner();
            let updated = self
                .latent_adam
                .step(value, grad, self.config.light.latent_lr, &config);
            self.volume.latent =
                burn::module::Param::from_tensor(updated.autodiff().require_grad());
        }
    }
}
