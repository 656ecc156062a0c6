//! One optimiser step of each stage (§3.1, §3.2, §3.4), on one training frame.
//!
//! Both stages render the scene and the human together (the joint term of Eq. 10 against the
//! frame) and the human alone against the person composited on the background (its human
//! term), plus the inverse-depth L1 on pixels without the person, the shadow decoder's
//! smoothness (Eq. 12: F_ao is on from stage 1, so the person's shadow never settles into the
//! scene's colours) and L_scale (Eq. 15). Stage 1 adds L_mesh; stage 2 adds the materials and
//! probe terms (Eq. 11, 13) and trains F_vis on its own optimiser against ray-cast labels of
//! the frame's posed mesh (Eq. 3).

use crate::IllumError;
use crate::human::pose_refined;
use crate::lighting::{LitGaussians, Material, shade_gaussians};
use crate::pbr::{Shading, linear_to_srgb};
use crate::render::{HumanLayer, JointMaps, SceneLayer, render_joint};
use crate::shadow::{ShadowBox, scene_occlusion};
use crate::smoothness::{materials_smoothness, shadow_smoothness};
use crate::stage1::{HumanView, stage1_terms};
use crate::trainer::{FramePose, IllumTrainer, neighbour_table};
use crate::visibility::{VisibilitySource, bce_with_logits, raycast_visibility, sample_labels};
use burn::module::Module;
use burn::tensor::activation::{relu, sigmoid};
use burn::tensor::{Gradients, Tensor, TensorData};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use splatzoo_models::normals::vertex_normals;
use splatzoo_models::raycast::TriangleBvh;
use splatzoo_rasterizer::{Camera, ColorMode, RasterSettings, Render, Splats};
use splatzoo_train::host_f32;
use splatzoo_train::loss::{photometric, scalar};
use splatzoo_train::scene::skinned::skinning::skin_splats;
use splatzoo_train::scene::{FrameContext, FrameQuery, SceneNode, StepEnd};

/// What one step reports.
#[derive(Debug, Clone, Default)]
pub struct StepLosses {
    pub total: f64,
    /// The joint image term.
    pub scene: f64,
    /// The human-only image term.
    pub human: f64,
    /// What the human's density control did this step, if anything.
    pub note: Option<String>,
}

/// The networks a render reads: the live ones while training, gradient-free copies in
/// evaluation (so an evaluation records no autodiff graph).
#[derive(Clone, Copy)]
pub struct Nets<'a> {
    pub volume: &'a crate::light_volume::LightVolume,
    pub decoder: &'a crate::shadow::ShadowDecoder,
    pub materials: &'a splatzoo_models::networks::hash_mlp::HashMlp,
}

/// One training frame's targets.
struct Target {
    /// Index into `capture.frames`.
    index: usize,
    camera: Camera,
    image: Tensor<3>,
    mask: Tensor<2>,
    /// `[H, W]` inverse true depth where the person is absent, 0 elsewhere, and its validity.
    inverse_depth: Tensor<2>,
    depth_valid: Tensor<2>,
    frame: usize,
}

fn host_points(t: &Tensor<2>) -> Vec<[f64; 3]> {
    host_f32(t)
        .chunks(3)
        .map(|p| [p[0], p[1], p[2]].map(f64::from))
        .collect()
}

