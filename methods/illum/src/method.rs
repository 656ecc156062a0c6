//! The two stages as one harness [`Method`]: steps `[0, S₁)` train stage 1, step `S₁` hands
//! the refined body's Gaussians to stage 2 (§3.1 → §3.2), which runs to `iterations`
//! (without the two-stage schedule, stage 2 starts at step 0 from the unrefined body). One
//! checkpoint holds every part's state; a resumed run rebuilds the capture from its seed and
//! continues bit-exactly on the CPU.

use crate::config::IllumConfig;
use crate::eval::IllumScores;
use crate::light_volume::LightVolume;
use crate::trainer::{HUMAN, IllumTrainer, SCENE};
use burn::module::Module;
use burn::tensor::{Device, Int, Tensor};
use splatzoo_train::TrainError;
use splatzoo_train::adam::AdamState;
use splatzoo_train::checkpoint::{Checkpoint, CheckpointError};
use splatzoo_train::harness::{
    EpochOrder, Evaluation, Method, ModuleChoice, Say, Scores, StepReport,
};
use splatzoo_train::lpips::Lpips;
use splatzoo_train::module_adam::{ModuleAdam, NETWORK_ADAM};
use splatzoo_train::scene::SceneNode;
use std::path::Path;

/// Shorthands for the Table-4 arms and the baseline (each one `--set` line).
#[derive(Debug, Clone, Default, clap::Args)]
pub struct IllumArgs {
    /// Without the light volume (no PBR on the human: a per-Gaussian colour).
    #[arg(long)]
    pub no_light_volume: bool,
    /// Without the shadow decoder.
    #[arg(long)]
    pub no_shadow: bool,
    /// Without the probe smoothness L_probe (Eq. 13).
    #[arg(long)]
    pub no_probe_smoothness: bool,
    /// Without the two-stage schedule (stage 2 from the unrefined body).
    #[arg(long)]
    pub no_two_stage: bool,
    /// The skinned-avatar baseline: no PBR, no light volume, no shadow decoder.
    #[arg(long)]
    pub baseline: bool,
}

pub struct Illum {
    pub trainer: IllumTrainer,
    decisions: Vec<String>,
}

/// A module's state: its tensors under `prefix` and its Adam moments under
/// `prefix.optimizer`.
fn put_network<M: Module>(c: &mut Checkpoint, prefix: &str, module: &M, adam: &ModuleAdam) {
    c.put_module(prefix, module);
    adam.save_under(module, c, &format!("{prefix}.optimizer"));
}

/// The light volume under `volume.` in `c`. A checkpoint written before the shared
/// environment existed has no `volume.environment`: it resumes with the zero environment it
/// had (the trainer's optimiser state for it stays fresh, as it was, never stepped), unless the
/// configuration asks for a shared environment, which is refused by name.
fn load_volume(
    c: &Checkpoint,
    fresh: LightVolume,
    shared_environment: bool,
) -> Result<LightVolume, TrainError> {
    if c.tensors.contains_key("volume.environment") {
        return Ok(c.module(fresh, "volume")?);
    }
    if shared_environment {
        return Err(TrainError::Config(format!(
            "{}: `volume.environment` missing: the checkpoint predates \
             light.shared_environment; resume it with light.shared_environment = false",
            c.origin
        )));
    }
    let mut volume_only = Checkpoint {
        origin: c.origin.clone(),
        ..Checkpoint::default()
    };
    volume_only.tensors = c
        .tensors
        .iter()
        .filter(|(name, _)| name.starts_with("volume."))
        .map(|(name, value)| (name.clone(), value.clone()))
        .collect();
    volume_only.put("volume.environment", &fresh.environment.val());
    Ok(volume_only.module(fresh, "volume")?)
}

fn load_network<M: Module>(
    c: &Checkpoint,
    prefix: &str,
    module: M,
) -> Result<(M, ModuleAdam), TrainError> {
    let module = c.module(module, prefix)?.train();
    let adam = ModuleAdam::load_under(NETWORK_ADAM, &module, c, &format!("{prefix}.optimizer"))?;
    Ok((module, adam))
}

