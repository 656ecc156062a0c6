//! A driving scene's graph, built from what the data contains, and one frame of it composed
//! for a camera: a static background (from the LiDAR outside the tracked people), one skinned
//! human node per tracked pedestrian (Eq. 2, 4), and one accessory node per person whose
//! decoupled accessory mask is large enough (Eq. 3, 8), after its human so it can read the
//! parent joint. Each decision is recorded with its reason.

use crate::accessory::{AccessoryDeformation, AccessoryNode};
use crate::config::{ApfConfig, SparsityOf};
use crate::data::ApfCapture;
use crate::decouple::wants_accessory;
use crate::error::ApfError;
use crate::gate::GateGranularity;
use crate::loss::{PersonTerms, limit_loss, relative_bone_loss};
use crate::networks::{ApfNetworks, Embeddings};
use crate::parent::{PELVIS, accessory_returns, fallback_points, initial_points, select_parent};
use crate::residual::{GatedResidual, ResidualGate, bounding_box};
use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_models::body::BodyModel;
use splatzoo_models::body::priors::bone_lengths;
use splatzoo_models::networks::encoding::frequency_encoding;
use splatzoo_rasterizer::{Camera, Splats};
use splatzoo_train::gaussians::GaussianSet;
use splatzoo_train::harness::ModuleChoice;
use splatzoo_train::scene::skinned::ResidualInput;
use splatzoo_train::scene::{
    FrameContext, FrameQuery, GaussianNode, NodeOutput, SceneNode, SkinnedGaussianNode,
};

/// The background node's name.
pub const BACKGROUND: &str = "background";

pub fn human_name(h: usize) -> String {
    format!("human_{h}")
}

pub fn accessory_name(h: usize) -> String {
    format!("accessory_{h}")
}

/// One tracked person's node and what Eq. 4–5 need about them.
pub struct Human {
    pub node: SkinnedGaussianNode,
    /// The canonical body's box for `γ(μ̄)`.
    pub centre: [f32; 3],
    pub half_extent: [f32; 3],
    /// Whether the person is in the scene at each frame (hidden where not).
    pub present: Vec<bool>,
}

pub struct Accessory {
    pub person: usize,
    pub node: AccessoryNode,
    /// Index into the accessory embeddings.
    pub index: usize,
    /// The candidates' spreads at parent selection (metres).
    pub spreads: Vec<(usize, f64)>,
}

pub struct ApfScene {
    pub background: GaussianNode,
    pub humans: Vec<Human>,
    pub accessories: Vec<Accessory>,
    pub decisions: Vec<String>,
    /// The accessory node of each tracked person, built or not, and why.
    pub modules: Vec<ModuleChoice>,
}

/// What a frame's composition switched on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stage {
    /// The residual field and gate (S2).
    pub residual: bool,
    /// The accessory network (S2).
    pub deform: bool,
}

/// One frame composed for one camera.
pub struct Composed {
    pub splats: Splats,
    /// Rows of each node in `splats`: humans, accessories, background (scene order).
    pub rows: Vec<std::ops::Range<usize>>,
    /// `[N]` 1 on human rows, and on accessory rows (for the node-alpha pass).
    pub human_rows: std::ops::Range<usize>,
    pub accessory_rows: std::ops::Range<usize>,
    /// Eq. 6's terms of each person whose residual was active: (person, terms).
    pub terms: Vec<(usize, PersonTerms)>,
}