impl IllumTrainer {
    /// The live networks.
    pub fn nets(&self) -> Nets<'_> {
        Nets {
            volume: &self.volume,
            decoder: &self.decoder,
            materials: &self.materials,
        }
    }

    fn target(&mut self) -> Target {
        let k = self.train[self.order.next(self.train.len())];
        let f = &self.capture.frames[k];
        let [h, w, _] = f.image.dims();
        let (inverse, valid): (Vec<f32>, Vec<f32>) = f
            .depth
            .iter()
            .zip(&f.person)
            .map(|(&d, &person)| {
                if !person && d.is_finite() && d > 0.0 {
                    (1.0 / d, 1.0)
                } else {
                    (0.0, 0.0)
                }
            })
            .unzip();
        let a = &self.autodiff;
        Target {
            index: k,
            camera: f.camera,
            image: f.image.clone().autodiff(),
            mask: f.mask.clone().autodiff(),
            inverse_depth: Tensor::from_data(TensorData::new(inverse, [h, w]), a),
            depth_valid: Tensor::from_data(TensorData::new(valid, [h, w]), a),
            frame: f.frame,
        }
    }

    /// The scene's SH degree at step `step` (one more every `scene.sh_degree_every`).
    pub fn scene_degree(&self, step: usize) -> u32 {
        let every = self.config.scene.sh_degree_every.max(1);
        ((step / every) as u32).min(self.config.scene.sh_degree)
    }

    /// Eq. 8 for the scene's Gaussians around a posed human (`None` without the decoder), and
    /// which of them are in the shadow box.
    pub fn scene_ao(
        &self,
        nets: Nets,
        scene_means: &Tensor<2>,
        human_points: &[[f64; 3]],
    ) -> Result<(Option<Tensor<1>>, Vec<bool>), IllumError> {
        if !self.config.ablation.shadow_decoder() {
            return Ok((None, Vec::new()));
        }
        let shadow_box = ShadowBox::around(human_points, 1, self.config.light.shadow_pad)?;
        let in_box = shadow_box.inside(scene_means);
        let ao = scene_occlusion(nets.decoder, nets.volume, &shadow_box, scene_means.clone());
        Ok((Some(ao), in_box))
    }

    /// The terms every step shares: the joint image term, the human-only term, depth and
    /// shadow smoothness; returns their weighted sum and the two image terms.
    fn shared_terms(
        &self,
        target: &Target,
        joint: &JointMaps,
        alone: Tensor<3>,
        ao: Option<Tensor<1>>,
        in_box: &[bool],
    ) -> (Tensor<1>, f64, f64) {
        let w = &self.config.weights;
        let frame = &self.capture.frames[target.index];
        let joint_colour = frame.on_real_pixels(joint.colour.clone(), target.image.clone());
        let scene = photometric(joint_colour, target.image.clone(), w.ssim);
        let [h, wd, _] = target.image.dims();
        let mask = target.mask.clone().reshape([h, wd, 1]);
        let background =
            Tensor::<1>::from_floats(self.capture.background, &self.autodiff).reshape([1, 1, 3]);
        let composite = target.image.clone() * mask.clone() + background * (mask.neg() + 1.0);
        let human = photometric(alone, composite, w.ssim);
        let mut total = scene.clone() * w.scene + human.clone() * w.human;
        if w.depth > 0.0 {
            let covered = joint
                .render
                .alpha
                .clone()
                .detach()
                .greater_elem(0.5)
                .float();
            let valid = covered * target.depth_valid.clone();
            let inverse = joint.render.depth.clone().clamp_min(1e-3).recip();
            let l1 = ((inverse - target.inverse_depth.clone()).abs() * valid.clone()).sum()
                / valid.sum().clamp_min(1.0);
            total = total + l1 * w.depth;
        }
        if let Some(ao) = ao
            && w.shadows > 0.0
        {
            total =
                total + shadow_smoothness(ao, self.scene_neighbours.clone(), in_box) * w.shadows;
        }
        (total, scalar(scene), scalar(human))
    }

    fn scene_splats(&mut self, camera: &Camera) -> Splats {
        self.scene.begin_step();
        let query = FrameQuery {
            camera,
            frame: 0,
            time: 0.0,
        };
        self.scene
            .render(&query, &FrameContext { outputs: &[] })
            .splats
    }

    /// The scene node's optimiser and density control; its neighbour table follows an edit.
    fn end_scene_step(&mut self, grads: &Gradients, render: &Render, rows: usize) {
        let progress = self.step as f64 / self.config.iterations.max(1) as f64;
        self.scene.end_step(&StepEnd {
            grads,
            renders: vec![(render, 0..rows)],
            step: self.step,
            progress,
        });
        if self.scene.take_lineage().is_some() {
            self.scene_neighbours = neighbour_table(
                &self.scene.set.means.clone().autodiff(),
                self.config.light.shadow_neighbours,
            );
        }
    }

    fn step_decoder(&mut self, grads: &Gradients) {
        if self.config.ablation.shadow_decoder() {
            self.decoder =
                self.decoder_adam
                    .step(self.decoder.clone(), grads, self.config.light.decoder_lr);
        }
    }

    /// The loss's value and gradients; a loss that is not finite stops the run, named.
    fn backward(&self, total: Tensor<1>) -> Result<(f64, Gradients), IllumError> {
        let value = scalar(total.clone());
        if !value.is_finite() {
            return Err(splatzoo_train::TrainError::NonFinite {
                step: self.step,
                value,
            }
            .into());
        }
        Ok((value, total.backward()))
    }

    /// Stage 1 (§3.1): the refined body's face Gaussians with F_c's colours.
    pub fn stage1_step(&mut self) -> Result<StepLosses, IllumError> {
        let target = self.target();
        let pose = self.frame_pose(target.frame, true);
        let settings = RasterSettings::new(target.camera, ColorMode::Features);
        let terms = stage1_terms(
            &self.body,
            &self.mesh,
            &self.laplacian,
            &self.body_queries,
            &pose.posed,
            HumanView {
                settings: &settings,
                image: target.image.clone(),
                mask: target.mask.clone(),
                background: self.capture.background,
            },
            &self.config.stage1.weights,
        )?;
        let human_splats = terms.splats.clone();
        let f = human_splats.len();
        let scene = self.scene_splats(&target.camera);
        let m = scene.len();
        let (ao, in_box) =
            self.scene_ao(self.nets(), &scene.means, &host_points(&human_splats.means))?;
        let zeros = |c: usize| Tensor::<2>::zeros([f, c], &self.autodiff);
        let joint = render_joint(
            Some(SceneLayer {
                splats: &scene,
                degree: self.scene_degree(self.step),
                ao: ao.clone(),
            }),
            Some(HumanLayer {
                splats: &human_splats,
                colour: human_splats.colors.clone().reshape([f, 3]),
                material: zeros(2),
                albedo: zeros(3),
                normals: zeros(3),
            }),
            &settings,
            self.capture.background,
        )?;
        let (shared, scene_term, human_term) =
            self.shared_terms(&target, &joint, terms.render.color.clone(), ao, &in_box);
        let w = &self.config.stage1.weights;
        let mut total = shared + terms.mesh * w.mesh + terms.scale * w.scale;
        if let Some(r) = self.scene.regulariser() {
            total = total + r;
        }
        let (value, grads) = self.backward(total)?;
        let lr = self.config.stage1.field_lr;
        self.body.offset = self.offset_adam.step(self.body.offset.clone(), &grads, lr);
        self.body.colour = self.colour_adam.step(self.body.colour.clone(), &grads, lr);
        if let Some(grad) = self.body.in_plane.val().grad(&grads) {
            let updated = self.in_plane_adam.step(
                self.body.in_plane.val().inner(),
                grad,
                self.config.stage1.in_plane_lr,
                &splatzoo_train::adam::AdamConfig::default(),
            );
            self.body.in_plane =
                burn::module::Param::from_tensor(updated.autodiff().require_grad());
        }
        self.end_scene_step(&grads, &joint.render, m);
        self.step_decoder(&grads);
        self.step_volume(&grads);
        Ok(StepLosses {
            total: value,
            scene: scene_term,
            human: human_term,
            note: None,
        })
    }

    /// Stage 2's human for one frame: posed Gaussians and their per-Gaussian channels (Eq. 4–7;
    /// without the light volume, their own colour) with `sampling`'s N_l; `step_seed` draws
    /// each Gaussian's random azimuth offset (training), `None` leaves them at 0 (evaluation).
    pub fn stage2_human(
        &self,
        nets: Nets,
        canonical: &Splats,
        pose: &FramePose,
        camera: &Camera,
        sampling: crate::lighting::SamplingConfig,
        step_seed: Option<u64>,
    ) -> (Splats, [Tensor<2>; 4]) {
        let stage2 = self.stage2.as_ref().expect("stage 2 has started");
        let n = canonical.len();
        let v = self.mesh.vertex_count();
        let offsets = stage2.offsets.clone().autodiff();
        let placed = pose_refined(&pose.posed, offsets).reshape([v, 3]);
        let slot = canonical
            .colors
            .clone()
            .slice([0..n, 0..1, 0..3])
            .reshape([n, 3])
            .clamp(0.0, 1.0);
        let posed = skin_splats(
            Splats {
                colors: slot.clone().reshape([n, 1, 3]),
                ..canonical.clone()
            },
            stage2.binding.skin_weights.clone(),
            &pose.transforms,
        );
        let normals = crate::stage2::posed_normals(&stage2.binding, &self.mesh, placed.clone());
        if !self.config.ablation.light_volume {
            let zeros = |c: usize| Tensor::<2>::zeros([n, c], &self.autodiff);
            return (posed, [slot, zeros(2), zeros(3), normals]);
        }
        let per_vertex = sigmoid(nets.materials.forward_queries(&self.material_queries));
        let material = stage2.binding.transfer.apply(per_vertex);
        let metallic = material.clone().slice([0..n, 0..1]);
        let roughness = material.clone().slice([0..n, 1..2]);
        let azimuth_offsets = step_seed.map(|step_seed| {
            let mut rng = StdRng::seed_from_u64(step_seed ^ 0xA21);
            let values: Vec<f32> = (0..n)
                .map(|_| rng.random_range(0.0..std::f32::consts::TAU))
                .collect();
            Tensor::<1>::from_data(TensorData::new(values, [n]), &self.autodiff)
        });
        let source = self.config.visibility.source;
        let vis_net = self.visibility.valid();
        let centres = canonical.means.clone().inner();
        let posed_centres = host_points(&posed.means);
        let height = self.mesh.height;
        let faces = &self.mesh.model.faces;
        let placed_host = host_points(&placed);
        let root = pose.root.clone().inner();
        let pose_vector = pose.pose_vector.clone().inner();
        let normals_host = host_points(&normals);
        let visibility = |directions: &Tensor<3>| -> Option<Tensor<2>> {
            let [rows, s, _] = directions.dims();
            match source {
                VisibilitySource::Open => None,
                VisibilitySource::Net => {
                    let world = directions.clone().inner().reshape([rows * s, 3]);
                    let local = world.matmul(root).reshape([rows, s, 3]);
                    let open = vis_net.forward(centres, local, pose_vector);
                    Some(Tensor::from_data(open.to_data(), &self.autodiff))
                }
                VisibilitySource::Raycast => {
                    let triangles: Vec<[u32; 3]> =
                        faces.chunks(3).map(|t| [t[0], t[1], t[2]]).collect();
                    let bvh = TriangleBvh::new(&placed_host, &triangles);
                    let dirs = host_f32(directions);
                    let mut origins = Vec::with_capacity(rows * s);
                    let mut ns = Vec::with_capacity(rows * s);
                    let mut ds = Vec::with_capacity(rows * s);
                    for i in 0..rows {
                        for j in 0..s {
                            origins.push(posed_centres[i]);
                            ns.push(normals_host[i]);
                            let d = &dirs[3 * (i * s + j)..3 * (i * s + j) + 3];
                            ds.push([d[0], d[1], d[2]].map(f64::from));
                        }
                    }
                    let open = raycast_visibility(&bvh, &origins, &ns, &ds, 1e-3 * height);
                    Some(Tensor::from_data(
                        TensorData::new(open, [rows, s]),
                        &self.autodiff,
                    ))
                }
            }
        };
        let linear = shade_gaussians(
            nets.volume,
            LitGaussians {
                points: posed.means.clone(),
                normals: normals.clone(),
                material: Material {
                    albedo: slot.clone(),
                    metallic,
                    roughness,
                },
                camera_centre: camera.position().map(f64::from),
                azimuth_offsets,
            },
            sampling,
            visibility,
            &Shading {
                specular: self.config.stage2.specular,
            },
        );
        (posed, [linear_to_srgb(linear), material, slot, normals])
    }

    /// Stage 2 (§3.2): the PBR human lit by the light volume.
    pub fn stage2_step(&mut self) -> Result<StepLosses, IllumError> {
        let target = self.target();
        let pose = self.frame_pose(target.frame, true);
        let settings = RasterSettings::new(target.camera, ColorMode::Features);
        let step_seed = self.config.seed ^ (self.step as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        let canonical = {
            let stage2 = self.stage2.as_mut().expect("stage 2 has started");
            stage2.human.begin_step();
            let query = FrameQuery {
                camera: &target.camera,
                frame: target.frame,
                time: 0.0,
            };
            stage2
                .human
                .render(&query, &FrameContext { outputs: &[] })
                .splats
        };
        let n = canonical.len();
        let (human, [colour, material, albedo, normals]) = self.stage2_human(
            self.nets(),
            &canonical,
            &pose,
            &target.camera,
            self.config.stage2.sampling(true),
            Some(step_seed),
        );
        let scene = self.scene_splats(&target.camera);
        let m = scene.len();
        let (ao, in_box) = self.scene_ao(self.nets(), &scene.means, &host_points(&human.means))?;
        let layer = || HumanLayer {
            splats: &human,
            colour: colour.clone(),
            material: material.clone(),
            albedo: albedo.clone(),
            normals: normals.clone(),
        };
        let joint = render_joint(
            Some(SceneLayer {
                splats: &scene,
                degree: self.scene_degree(self.step),
                ao: ao.clone(),
            }),
            Some(layer()),
            &settings,
            self.capture.background,
        )?;
        let alone = render_joint(None, Some(layer()), &settings, self.capture.background)?;
        let (shared, scene_term, human_term) =
            self.shared_terms(&target, &joint, alone.colour.clone(), ao, &in_box);
        let w = &self.config.weights;
        let mut total = shared;
        if self.config.ablation.light_volume {
            if w.materials > 0.0 {
                total = total
                    + materials_smoothness(
                        joint.material.clone(),
                        target.image.clone(),
                        target.mask.clone(),
                    ) * w.materials;
            }
            if w.probe > 0.0 {
                total = total + self.volume.probe_smoothness() * w.probe;
            }
        }
        let largest = human.log_scales.clone().exp().max_dim(1);
        let scale = relu(largest - w.max_scale * self.mesh.height).mean();
        total = total + scale * w.scale;
        if let Some(r) = self.scene.regulariser() {
            total = total + r;
        }
        let (value, grads) = self.backward(total)?;
        self.end_scene_step(&grads, &joint.render, m);
        let progress = self.step as f64 / self.config.iterations.max(1) as f64;
        let (edited, report) = {
            let stage2 = self.stage2.as_mut().expect("stage 2 has started");
            let report = stage2.human.end_step(&StepEnd {
                grads: &grads,
                renders: vec![(&joint.render, m..m + n), (&alone.render, 0..n)],
                step: self.step,
                progress,
            });
            let count = stage2.human.gaussians();
            let note = report.map(|r| {
                format!(
                    "human density: {} cloned, {} split, {} merged, {} pruned ({} off the mesh) \
                     → {count} Gaussians",
                    r.cloned, r.split, r.merged, r.pruned, r.off_surface
                )
            });
            (stage2.human.take_lineage().is_some(), note)
        };
        if edited {
            self.rebind();
        }
        if self.config.ablation.light_volume {
            self.materials = self.materials_adam.step(
                self.materials.clone(),
                &grads,
                self.config.stage2.materials_lr,
            );
        }
        self.step_decoder(&grads);
        self.step_volume(&grads);
        if self.config.ablation.light_volume
            && self.config.visibility.source == VisibilitySource::Net
        {
            self.visibility_step(&pose, step_seed);
        }
        Ok(StepLosses {
            total: value,
            scene: scene_term,
            human: human_term,
            note: report,
        })
    }

    /// F_vis's own step (Eq. 3): BCE against ray-cast labels of the refined mesh in `pose`
    /// (the image step's own pose, so the body is posed once a step). Returns the loss.
    pub fn visibility_step(&mut self, pose: &FramePose, seed: u64) -> f64 {
        let labels = self.visibility_labels(pose, self.config.visibility.labels, seed);
        self.fit_visibility(pose.root.clone(), pose.pose_vector.clone(), labels)
    }

    /// `visibility.warmup` F_vis steps on their own at the hand-over (our choice; see
    /// [`crate::config::VisibilitySchedule::warmup`]): step `i` takes training frame
    /// `i mod T` of a seeded shuffle, so every training pose is seen alike; each frame's posed
    /// mesh, its BVH and its pose inputs are built once. Returns the mean BCE of the first and
    /// the last tenth of the steps, or `None` when there are none (or F_vis is not in use).
    pub fn visibility_warmup(&mut self) -> Option<(f64, f64)> {
        let steps = self.config.visibility.warmup;
        if steps == 0
            || !self.config.ablation.light_volume
            || self.config.visibility.source != VisibilitySource::Net
        {
            return None;
        }
        let mut order: Vec<usize> = self
            .train
            .iter()
            .map(|&k| self.capture.frames[k].frame)
            .collect();
        if order.is_empty() {
            return None;
        }
        let mut rng = StdRng::seed_from_u64(self.config.seed ^ 0xF715_3A2B);
        for i in (1..order.len()).rev() {
            order.swap(i, rng.random_range(0..=i));
        }
        let meshes: Vec<PosedVisibilityMesh> = order
            .iter()
            .map(|&f| self.visibility_mesh(&self.frame_pose(f, false)))
            .collect();
        // The pose inputs as constants of the autodiff device (F_vis's step needs no gradient
        // to the pose).
        let a = &self.autodiff;
        let inputs: Vec<(Tensor<2>, Tensor<1>)> = meshes
            .iter()
            .map(|m| {
                (
                    Tensor::from_data(m.root.clone().into_data(), a),
                    Tensor::from_data(m.pose_vector.clone().into_data(), a),
                )
            })
            .collect();
        let tenth = steps.div_ceil(10);
        let (mut first, mut last) = (0.0, 0.0);
        for i in 0..steps {
            let k = i % order.len();
            let (root, pose_vector) = inputs[k].clone();
            let labels = meshes[k].labels(
                self.config.visibility.labels,
                self.config.seed ^ (i as u64).wrapping_mul(0x2545_F491_4F6C_DD1D),
            );
            let loss = self.fit_visibility(root, pose_vector, labels);
            if i < tenth {
                first += loss / tenth as f64;
            }
            if i >= steps - tenth {
                last += loss / tenth as f64;
            }
        }
        Some((first, last))
    }

    /// One Adam step of F_vis on `labels` cast in the pose of root rotation `root` and pose
    /// vector `pose_vector` (autodiff device). Returns the BCE.
    fn fit_visibility(
        &mut self,
        root: Tensor<2>,
        pose_vector: Tensor<1>,
        labels: crate::visibility::VisibilityLabels,
    ) -> f64 {
        let count = labels.open.len();
        let a = &self.autodiff;
        let flat = |v: &[[f64; 3]]| -> Vec<f32> { v.iter().flatten().map(|&x| x as f32).collect() };
        let points = Tensor::<2>::from_data(TensorData::new(flat(&labels.points), [count, 3]), a);
        let world =
            Tensor::<2>::from_data(TensorData::new(flat(&labels.directions), [count, 3]), a);
        let local = world.matmul(root).reshape([count, 1, 3]);
        let open = Tensor::<2>::from_data(TensorData::new(labels.open, [count, 1]), a);
        let logits = self.visibility.logits(points, local, pose_vector);
        let loss = bce_with_logits(logits, open);
        let value = scalar(loss.clone());
        let grads = loss.backward();
        self.visibility =
            self.visibility_adam
                .step(self.visibility.clone(), &grads, self.config.visibility.lr);
        value
    }

    /// `count` ray-cast labels of the refined mesh in `pose` (either device).
    pub fn visibility_labels(
        &self,
        pose: &FramePose,
        count: usize,
        seed: u64,
    ) -> crate::visibility::VisibilityLabels {
        self.visibility_mesh(pose).labels(count, seed)
    }

    /// The refined mesh in `pose` (either device; read as constants), its normals and its
    /// BVH, with the canonical vertices the labels name.
    fn visibility_mesh(&self, pose: &FramePose) -> PosedVisibilityMesh {
        let stage2 = self.stage2.as_ref().expect("F_vis is trained in stage 2");
        let v = self.mesh.vertex_count();
        let posed = pose_refined(&pose.posed, stage2.offsets.clone()).inner();
        let normals =
            host_points(&vertex_normals(posed.clone(), &self.mesh.model.faces).reshape([v, 3]));
        let placed = host_points(&posed.reshape([v, 3]));
        let canonical: Vec<[f64; 3]> = stage2.canonical.iter().map(|p| p.map(f64::from)).collect();
        let triangles: Vec<[u32; 3]> = self
            .mesh
            .model
            .faces
            .chunks(3)
            .map(|t| [t[0], t[1], t[2]])
            .collect();
        PosedVisibilityMesh {
            bvh: TriangleBvh::new(&placed, &triangles),
            canonical,
            placed,
            normals,
            height: self.mesh.height,
            root: pose.root.clone().inner(),
            pose_vector: pose.pose_vector.clone().inner(),
        }
    }
}

/// One pose of the refined mesh, ready to cast F_vis's labels on.
struct PosedVisibilityMesh {
    bvh: TriangleBvh,
    canonical: Vec<[f64; 3]>,
    placed: Vec<[f64; 3]>,
    normals: Vec<[f64; 3]>,
    height: f64,
    /// F_vis's pose inputs (plain device): the root rotation and the pose vector.
    root: Tensor<2>,
    pose_vector: Tensor<1>,
}

impl PosedVisibilityMesh {
    /// `count` labelled pairs drawn with `seed`.
    fn labels(&self, count: usize, seed: u64) -> crate::visibility::VisibilityLabels {
        let mut rng = StdRng::seed_from_u64(seed ^ 0x7150);
        sample_labels(
            &self.bvh,
            &self.canonical,
            &self.placed,
            &self.normals,
            self.height,
            count,
            &mut rng,
        )
    }
}