fn int_as_float(t: &Tensor<2, Int>) -> Tensor<2> {
    t.clone().float()
}

fn load_int(
    c: &Checkpoint,
    name: &str,
    shape: [Option<usize>; 2],
    device: &Device,
) -> Result<Tensor<2, Int>, CheckpointError> {
    Ok(c.tensor::<2>(name, shape, device)?.round().int())
}

impl Illum {
    /// A fresh run on a capture already built from `config.data` (shared by the arms of
    /// `ablate-illum` and the bench).
    pub fn from_capture(
        config: IllumConfig,
        capture: crate::data::IllumCapture,
        device: &Device,
    ) -> Result<Self, TrainError> {
        Ok(Self::around(IllumTrainer::from_capture(
            config, capture, device,
        )?))
    }

    /// The method around a freshly built trainer. Without stage 1 the hand-over happens at
    /// construction, and so does F_vis's warm-up.
    fn around(mut trainer: IllumTrainer) -> Self {
        if trainer.stage2.is_some() {
            trainer.visibility_warmup();
        }
        let decisions = Self::decisions_for(&trainer);
        Self { trainer, decisions }
    }

    fn decisions_for(trainer: &IllumTrainer) -> Vec<String> {
        let c = &trainer.config;
        let grid = trainer.volume.grid();
        let mut lines = trainer.capture.decisions.clone();
        let truth = trainer.capture.truth.as_ref();
        lines.push(format!(
            "capture: {} frames ({} trained, {} held out), {} relit frames, {} novel-pose \
             frames, {} scene points",
            trainer.capture.frames.len(),
            trainer.train.len(),
            trainer.capture.test_frames().count(),
            truth.map_or(0, |t| t.relit.len()),
            truth.map_or(0, |t| t.novel_pose.len()),
            trainer.capture.scene_points.len()
        ));
        lines.push(match (c.poses, truth) {
            (crate::config::PoseTrack::True, Some(_)) => {
                "poses: the true motion (poses = \"true\")".to_owned()
            }
            (crate::config::PoseTrack::Prior, _) => {
                "poses: the capture's prior track (poses = \"prior\")".to_owned()
            }
            (crate::config::PoseTrack::True, None) => {
                "poses: the capture's own track (poses = \"true\" asks for a truth a capture on \
                 disk does not have)"
                    .to_owned()
            }
        });
        lines.extend([
            format!(
                "human: built-in body, {} subdivision(s), {} vertices, {} face Gaussians",
                c.stage1.body.subdivisions,
                trainer.mesh.vertex_count(),
                trainer.mesh.face_count()
            ),
            format!(
                "light volume: {}×{}×{} probes {:.3} m apart over the person's trajectory, SH \
                 degree {}, latents of {}",
                grid.dims[0],
                grid.dims[1],
                grid.dims[2],
                grid.spacing,
                c.light.degree,
                c.light.latent_dim
            ),
        ]);
        lines.push(if c.ablation.two_stage {
            format!(
                "schedule: stage 1 for {} steps, stage 2 to step {}",
                c.stage2_start(),
                c.iterations
            )
        } else {
            format!(
                "schedule: no stage 1 (ablation.two_stage = false); stage 2 for {} steps",
                c.iterations
            )
        });
        lines.push(if c.ablation.light_volume {
            format!(
                "shading: PBR by the light volume, N_l = {} ({} in evaluation), visibility {:?}",
                c.stage2.samples, c.stage2.eval_samples, c.visibility.source
            )
        } else {
            "shading: none (ablation.light_volume = false: a per-Gaussian colour)".into()
        });
        lines.push(if c.ablation.shadow_decoder() {
            "shadows: decoder F_ao on scene Gaussians in the person's box".into()
        } else {
            "shadows: none (the shadow decoder is off: its module line says why)".into()
        });
        lines
    }
}

impl Method for Illum {
    const NAME: &'static str = "illum";
    const FORMAT: &'static str = "splatzoo-illum-1";
    const ABOUT: &'static str = "Illum: a 3DGS scene and a PBR human sharing a light volume of SH \
                                 probes, with a shadow decoder, from a monocular video";
    type Config = IllumConfig;
    type Args = IllumArgs;

