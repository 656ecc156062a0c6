//! NLF-GS training across identities as a [`Method`] (§3.7 of NLF-GS): each step generates one
//! training identity's avatar from its three input views, renders it through a scene graph
//! (the avatar as a [`GeneratedAvatar`] node) into the supervised views
//! ([`NlfTrainConfig::supervision`]) and descends the Eq. 5–7 loss with Adam. Every configured
//! identity is visited in turn ([`identity_at`]). Held-out identities are scored at the novel
//! views 60°/180°/300° (Table 3's protocol) and, as `at_input_views`, at the input views
//! 0°/120°/240° (the convention of Tables 5–7). The state (network, Adam moments by parameter
//! path) goes into one checkpoint; a resumed run continues bit-exactly on the CPU backends,
//! because nothing is random after initialisation.

use crate::NlfError;
use crate::baseline::mean_colour_avatar;
use crate::capture::capture_subjects;
use crate::config::{NlfTrainConfig, Supervision};
use crate::data::{NlfSubject, NlfView, posed_splats};
use crate::loss::{NlfLossInputs, nlf_loss};
use crate::network::{NlfGs, NlfInputs, PosedGaussians};
use crate::node::GeneratedAvatar;
use crate::onnx::{self, OnnxSamples};
use crate::query::Views;
use burn::module::Module;
use burn::tensor::{Device, Tensor};
use splatzoo_models::anchor::MeshAnchors;
use splatzoo_models::body::{builtin_body, load_body_model};
use splatzoo_models::networks::weights::{WeightFile, load_module, module_tensors};
use splatzoo_rasterizer::{ColorMode, RasterSettings, Render};
use splatzoo_train::TrainError;
use splatzoo_train::checkpoint::Checkpoint;
use splatzoo_train::config;
use splatzoo_train::harness::{
    Evaluation, Method, ModuleChoice, Say, ScoreSum, Scores, StepReport, checkpoint_config,
    read_back,
};
use splatzoo_train::images::{side_by_side, srgb_image, write_png};
use splatzoo_train::loss::{psnr, scalar, ssim};
use splatzoo_train::lpips::Lpips;
use splatzoo_train::module_adam::{ModuleAdam, NETWORK_ADAM};
use splatzoo_train::scene::{FrameQuery, SceneGraph};
use std::path::Path;
use std::time::Instant;

/// The training identity step `step` (1-based) trains on: each of the `identities` in turn,
/// so every configured identity is used once per `identities` steps.
pub fn identity_at(step: usize, identities: usize) -> usize {
    (step - 1) % identities
}

/// `train-nlf`'s shorthands (none yet beyond the harness's).
#[derive(clap::Args, Debug)]
pub struct NlfArgs {}

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
    /// Where the subjects came from (a real capture's conversion notes).
    decisions: Vec<String>,
}

