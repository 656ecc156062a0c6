//! [`ApfTrainer`] as the harness's [`Method`]: shorthands, fresh and resumed runs, the
//! evaluation written to `metrics.json`, the checkpoint and the exports.

use crate::config::ApfConfig;
use crate::eval::{HUMAN_REGION, spearman};
use crate::networks::ApfNetworks;
use crate::trainer::{ApfArgs, ApfTrainer, NetworkOptimizers};
use burn::module::Module;
use burn::tensor::Device;
use splatzoo_train::TrainError;
use splatzoo_train::checkpoint::Checkpoint;
use splatzoo_train::gaussians::GaussianSet;
use splatzoo_train::harness::{
    EpochOrder, Evaluation, Method, ModuleChoice, Say, StepReport, read_back,
};
use splatzoo_train::images::{side_by_side, srgb_image, write_png};
use splatzoo_train::lpips::Lpips;
use splatzoo_train::module_adam::{ModuleAdam, NETWORK_ADAM};
use splatzoo_train::ply::write_ply;
use splatzoo_train::scene::SceneNode;
use std::path::Path;

/// Networks' tensors live under this prefix in checkpoints.
const NETWORKS: &str = "networks";

fn load_networks(
    fresh: ApfNetworks,
    checkpoint: &Checkpoint,
) -> Result<(ApfNetworks, NetworkOptimizers), TrainError> {
    let nets = checkpoint.module(fresh, NETWORKS)?.train();
    let under = |name: &str| format!("{NETWORKS}.optimizer.{name}");
    let optimizers = NetworkOptimizers {
        encoder: ModuleAdam::load_under(
            NETWORK_ADAM,
            &nets.encoder,
            checkpoint,
            &under("encoder"),
        )?,
        guidance: ModuleAdam::load_under(
            NETWORK_ADAM,
            &nets.guidance,
            checkpoint,
            &under("guidance"),
        )?,
        residual: ModuleAdam::load_under(
            NETWORK_ADAM,
            &nets.residual,
            checkpoint,
            &under("residual"),
        )?,
        accessory: ModuleAdam::load_under(
            NETWORK_ADAM,
            &nets.accessory,
            checkpoint,
            &under("accessory"),
        )?,
        embeddings: ModuleAdam::load_under(
            NETWORK_ADAM,
            &nets.embeddings,
            checkpoint,
            &under("embeddings"),
        )?,
    };
    Ok((nets, optimizers))
}

impl Method for ApfTrainer {
    const NAME: &'static str = "apf";
    const FORMAT: &'static str = "splatzoo-apf-1";
    const ABOUT: &'static str = "APF-GS: pedestrians in driving scenes (reliability-gated residual field, human/accessory decoupling, parent-child accessories)";
    type Config = ApfConfig;
    type Args = ApfArgs;

    fn overrides(args: &ApfArgs) -> Vec<String> {
        let mut sets = Vec::new();
        if args.no_decoupling {
            sets.push("decouple.enabled=false".into());
        }
        if let Some(v) = args.fixed_sigma {
            sets.push("gate.mode=\"fixed\"".into());
            sets.push(format!("gate.value={v}"));
        }
        if let Some(path) = &args.data {
            let path = toml::Value::from(path.display().to_string());
            sets.push(format!("data.path={path}"));
        }
        sets
    }

    fn new(config: ApfConfig, device: &Device) -> Result<Self, TrainError> {
        Ok(Self::assemble(config, device)?)
    }

    fn resume(
        config: ApfConfig,
        checkpoint: &Checkpoint,
        device: &Device,
    ) -> Result<Self, TrainError> {
        let mut trainer = Self::assemble(config, device)?;
        for node in trainer.scene.nodes_mut() {
            let name = node.name().to_owned();
            node.load(checkpoint, &name, device)?;
        }
        let fresh = trainer.nets.clone();
        let (nets, optimizers) = load_networks(fresh, checkpoint)?;
        trainer.nets = nets;
        trainer.optimizers = optimizers;
        trainer.step = checkpoint.meta_parsed("step")?;
        trainer.order = EpochOrder::load(checkpoint, trainer.capture.train.len())?;
        trainer.load_refresh(checkpoint, device)?;
        Ok(trainer)
    }

    fn steps(&self) -> usize {
        self.step
    }

    fn describe(&self) -> String {
        format!(
            "{} training and {} held-out images; {} Gaussians: {} humans, {} accessories, background {}",
            self.capture.train.len(),
            self.capture.test.len(),
            self.scene.gaussians(),
            self.scene.humans.len(),
            self.scene.accessories.len(),
            self.scene.background.gaussians(),
        )
    }

    fn decisions(&self) -> Vec<String> {
        let mut d = self.capture.decisions.clone();
        d.extend(self.scene.decisions.iter().cloned());
        d
    }