impl ApfScene {
    pub fn build(
        config: &ApfConfig,
        capture: &ApfCapture,
        model: &BodyModel,
        device: &Device,
    ) -> Result<Self, ApfError> {
        let mut decisions = Vec::new();
        let mut modules = Vec::new();
        let mut humans = Vec::new();
        let mut human = config.human.clone();
        human.smoothness_weight = config.loss.pose;
        for (h, person) in capture.people.iter().enumerate() {
            let node = SkinnedGaussianNode::new(
                &human_name(h),
                model,
                &person.prior,
                capture.trained.clone(),
                &human,
                config.human_rates,
                &splatzoo_train::densify::DensifyConfig {
                    strategy: splatzoo_train::densify::Strategy::None,
                    ..Default::default()
                },
                1.0,
                config.seed ^ (0xA9F0_0000 + h as u64),
                device,
            )?;
            let (centre, half_extent) =
                bounding_box(&splatzoo_train::host_f32(&node.canonical_set().means), 1e-3);
            humans.push(Human {
                node,
                centre,
                half_extent,
                present: person.present.clone(),
            });
        }
        let mut accessories = Vec::new();
        for (h, person) in capture.people.iter().enumerate() {
            if !config.decouple.enabled {
                continue;
            }
            let masks: Vec<_> = capture
                .train
                .iter()
                .map(|&i| &capture.views[i].people[h])
                .collect();
            let (wanted, why) = wants_accessory(&config.decouple, &masks);
            let module = format!("accessory node of {}", person.name);
            let choice = ModuleChoice::decide(
                module.clone(),
                "decouple.accessories",
                config.decouple.accessories,
                wanted,
                why.clone(),
            );
            if !choice.enabled {
                modules.push(choice);
                continue;
            }
            let returns = accessory_returns(capture, h);
            let point_seed = config.seed ^ (0xACC0_0000 + h as u64);
            let keep = config.attach.initial_gaussians;
            let (joint, spreads, points) = match select_parent(person, &returns) {
                Some((joint, spreads)) => {
                    let points = initial_points(person, &returns, joint, keep, point_seed);
                    modules.push(choice);
                    (joint, spreads, points)
                }
                // Forced on: it starts on the pelvis all the same.
                None if choice.forced_by.is_some() => {
                    modules.push(ModuleChoice {
                        reason: format!(
                            "{}; too few LiDAR returns on its mask to place it: it starts on \
                             the pelvis",
                            choice.reason
                        ),
                        ..choice
                    });
                    (PELVIS, Vec::new(), fallback_points(keep, point_seed))
                }
                None => {
                    modules.push(ModuleChoice {
                        enabled: false,
                        reason: format!(
                            "{}; but too few LiDAR returns on its mask to place it",
                            choice.reason
                        ),
                        ..choice
                    });
                    continue;
                }
            };
            let set = GaussianSet::from_points(
                &points.positions,
                &points.colours,
                &points.sigmas,
                device,
            );
            let mut node = AccessoryNode::new(
                &accessory_name(h),
                &human_name(h),
                joint,
                set,
                config.background_rates,
                config.attach.rates,
                &config.accessory_densify,
                config.seed ^ (0xACC1_0000 + h as u64),
            );
            node.detach_parent = config.attach.detach_parent;
            decisions.push(format!(
                "{}: accessory node on joint {joint} ({why}; {} initial points; {})",
                person.name,
                points.len(),
                if spreads.is_empty() {
                    "forced: the pelvis, no returns to choose a parent by".to_owned()
                } else {
                    let spreads: Vec<String> = spreads
                        .iter()
                        .map(|(k, s)| format!("{k}: {:.0} mm", 1e3 * s))
                        .collect();
                    format!("parent spread {}", spreads.join(", "))
                }
            ));
            let index = accessories.len();
            accessories.push(Accessory {
                person: h,
                node,
                index,
                spreads,
            });
        }
        if !config.decouple.enabled {
            decisions.push(
                "decoupling off: humans supervised by M_coarse, no accessory nodes (Table II's w/o decoupling)"
                    .into(),
            );
        }
        let points = &capture.scene_points;
        if points.is_empty() {
            return Err(ApfError::input(
                "background",
                "no LiDAR return outside the tracked people to start the background from",
            ));
        }
        let set =
            GaussianSet::from_points(&points.positions, &points.colours, &points.sigmas, device);
        decisions.push(format!(
            "background node from {} LiDAR returns outside the tracked people",
            points.len()
        ));
        let background = GaussianNode::new(
            BACKGROUND,
            set,
            config.background_rates,
            &config.background_densify,
            scene_extent(points),
            config.seed ^ 0xB6B6_0000,
        );
        Ok(Self {
            background,
            humans,
            accessories,
            decisions,
            modules,
        })
    }

    pub fn gaussians(&self) -> usize {
        self.background.gaussians()
            + self
                .humans
                .iter()
                .map(|h| h.node.gaussians())
                .sum::<usize>()
            + self
                .accessories
                .iter()
                .map(|a| a.node.gaussians())
                .sum::<usize>()
    }

    pub fn begin_step(&mut self) {
        self.background.begin_step();
        for h in &mut self.humans {
            h.node.begin_step();
        }
        for a in &mut self.accessories {
            a.node.begin_step();
        }
    }