    fn overrides(args: &IllumArgs) -> Vec<String> {
        let mut sets = Vec::new();
        let mut on = |flag: bool, set: &str| {
            if flag {
                sets.push(set.to_owned());
            }
        };
        on(
            args.no_light_volume || args.baseline,
            "ablation.light_volume=false",
        );
        on(args.no_shadow || args.baseline, "ablation.shadow=false");
        on(args.no_probe_smoothness, "weights.probe=0.0");
        on(args.no_two_stage, "ablation.two_stage=false");
        sets
    }

    fn new(config: IllumConfig, device: &Device) -> Result<Self, TrainError> {
        Ok(Self::around(IllumTrainer::new(config, device)?))
    }

    fn resume(config: IllumConfig, c: &Checkpoint, device: &Device) -> Result<Self, TrainError> {
        let mut t = IllumTrainer::new(config, device)?;
        let a = t.autodiff.clone();
        t.step = c.meta_parsed("step")?;
        t.scene.load(c, SCENE, device)?;
        t.scene_neighbours = load_int(
            c,
            "scene.neighbours",
            [
                Some(t.scene.gaussians()),
                Some(t.config.light.shadow_neighbours),
            ],
            &a,
        )?;
        let body = t.body.clone();
        (t.body.offset, t.offset_adam) = load_network(c, "body.offset", body.offset)?;
        (t.body.colour, t.colour_adam) = load_network(c, "body.colour", body.colour)?;
        let in_plane = c.tensor::<2>("body.in_plane", [Some(t.mesh.face_count()), Some(3)], &a)?;
        t.in_plane_adam = AdamState::load(c, "body.in_plane", &in_plane.clone().inner())?;
        t.body.in_plane = burn::module::Param::from_tensor(in_plane.require_grad());
        let with_environment = c.tensors.contains_key("volume.environment");
        t.volume = load_volume(c, t.volume.clone(), t.config.light.shared_environment)?.train();
        t.sh_adam = AdamState::load(c, "volume.sh", &t.volume.sh.val().inner())?;
        if with_environment {
            t.environment_adam =
                AdamState::load(c, "volume.environment", &t.volume.environment.val().inner())?;
        }
        t.latent_adam = AdamState::load(c, "volume.latent", &t.volume.latent.val().inner())?;
        (t.decoder, t.decoder_adam) = load_network(c, "decoder", t.decoder.clone())?;
        (t.visibility, t.visibility_adam) = load_network(c, "visibility", t.visibility.clone())?;
        (t.materials, t.materials_adam) = load_network(c, "materials", t.materials.clone())?;
        if c.meta("stage2").is_ok() {
            let mut stage2 = match t.stage2.take() {
                Some(stage2) => stage2,
                None => t.hand_over(),
            };
            stage2.human.load(c, HUMAN, device)?;
            let n = stage2.human.gaussians();
            let joints = t.mesh.model.joint_count();
            stage2.binding.skin_weights =
                c.tensor::<2>("binding.skin_weights", [Some(n), Some(joints)], &a)?;
            stage2.binding.transfer.indices = load_int(c, "binding.indices", [Some(n), None], &a)?;
            stage2.binding.transfer.weights =
                c.tensor::<2>("binding.weights", [Some(n), None], &a)?;
            t.stage2 = Some(stage2);
        } else {
            t.stage2 = None;
        }
        t.order = EpochOrder::load(c, t.train.len())?;
        let decisions = Self::decisions_for(&t);
        Ok(Self {
            trainer: t,
            decisions,
        })
    }

    fn steps(&self) -> usize {
        self.trainer.step
    }

    fn describe(&self) -> String {
        let t = &self.trainer;
        let first = &t.capture.frames[t.train[0]].camera;
        format!(
            "{} training frames at {}×{}; scene {} Gaussians, human {} Gaussians, {} probes",
            t.train.len(),
            first.width,
            first.height,
            t.scene.gaussians(),
            t.stage2
                .as_ref()
                .map_or(t.mesh.face_count(), |s| s.human.gaussians()),
            t.volume.grid().count()
        )
    }