    /// Decoupling and the residual field by configuration (Table II's arms); an accessory node
    /// per tracked person by the mask rule (forced by `decouple.accessories`).
    fn modules(&self) -> Vec<ModuleChoice> {
        let c = &self.config;
        let mut modules = vec![
            ModuleChoice::configured("decoupling (Eq. 3)", "decouple.enabled", c.decouple.enabled),
            ModuleChoice::configured(
                "residual field and gate (Eq. 4–5)",
                "residual.enabled",
                c.residual.enabled,
            ),
        ];
        modules.extend(self.scene.modules.iter().cloned());
        modules
    }

    fn step(&mut self) -> Result<StepReport, TrainError> {
        Ok(self.train_step()?)
    }

    fn evaluate(&self, lpips: Option<&Lpips>) -> Result<Evaluation, TrainError> {
        let novel = self.score_set(&self.capture.test, lpips)?;
        // Reconstruction on every 6th training image (the same ones each time).
        let recon_views: Vec<usize> = self.capture.train.iter().step_by(6).copied().collect();
        let recon = self.score_set(&recon_views, lpips)?;
        let mut evaluation = Evaluation::new(self.step, novel.human_coarse)
            .with(
                "scores",
                "novel view (held-out timesteps), coarse human region",
            )
            .with("human_region", HUMAN_REGION)
            .with(
                "novel_view",
                serde_json::to_value(novel).expect("plain data"),
            )
            .with(
                "reconstruction",
                serde_json::to_value(recon).expect("plain data"),
            )
            .with("gaussians", self.scene.gaussians());
        if let Some((refined, prior)) = self.pose_errors() {
            evaluation = evaluation
                .with("mpjpe_mm", refined)
                .with("prior_mpjpe_mm", prior);
        }
        if let Some(trace) = self.sigma_trace() {
            evaluation = evaluation.with("sigma", sigma_summary(self, &trace));
        }
        Ok(evaluation)
    }

    /// The composed scene (every node, residuals and accessories) at each held-out view.
    fn render_held_out(&self) -> Result<usize, TrainError> {
        let nets = self.nets.valid();
        for &i in &self.capture.test {
            let view = &self.capture.views[i];
            let composed = self.compose_at(&nets, view.frame, &view.camera);
            read_back(&self.render_splats(&composed.splats, view.camera)?.color);
        }
        Ok(self.capture.test.len())
    }

    fn gaussians(&self) -> usize {
        self.scene.gaussians()
    }

    fn checkpoint(&self) -> Checkpoint {
        let mut c = Checkpoint::default();
        for node in self.scene.nodes() {
            node.save(&mut c, node.name());
        }
        c.put_module(NETWORKS, &self.nets);
        let o = &self.optimizers;
        let n = &self.nets;
        let under = |name: &str| format!("{NETWORKS}.optimizer.{name}");
        o.encoder.save_under(&n.encoder, &mut c, &under("encoder"));
        o.guidance
            .save_under(&n.guidance, &mut c, &under("guidance"));
        o.residual
            .save_under(&n.residual, &mut c, &under("residual"));
        o.accessory
            .save_under(&n.accessory, &mut c, &under("accessory"));
        o.embeddings
            .save_under(&n.embeddings, &mut c, &under("embeddings"));
        self.order.save(&mut c);
        self.save_refresh(&mut c, &self.background.device());
        c
    }