impl NlfTrainer {
    fn with_model(
        config: NlfTrainConfig,
        model: NlfGs,
        optimizer: ModuleAdam,
        step: usize,
        device: &Device,
    ) -> Result<Self, TrainError> {
        let (train, test, faces, decisions) = match (&config.data.train, &config.data.test) {
            (Some(train_dir), Some(test_dir)) => {
                let body = match &config.data.body_model {
                    Some(path) => load_body_model(path)?,
                    None => builtin_body().model.clone(),
                };
                let load = |dir: &Path, limit: usize| {
                    let dataset = splatzoo_datasets::formats::load(dir, None)?;
                    capture_subjects(&dataset, &body, config.size, limit, device)
                };
                let (train, mut notes) = load(train_dir, config.train_subjects)?;
                let (test, test_notes) = load(test_dir, config.test_subjects)?;
                notes.extend(test_notes);
                notes.dedup();
                notes.insert(
                    0,
                    format!(
                        "subjects: {} training from {}, {} held out from {}, on the {} ({} \
                         vertices)",
                        train.len(),
                        train_dir.display(),
                        test.len(),
                        test_dir.display(),
                        config.data.body_model.as_ref().map_or_else(
                            || "built-in body".to_owned(),
                            |p| format!("body model {}", p.display())
                        ),
                        body.vertex_count()
                    ),
                );
                (train, test, body.faces.clone(), notes)
            }
            _ => {
                let train = (0..config.train_subjects as u64)
                    .map(|s| NlfSubject::synthetic(s, config.size, device))
                    .collect();
                let test = (0..config.test_subjects as u64)
                    .map(|s| NlfSubject::synthetic(config.test_seed + s, config.size, device))
                    .collect();
                (train, test, builtin_body().model.faces.clone(), Vec::new())
            }
        };
        let anchors = MeshAnchors::per_face(faces.len() / 3, config.network.gaussians_per_face);
        Ok(Self {
            config,
            model,
            optimizer,
            step,
            train,
            test,
            faces,
            anchors,
            decisions,
        })
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

    /// The views the loss is computed at.
    fn supervised<'a>(&self, subject: &'a NlfSubject) -> &'a [NlfView] {
        match self.config.supervision {
            Supervision::Inputs => &subject.inputs,
            Supervision::Targets => &subject.targets,
        }
    }

    /// Mean scores of `avatar_of`'s avatars over each view set of `view_sets` (one avatar per
    /// subject, rendered into every set); `keep` sees every render with its set, subject and
    /// view index.
    fn score(
        &self,
        subjects: &[NlfSubject],
        avatar_of: &dyn Fn(&NlfSubject) -> PosedGaussians,
        view_sets: &[ViewSet],
        lpips: Option<&Lpips>,
        keep: &mut Keep<'_>,
    ) -> Result<Vec<Scores>, TrainError> {
        let mut sums = vec![ScoreSum::default(); view_sets.len()];
        for (i, subject) in subjects.iter().enumerate() {
            let graph =
                SceneGraph::new().with(GeneratedAvatar::new(posed_splats(avatar_of(subject))));
            let background = subject.background_tensor();
            for (set, (views_of, sum)) in view_sets.iter().zip(&mut sums).enumerate() {
                for (k, view) in views_of(subject).iter().enumerate() {
                    let render = render_view(&graph, view, background.clone())?;
                    let image = render.color.clone().clamp(0.0, 1.0);
                    sum.add(
                        psnr(image.clone(), view.image.clone()),
                        scalar(ssim(image.clone(), view.image.clone())),
                        lpips.map(|l| scalar(l.distance(image, view.image.clone()))),
                    );
                    keep(set, i, k, &render)?;
                }
            }
        }
        Ok(sums.iter().map(ScoreSum::mean).collect())
    }

    /// The ONNX graphs, with the first held-out identity's views (all three, and two of them)
    /// and its fused features as test vectors.
    fn export_onnx(&self, dir: &Path) -> Result<onnx::OnnxFiles, NlfError> {
        let model = self.model();
        let subject = &self.test[0];
        let inputs = subject.nlf_inputs(&self.faces, &self.anchors);
        let images = inputs.images.clone();
        let [v, _, h, w] = images.dims();
        let network = &self.config.network;
        let fused = model.query(
            model.encoder.forward_inference(images.clone()),
            &inputs,
            network.fusion,
            network.occlusion_tolerance,
        );
        let samples = OnnxSamples {
            images: vec![images.clone(), images.slice([0..v - 1, 0..3, 0..h, 0..w])],
            fused: vec![fused],
        };
        onnx::export(&model, network, &self.anchors, &samples, dir)
    }
}

/// One view of a scene graph (the avatar) over `background`.
fn render_view(
    graph: &SceneGraph,
    view: &NlfView,
    background: Tensor<1>,
) -> Result<Render, TrainError> {
    let settings = RasterSettings::new(view.camera, ColorMode::Sh { degree: 0 });
    let query = FrameQuery {
        camera: &view.camera,
        frame: 0,
        time: 0.0,
    };
    Ok(graph.render(&query, background, &settings)?.render)
}

fn targets(subject: &NlfSubject) -> &[NlfView] {
    &subject.targets
}

fn inputs(subject: &NlfSubject) -> &[NlfView] {
    &subject.inputs
}

/// Selects one set of a subject's views.
type ViewSet = fn(&NlfSubject) -> &[NlfView];

/// Sees each render of [`NlfTrainer::score`]: view set, subject, view, render.
type Keep<'a> = dyn FnMut(usize, usize, usize, &Render) -> Result<(), TrainError> + 'a;