    fn decisions(&self) -> Vec<String> {
        self.decisions.clone()
    }

    fn step(&mut self) -> Result<StepReport, TrainError> {
        let t = &mut self.trainer;
        let mut note = None;
        let mut losses = if t.step < t.config.stage2_start() {
            t.stage1_step()?
        } else {
            if t.stage2.is_none() {
                let stage2 = t.hand_over();
                note = Some(format!(
                    "stage 2: {} face Gaussians freed in canonical space{}",
                    stage2.human.gaussians(),
                    if t.config.ablation.light_volume {
                        " with albedo sRGB⁻¹(c)"
                    } else {
                        ""
                    }
                ));
                t.stage2 = Some(stage2);
                if let Some((first, last)) = t.visibility_warmup() {
                    note = note.map(|n| {
                        format!(
                            "{n}; F_vis warmed up for {} steps on the training poses (BCE {first:.3} → {last:.3})",
                            t.config.visibility.warmup
                        )
                    });
                }
            }
            t.stage2_step()?
        };
        t.step += 1;
        Ok(StepReport {
            loss: losses.total,
            note: note.or(losses.note.take()),
        })
    }

    fn evaluate(&self, lpips: Option<&Lpips>) -> Result<Evaluation, TrainError> {
        let scores: IllumScores = self.trainer.evaluate(lpips)?;
        Ok(Evaluation::new(
            self.trainer.step,
            Scores {
                psnr: scores.psnr,
                ssim: scores.ssim,
                lpips: scores.lpips,
            },
        )
        .with("scores", "held-out frames, full image")
        .with("illum", serde_json::to_value(&scores).expect("plain data")))
    }

    /// The shadow decoder as the capture calls for it ([`crate::needs`]); the other modules by
    /// their switches (the ablations).
    fn modules(&self) -> Vec<ModuleChoice> {
        let a = &self.trainer.config.ablation;
        vec![
            ModuleChoice::configured(
                "light volume and PBR shading (Eq. 4–7)",
                "ablation.light_volume",
                a.light_volume,
            ),
            self.trainer.shadow_choice.clone(),
            ModuleChoice::configured("stage 1 (refined body)", "ablation.two_stage", a.two_stage),
        ]
    }

    fn render_held_out(&self) -> Result<usize, TrainError> {
        Ok(self.trainer.render_held_out()?)
    }

    fn gaussians(&self) -> usize {
        self.trainer.gaussians()
    }

    fn checkpoint(&self) -> Checkpoint {
        let t = &self.trainer;
        let mut c = Checkpoint::default();
        t.scene.save(&mut c, SCENE);
        c.put("scene.neighbours", &int_as_float(&t.scene_neighbours));
        put_network(&mut c, "body.offset", &t.body.offset, &t.offset_adam);
        put_network(&mut c, "body.colour", &t.body.colour, &t.colour_adam);
        c.put("body.in_plane", &t.body.in_plane.val());
        t.in_plane_adam.save(&mut c, "body.in_plane");
        c.put_module("volume", &t.volume);
        t.sh_adam.save(&mut c, "volume.sh");
        t.environment_adam.save(&mut c, "volume.environment");
        t.latent_adam.save(&mut c, "volume.latent");
        put_network(&mut c, "decoder", &t.decoder, &t.decoder_adam);
        put_network(&mut c, "visibility", &t.visibility, &t.visibility_adam);
        put_network(&mut c, "materials", &t.materials, &t.materials_adam);
        if let Some(stage2) = &t.stage2 {
            c.put_meta("stage2", 1);
            stage2.human.save(&mut c, HUMAN);
            c.put("binding.skin_weights", &stage2.binding.skin_weights);
            c.put(
                "binding.indices",
                &int_as_float(&stage2.binding.transfer.indices),
            );
            c.put("binding.weights", &stage2.binding.transfer.weights);
        }
        t.order.save(&mut c);
        c
    }

    fn finish(
        &self,
        run: &Path,
        say: &mut dyn Say,
    ) -> Result<serde_json::Map<String, serde_json::Value>, TrainError> {
        crate::export::write_outputs(&self.trainer, run, say)
    }
}