    /// Every node in graph order (humans, accessories, background).
    pub fn nodes_mut(&mut self) -> Vec<&mut dyn SceneNode> {
        let mut nodes: Vec<&mut dyn SceneNode> = Vec::new();
        for h in &mut self.humans {
            nodes.push(&mut h.node);
        }
        for a in &mut self.accessories {
            nodes.push(&mut a.node);
        }
        nodes.push(&mut self.background);
        nodes
    }

    pub fn nodes(&self) -> Vec<&dyn SceneNode> {
        let mut nodes: Vec<&dyn SceneNode> = Vec::new();
        for h in &self.humans {
            nodes.push(&h.node);
        }
        for a in &self.accessories {
            nodes.push(&a.node);
        }
        nodes.push(&self.background);
        nodes
    }
}

/// The radius of the points' bounding box (3DGS's scene extent).
fn scene_extent(points: &splatzoo_train::views::InitPoints) -> f64 {
    let (_, half) = bounding_box(&points.positions.concat(), 0.0);
    f64::from((half[0] * half[0] + half[1] * half[1] + half[2] * half[2]).sqrt()) * 1.1
}

/// What conditions one person's residual at one frame.
pub struct Guided {
    /// `[1, 1]` σ and `[1, 1]` the guidance's logit (σ's, in learned mode).
    pub sigma: Tensor<2>,
    pub logit: Tensor<2>,
    pub condition: Tensor<2>,
}

/// `γ(t)` of `t / duration`, `[1, 1 + 2 L]`.
pub fn time_encoding(time: f64, duration: f64, levels: usize, device: &Device) -> Tensor<2> {
    let t = (time / duration.max(1e-9)) as f32;
    frequency_encoding(
        Tensor::<2>::from_data(TensorData::new(vec![t], [1, 1]), device),
        levels,
    )
}

/// Inputs of one frame's composition.
pub struct FrameInputs<'a> {
    pub camera: &'a Camera,
    pub frame: usize,
    pub time: f64,
    /// Per tracked person: the guidance output, where the residual is on for them.
    pub guided: &'a [Option<Guided>],
    pub nets: &'a ApfNetworks,
    pub stage: Stage,
    pub duration: f64,
    pub in_step: bool,
}

impl ApfScene {
    /// The frame's Gaussians from every node (the step's leaves inside a step) and Eq. 6's
    /// per-person terms.
    pub fn compose(&self, input: &FrameInputs, config: &ApfConfig) -> Composed {
        let query = FrameQuery {
            camera: input.camera,
            frame: input.frame,
            time: input.time,
        };
        let mut outputs: Vec<(String, NodeOutput)> = Vec::new();
        let mut terms = Vec::new();
        let present = |h: usize| {
            let human: &Human = &self.humans[h];
            human.present.get(input.frame).copied().unwrap_or(true)
        };
        for (h, human) in self.humans.iter().enumerate() {
            let guided = input
                .guided
                .get(h)
                .and_then(|g| g.as_ref())
                .filter(|_| present(h));
            let posed = pose_human(
                &human.node,
                human,
                input.frame,
                guided,
                input.nets,
                config,
                input.in_step,
            );
            if let Some(t) = posed.terms {
                terms.push((h, t));
            }
            outputs.push((
                human_name(h),
                NodeOutput {
                    splats: hidden_unless(present(h), posed.splats),
                    joints: Some(posed.joints),
                    bounds: None,
                },
            ));
        }
        let humans_end: usize = outputs.iter().map(|(_, o)| o.splats.len()).sum();
        for accessory in &self.accessories {
            let deformation = input.stage.deform.then(|| AccessoryDeformation {
                field: input.nets.accessory.clone(),
                embedding: Embeddings::row(&input.nets.embeddings.accessory, accessory.index),
                position_levels: config.network.position_levels,
                time_levels: config.network.time_levels,
                duration: input.duration,
            });
            let mut output = accessory.node.render_with(
                &query,
                &FrameContext { outputs: &outputs },
                deformation.as_ref(),
            );
            output.splats = hidden_unless(present(accessory.person), output.splats);
            outputs.push((accessory.node.name().to_owned(), output));
        }
        let accessories_end: usize = outputs.iter().map(|(_, o)| o.splats.len()).sum();
        let background = self
            .background
            .render(&query, &FrameContext { outputs: &outputs });
        outputs.push((BACKGROUND.to_owned(), background));
        let mut rows = Vec::new();
        let mut start = 0;
        for (_, o) in &outputs {
            rows.push(start..start + o.splats.len());
            start += o.splats.len();
        }
        let splats = splatzoo_train::scene::concatenate(
            outputs.into_iter().map(|(_, o)| o.splats).collect(),
        );
        Composed {
            splats,
            rows,
            human_rows: 0..humans_end,
            accessory_rows: humans_end..accessories_end,
            terms,
        }
    }
}