fn no_keep(_: usize, _: usize, _: usize, _: &Render) -> Result<(), TrainError> {
    Ok(())
}

impl Method for NlfTrainer {
    const NAME: &'static str = "nlf";
    const FORMAT: &'static str = "splatzoo-nlf-2";
    const ABOUT: &'static str = "Train NLF-GS across identities and evaluate on held-out ones";
    type Config = NlfTrainConfig;
    type Args = NlfArgs;

    fn overrides(_args: &NlfArgs) -> Vec<String> {
        Vec::new()
    }

    /// A fresh network (seeded by `config.seed`) and the identities.
    fn new(config: NlfTrainConfig, device: &Device) -> Result<Self, TrainError> {
        device.seed(config.seed);
        let mut model = NlfGs::new(&config.network, device);
        if let Some(path) = &config.encoder_weights {
            model.encoder.load_backbone(&WeightFile::read(path)?)?;
        }
        let model = model.train();
        Self::with_model(config, model, ModuleAdam::new(NETWORK_ADAM), 0, device)
    }

    /// Continues from `checkpoint` (network, Adam moments, step) with `config`, which may
    /// change the schedule but not the network.
    fn resume(
        config: NlfTrainConfig,
        checkpoint: &Checkpoint,
        device: &Device,
    ) -> Result<Self, TrainError> {
        let saved = checkpoint_config::<Self>(checkpoint)?;
        if saved.network != config.network {
            return Err(TrainError::Config(format!(
                "{}: the network configuration differs from the checkpoint's",
                checkpoint.origin
            )));
        }
        let step: usize = checkpoint.meta_parsed("step")?;
        let file = WeightFile::new(checkpoint.origin.clone(), checkpoint.tensors.clone());
        let model = load_module(NlfGs::new(&config.network, device), &file)?.train();
        let optimizer = ModuleAdam::load(NETWORK_ADAM, &model, checkpoint)?;
        Self::with_model(config, model, optimizer, step, device)
    }

    fn steps(&self) -> usize {
        self.step
    }

    fn decisions(&self) -> Vec<String> {
        self.decisions.clone()
    }

    /// The avatar has no optional scene module (a person over a plain background, decoded
    /// from three views); the encoder's image-colour branch is the one switch.
    fn modules(&self) -> Vec<ModuleChoice> {
        vec![ModuleChoice::configured(
            "image-colour branch of the decoder input",
            "network.image_colour",
            self.config.network.image_colour,
        )]
    }

    fn describe(&self) -> String {
        format!(
            "{} training and {} held-out identities at {}², {} Gaussians each, supervised at \
             the {} views",
            self.train.len(),
            self.test.len(),
            self.config.size,
            self.anchors.len(),
            match self.config.supervision {
                Supervision::Inputs => "input",
                Supervision::Targets => "target",
            }
        )
    }

    /// The two references: each Gaussian taking the mean colour of its projections, and the
    /// untrained network.
    fn baselines(&self, lpips: Option<&Lpips>) -> Result<Vec<(String, Scores)>, TrainError> {
        let mean_colour = self.score(
            &self.test,
            &|s| mean_colour_avatar(s, &self.faces, &self.anchors),
            &[targets],
            lpips,
            &mut no_keep,
        )?;
        let model = self.model();
        let untrained = self.score(
            &self.test,
            &|s| self.avatar(&model, s),
            &[targets],
            lpips,
            &mut no_keep,
        )?;
        Ok(vec![
            ("mean_colour".into(), mean_colour[0]),
            ("untrained".into(), untrained[0]),
        ])
    }