    /// `.ply` files (each node's canonical Gaussians and the whole scene posed at the first
    /// held-out timestep), held-out renders (render | truth), the σ trace and the ONNX graphs
    /// of `C`, `F_φ` and `D_ψ` checked in tract.
    fn finish(
        &self,
        run: &Path,
        say: &mut dyn Say,
    ) -> Result<serde_json::Map<String, serde_json::Value>, TrainError> {
        write_ply(&run.join("background.ply"), &self.scene.background.set)?;
        for (h, human) in self.scene.humans.iter().enumerate() {
            write_ply(
                &run.join(format!("human_{h}_canonical.ply")),
                human.node.canonical_set(),
            )?;
        }
        for a in &self.scene.accessories {
            write_ply(
                &run.join(format!("accessory_{}_canonical.ply", a.person)),
                a.node.canonical_set(),
            )?;
        }
        if let Some(&first) = self.capture.test.first() {
            let view = &self.capture.views[first];
            let composed = self.compose_at(&self.nets.valid(), view.frame, &view.camera);
            write_ply(
                &run.join(format!("scene_frame_{:04}.ply", view.frame)),
                &GaussianSet::from_splats(&composed.splats),
            )?;
        }
        let renders = run.join("renders");
        std::fs::create_dir_all(&renders).map_err(|e| {
            splatzoo_datasets::DatasetError::file(&renders, format!("cannot create ({e})"))
        })?;
        for &i in &self.capture.test {
            let (render, _) = self.render_view(i)?;
            let view = &self.capture.views[i];
            let pair = side_by_side(&[srgb_image(&render.color), srgb_image(&view.image)]);
            write_png(&renders.join(format!("{}.png", view.name)), &pair)?;
        }
        let mut summary = serde_json::Map::new();
        summary.insert("gaussians".into(), self.scene.gaussians().into());
        let nodes: Vec<String> = self
            .scene
            .nodes()
            .iter()
            .map(|n| n.name().to_owned())
            .collect();
        summary.insert("nodes".into(), nodes.into());
        let parents: Vec<serde_json::Value> = self
            .scene
            .accessories
            .iter()
            .map(|a| {
                serde_json::json!({
                    "person": a.person,
                    "joint": a.node.joint,
                    "true_joints": self.capture.people[a.person].true_parents,
                    "attach": a.node.attachment(),
                })
            })
            .collect();
        summary.insert("accessories".into(), parents.into());
        if let Some(trace) = self.sigma_trace() {
            summary.insert(
                "sigma_trace".into(),
                serde_json::to_value(&trace).expect("plain data"),
            );
        }
        let mut drifts = serde_json::Map::new();
        for a in &self.scene.accessories {
            if self.config.repose_frames == 0 {
                break;
            }
            let h = a.person;
            let motion = match &self.config.repose_poses {
                Some(path) => splatzoo_datasets::pose_sequence::load_driving_sequence(
                    path,
                    self.model.joint_count(),
                    self.model.shape_count(),
                    splatzoo_datasets::pose_sequence::UpAxis::Z,
                )?,
                None => crate::repose::default_motion(self, h, self.config.repose_frames),
            };
            let clip = crate::repose::repose(self, h, &motion, [256, 256])?;
            let dir = run.join(format!("reposed/person_{h}"));
            std::fs::create_dir_all(&dir).map_err(|e| {
                splatzoo_datasets::DatasetError::file(&dir, format!("cannot create ({e})"))
            })?;
            for (t, frame) in clip.frames.iter().enumerate() {
                write_png(&dir.join(format!("frame_{t:04}.png")), frame)?;
            }
            splatzoo_train::images::write_gif(&dir.join("animation.gif"), &clip.frames, 24)?;
            let first = clip
                .accessory_in_parent
                .first()
                .copied()
                .unwrap_or_default();
            let drift = clip
                .accessory_in_parent
                .iter()
                .map(|p| {
                    (0..3)
                        .map(|c| (p[c] - first[c]).abs())
                        .fold(0.0f32, f32::max)
                })
                .fold(0.0f32, f32::max);
            drifts.insert(format!("person_{h}"), f64::from(drift).into());
            say.say(&format!(
                "re-posed pedestrian {h} over {} frames with their accessory: {}",
                clip.frames.len(),
                dir.display()
            ));
        }
        if !drifts.is_empty() {
            summary.insert("reposed_accessory_drift_m".into(), drifts.into());
        }
        if self.config.onnx {
            let gaussians = self.scene.humans.first().map_or(1, |h| h.node.gaussians());
            let graphs = crate::onnx::export(
                &self.nets.valid(),
                &self.config.network,
                gaussians,
                256,
                &run.join("onnx"),
                &self.background.device(),
            )?;
            let mut errors = serde_json::Map::new();
            for g in &graphs {
                say.say(&format!(
                    "exported {} with test vectors; tract reproduces Burn to {:.1e} (relative)",
                    g.graph.display(),
                    g.relative_error
                ));
                if g.relative_error > 1e-3 {
                    return Err(crate::error::ApfError::input(
                        g.graph.display().to_string(),
                        format!(
                            "tract disagrees with Burn by {:.1e} (relative), above 1e-3",
                            g.relative_error
                        ),
                    )
                    .into());
                }
                let stem = g
                    .graph
                    .file_stem()
                    .and_then(|s| s.to_str())
                    .unwrap_or("graph");
                errors.insert(stem.to_owned(), f64::from(g.relative_error).into());
            }
            summary.insert("onnx_relative_error".into(), errors.into());
        }
        Ok(summary)
    }
}

/// σ statistics: mean inside and outside the corruption window, Spearman ρ against the injected
/// error, median and spread over every (person, frame).
fn sigma_summary(trainer: &ApfTrainer, trace: &[Vec<f64>]) -> serde_json::Value {
    let (mut inside, mut outside) = (Vec::new(), Vec::new());
    let (mut sigmas, mut errors) = (Vec::new(), Vec::new());
    for (h, row) in trace.iter().enumerate() {
        let person = &trainer.capture.people[h];
        for (t, &s) in row.iter().enumerate() {
            if person.corrupted.get(t).copied().unwrap_or(false) {
                inside.push(s);
            } else {
                outside.push(s);
            }
            sigmas.push(s);
            errors.push(person.injected.get(t).copied().unwrap_or(0.0));
        }
    }
    let mean = |v: &[f64]| (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64);
    let mut sorted = sigmas.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted.get(sorted.len() / 2).copied();
    let m = mean(&sigmas).unwrap_or(0.0);
    let std =
        (sigmas.iter().map(|s| (s - m).powi(2)).sum::<f64>() / sigmas.len().max(1) as f64).sqrt();
    serde_json::json!({
        "mean_in_corruption_window": mean(&inside),
        "mean_outside": mean(&outside),
        "spearman_vs_injected_error": spearman(&sigmas, &errors),
        "median": median,
        "std": std,
    })
}