/// Opacity logit of a hidden node's Gaussians: sigmoid(−30) ≈ 1e-13, under the rasterizer's
/// 1/255 alpha cut-off, so they touch no pixel and take no gradient.
const HIDDEN_LOGIT: f64 = -30.0;

/// `splats` as they are where `visible`, else with every opacity below the alpha cut-off (a
/// person out of the scene at this frame; the rows stay so every frame composes the same way).
fn hidden_unless(visible: bool, splats: Splats) -> Splats {
    if visible {
        return splats;
    }
    // Through the logits (× 0), so the tensor stays on the step's tape like its neighbours.
    Splats {
        opacity_logits: splats.opacity_logits.clone() * 0.0 + HIDDEN_LOGIT,
        ..splats
    }
}

/// One person at one frame: their Gaussians, joints and Eq. 6's terms.
pub struct PosedHuman {
    pub splats: Splats,
    /// `[J, 4, 4]` world transforms of the joints (what an accessory hangs from).
    pub joints: Tensor<3>,
    /// Eq. 6's terms, where the residual was on.
    pub terms: Option<PersonTerms>,
}

/// `node` (person `human`'s, or a re-posed copy) at `frame`: LBS with the frame's pose, then
/// Eq. 4's residual where `guided` is given.
pub fn pose_human(
    node: &SkinnedGaussianNode,
    human: &Human,
    frame: usize,
    guided: Option<&Guided>,
    nets: &ApfNetworks,
    config: &ApfConfig,
    in_step: bool,
) -> PosedHuman {
    let canonical = match node.canonical_leaves() {
        Some(l) if in_step => l.splats(),
        _ => node.canonical_set().splats(),
    };
    let posed = node.posed(canonical.clone(), frame);
    let joints = posed.joints.homogeneous();
    let Some(guided) = guided else {
        return PosedHuman {
            splats: posed.splats,
            joints,
            terms: None,
        };
    };
    let field = GatedResidual {
        field: nets.residual.clone(),
        condition: guided.condition.clone(),
        gate: match config.gate.granularity {
            GateGranularity::PersonFrame => {
                ResidualGate::PersonFrame(config.gate.amplitude(guided.sigma.clone()))
            }
            GateGranularity::Gaussian => ResidualGate::Gaussian {
                logit: guided.logit.clone(),
                gate: config.gate.clone(),
            },
        },
        levels: config.network.position_levels,
        centre: human.centre,
        half_extent: human.half_extent,
        max_offset: config.residual.max_offset,
    };
    let (residual, produced) = field.compute(&ResidualInput {
        splats: &posed.splats,
        canonical: &canonical,
        frame,
        pose: &posed.pose.rotations,
    });
    // Eq. 7's reference: the bones of the joints regressed from this frame's LBS alone, so the
    // term reads only what Δ stretches (regressed joints of a posed mesh are not the skeleton's
    // exactly, and a reference from the rest skeleton would make the term a function of θ
    // alone, pushing σ to 1 whatever Δ does).
    let j = node.model().joint_count() - 1;
    let unstretched = bone_lengths(
        node.regress_joints(posed.splats.means.clone().detach())
            .detach()
            .reshape([1, j + 1, 3]),
        &node.model().parents,
    )
    .reshape([j]);
    let splats = residual.apply(posed.splats);
    let regressed = node.regress_joints(splats.means.clone());
    // Eq. 6's weights: the person-frame's σ, or each Gaussian's on its own sparsity row.
    let rows = match config.loss.sparsity_of {
        SparsityOf::Gated => produced.sparsity_rows(),
        SparsityOf::Field => produced.field_sparsity_rows(config.residual.max_offset),
    };
    let (sigma, sparsity) = match &produced.sigma {
        Some(per_gaussian) => (per_gaussian.clone(), rows),
        None => (guided.sigma.clone(), rows.mean()),
    };
    let terms = PersonTerms {
        sigma,
        sparsity,
        bone: relative_bone_loss(regressed, &node.model().parents, unstretched),
        limit: limit_loss(posed.pose.rotations.clone()),
    };
    PosedHuman {
        splats,
        joints,
        terms: Some(terms),
    }
}