    /// One step on the next training identity; returns the loss.
    fn step(&mut self) -> Result<StepReport, TrainError> {
        let subject = &self.train[identity_at(self.step + 1, self.train.len())];
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
        let graph = SceneGraph::new().with(GeneratedAvatar::new(posed_splats(posed)));
        let background = subject.background_tensor().autodiff();
        let supervised = self.supervised(subject);
        let mut total: Option<Tensor<1>> = None;
        for view in supervised {
            let render = render_view(&graph, view, background.clone())?;
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
        let loss = total.ok_or_else(|| TrainError::Config("no supervised views".into()))?
            / supervised.len() as f64;
        let value = scalar(loss.clone().inner());
        self.step += 1;
        if !value.is_finite() {
            return Err(TrainError::NonFinite {
                step: self.step,
                value,
            });
        }
        let grads = loss.backward();
        let model = self.model.clone();
        self.model = self
            .optimizer
            .step(model, &grads, self.config.learning_rate);
        Ok(StepReport {
            loss: value,
            note: None,
        })
    }

    /// Held-out identities at the novel views (the headline) and at the input views.
    fn evaluate(&self, lpips: Option<&Lpips>) -> Result<Evaluation, TrainError> {
        let model = self.model();
        let avatar = |s: &NlfSubject| self.avatar(&model, s);
        let scores = self.score(&self.test, &avatar, &[targets, inputs], lpips, &mut no_keep)?;
        Ok(Evaluation::new(self.step, scores[0]).with(
            "at_input_views",
            serde_json::to_value(scores[1]).expect("plain data"),
        ))
    }

    /// Inference: each held-out identity's avatar decoded from its three input views, rendered
    /// at every novel view.
    fn render_held_out(&self) -> Result<usize, TrainError> {
        let model = self.model();
        let mut frames = 0;
        for subject in &self.test {
            let graph = SceneGraph::new().with(GeneratedAvatar::new(posed_splats(
                self.avatar(&model, subject),
            )));
            let background = subject.background_tensor();
            for view in &subject.targets {
                read_back(&render_view(&graph, view, background.clone())?.color);
                frames += 1;
            }
        }
        Ok(frames)
    }

    /// The Gaussians of one decoded avatar (one per anchor).
    fn gaussians(&self) -> usize {
        self.anchors.face_from_gaussian.len()
    }

    /// The network by parameter path, the Adam moments (`optimizer.<path>.exp_avg[_sq]`) and
    /// the network's configuration on its own (for `drive-nlf`).
    fn checkpoint(&self) -> Checkpoint {
        let mut checkpoint = Checkpoint {
            tensors: module_tensors(&self.model),
            ..Default::default()
        };
        self.optimizer.save(&self.model, &mut checkpoint);
        checkpoint.put_meta("network", config::to_toml(&self.config.network));
        checkpoint
    }

    /// Held-out renders (render | truth at every novel view) and the ONNX export, verified in
    /// tract.
    fn finish(
        &self,
        run: &Path,
        say: &mut dyn Say,
    ) -> Result<serde_json::Map<String, serde_json::Value>, TrainError> {
        let renders = run.join("renders");
        std::fs::create_dir_all(&renders).map_err(|e| {
            splatzoo_datasets::DatasetError::file(&renders, format!("cannot create ({e})"))
        })?;
        let model = self.model();
        let test = &self.test;
        self.score(
            test,
            &|s| self.avatar(&model, s),
            &[targets],
            None,
            &mut |_, i, k, render| {
                let pair = side_by_side(&[
                    srgb_image(&render.color),
                    srgb_image(&test[i].targets[k].image),
                ]);
                write_png(&renders.join(format!("subject_{i}_target_{k}.png")), &pair)?;
                Ok(())
            },
        )?;
        let mut summary = serde_json::Map::new();
        summary.insert("gaussians".into(), self.anchors.len().into());
        if self.config.onnx {
            let started = Instant::now();
            let files = self.export_onnx(&run.join("onnx"))?;
            let encoder = onnx::verify(&files.encoder, &files.encoder_vectors)?;
            let decoder = onnx::verify(&files.decoder, &files.decoder_vectors)?;
            say.say(&format!(
                "exported {} and {} with test vectors; tract reproduces Burn to {encoder:.1e} \
                 and {decoder:.1e} (relative) ({:.1} s)",
                files.encoder.display(),
                files.decoder.display(),
                started.elapsed().as_secs_f64()
            ));
            if encoder.max(decoder) > 1e-3 {
                return Err(NlfError::OnnxMismatch {
                    encoder: encoder as f64,
                    decoder: decoder as f64,
                }
                .into());
            }
            summary.insert(
                "onnx_relative_error".into(),
                serde_json::json!({"encoder": encoder, "decoder": decoder}),
            );
        }
        Ok(summary)
    }
}
