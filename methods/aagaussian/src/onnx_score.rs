//! The real-model adapter (spec §3, adapter 1): a user's ONNX denoising UNet run in tract, a
//! pure-Rust ONNX runtime, behind [`ScoreModel`]. A TOML file describes the graph, since
//! exported UNets differ in names and types:
//!
//! ```toml
//! graph = "unet.onnx"                      # relative to this file
//! prompt_embeddings = "prompts.safetensors" # see crate::prompts for its keys
//! prediction = "epsilon"                   # or "v"
//! latent_scale = 1.0                       # z = latent_scale · encode(x) before noising
//! batch = 2                                # only for a graph with a fixed row count
//! outputs = ["eps_rgb", "eps_depth"]       # one per branch
//! [inputs]
//! samples = ["sample_rgb", "sample_depth"] # one per branch: 1 = RGB, 2 = RGB + depth (Eq. 5)
//! timestep = "timestep"
//! timestep_type = "int64"                  # or "int32", "float32"
//! encoder_hidden_states = "encoder_hidden_states"
//! [schedule]                               # the model's training schedule (defaults: SD-2)
//! beta_start = 0.00085
//! beta_end = 0.012
//! steps = 1000
//! zero_snr = false
//! ```
//!
//! Every graph input must be named in the TOML and every TOML name must be a graph input or
//! output: a mismatch is an error naming both lists. The graph runs on the host with the
//! stacked rows of one SDS call (`[N, C, H, W]` per branch, `[N]` timesteps, `[N, L, D]`
//! text); tract optimises it once per distinct set of input shapes and keeps the plan.
//! A pixel-space graph takes the renders themselves; a latent-space UNet (SD's 4 channels)
//! takes them through the run's `[vae]` encoder (`splatzoo_models::networks::vae`), scaled by
//! `latent_scale`.

use crate::error::AagError;
use crate::prompts::PromptEmbeddings;
use crate::schedule::NoiseSchedule;
use crate::score::{Conditioning, LatentBatch, Prediction, ScoreModel};
use serde::{Deserialize, Serialize};
use splatzoo_train::onnx::tract_io_names;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use tract_onnx::prelude::{
    Datum, Framework, InferenceFact, InferenceModel, InferenceModelExt, IntoRunnable, IntoTValue,
    TValue, TVec, Tensor as TractTensor, TypedRunnableModel,
};

/// The guidance model's description (the TOML above).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OnnxScoreConfig {
    pub graph: PathBuf,
    pub prompt_embeddings: PathBuf,
    pub prediction: Prediction,
    #[serde(default = "unit")]
    pub latent_scale: f64,
    /// A graph exported with a fixed row count: rows run in chunks of it (the last padded).
    #[serde(default)]
    pub batch: Option<usize>,
    pub outputs: Vec<String>,
    pub inputs: InputNames,
    #[serde(default)]
    pub schedule: ScheduleSpec,
}

fn unit() -> f64 {
    1.0
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InputNames {
    pub samples: Vec<String>,
    pub timestep: String,
    #[serde(default)]
    pub timestep_type: TimestepType,
    pub encoder_hidden_states: String,
}

#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TimestepType {
    #[default]
    Int64,
    Int32,
    Float32,
}

/// A `scaled_linear` schedule (SD's), optionally rescaled to zero terminal SNR.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ScheduleSpec {
    pub beta_start: f64,
    pub beta_end: f64,
    pub steps: usize,
    pub zero_snr: bool,
}

impl Default for ScheduleSpec {
    fn default() -> Self {
        Self {
            beta_start: 0.00085,
            beta_end: 0.012,
            steps: 1000,
            zero_snr: false,
        }
    }
}

/// What feeds one graph input.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Slot {
    Sample(usize),
    Timestep,
    Text,
}

/// A plan per distinct list of input shapes.
type Plans = HashMap<Vec<Vec<usize>>, Arc<TypedRunnableModel>>;

pub struct OnnxScore {
    pub config: OnnxScoreConfig,
    graph: PathBuf,
    model: InferenceModel,
    /// Per graph input, in graph order.
    slots: Vec<Slot>,
    /// Per branch, its graph output's index.
    outputs: Vec<usize>,
    schedule: NoiseSchedule,
    prompts: PromptEmbeddings,
    plans: Mutex<Plans>,
}

impl OnnxScore {
    /// Reads the TOML at `path`, its graph and its prompt embeddings.
    pub fn load(path: &Path) -> Result<Self, AagError> {
        let what = || format!("guidance config {}", path.display());
        let text = std::fs::read_to_string(path)
            .map_err(|e| AagError::input(what(), format!("cannot read ({e})")))?;
        let config: OnnxScoreConfig =
            toml::from_str(&text).map_err(|e| AagError::input(what(), e.to_string()))?;
        let folder = path.parent().unwrap_or(Path::new("."));
        Self::with_config(config, folder)
    }

    /// `config` with its files relative to `folder`.
    pub fn with_config(config: OnnxScoreConfig, folder: &Path) -> Result<Self, AagError> {
        let graph = folder.join(&config.graph);
        let gerr =
            |problem: String| AagError::input(format!("ONNX graph {}", graph.display()), problem);
        let branches = config.inputs.samples.len();
        if !(1..=2).contains(&branches) || config.outputs.len() != branches {
            return Err(gerr(format!(
                "the TOML names {branches} sample input(s) and {} output(s); 1 or 2 of each, \
                 one per branch",
                config.outputs.len()
            )));
        }
        let s = &config.schedule;
        if !(s.steps >= 2 && 0.0 < s.beta_start && s.beta_start <= s.beta_end && s.beta_end < 1.0) {
            return Err(gerr(format!(
                "schedule {s:?} is not a scaled_linear schedule"
            )));
        }
        if config.batch == Some(0) {
            return Err(gerr("batch must be at least 1".into()));
        }
        if !(config.latent_scale.is_finite() && config.latent_scale > 0.0) {
            return Err(gerr(format!(
                "latent_scale {} must be positive",
                config.latent_scale
            )));
        }
        let model = tract_onnx::onnx()
            .model_for_path(&graph)
            .map_err(|e| gerr(format!("cannot load ({e})")))?;
        let (input_names, output_names) =
            tract_io_names(&model).map_err(|e| gerr(e.to_string()))?;
        let names = &config.inputs;
        let mut slots = Vec::with_capacity(input_names.len());
        for name in &input_names {
            let slot = if let Some(k) = names.samples.iter().position(|s| s == name) {
                Slot::Sample(k)
            } else if *name == names.timestep {
                Slot::Timestep
            } else if *name == names.encoder_hidden_states {
                Slot::Text
            } else {
                return Err(gerr(format!(
                    "graph input `{name}` is not named in the TOML (graph inputs {input_names:?})"
                )));
            };
            slots.push(slot);
        }
        let wanted = names
            .samples
            .iter()
            .chain([&names.timestep, &names.encoder_hidden_states]);
        for name in wanted {
            if !input_names.contains(name) {
                return Err(gerr(format!(
                    "no graph input `{name}` (graph inputs {input_names:?})"
                )));
            }
        }
        let outputs = config
            .outputs
            .iter()
            .map(|name| {
                output_names.iter().position(|o| o == name).ok_or_else(|| {
                    gerr(format!(
                        "no graph output `{name}` (graph outputs {output_names:?})"
                    ))
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        let prompts = PromptEmbeddings::read(&folder.join(&config.prompt_embeddings))?;
        let base = NoiseSchedule::scaled_linear(s.beta_start, s.beta_end, s.steps);
        let schedule = if s.zero_snr { base.zero_snr() } else { base };
        Ok(Self {
            config,
            graph,
            model,
            slots,
            outputs,
            schedule,
            prompts,
            plans: Mutex::new(HashMap::new()),
        })
    }

    fn fail(&self, problem: impl std::fmt::Display) -> AagError {
        AagError::input(
            format!("ONNX graph {}", self.graph.display()),
            problem.to_string(),
        )
    }

    /// The plan for these input shapes (built and kept on first use).
    fn plan(&self, shapes: &[Vec<usize>]) -> Result<Arc<TypedRunnableModel>, AagError> {
        let mut plans = self
            .plans
            .lock()
            .expect("no panic while holding the plan cache");
        if let Some(plan) = plans.get(shapes) {
            return Ok(plan.clone());
        }
        let mut model = self.model.clone();
        for (ix, (slot, shape)) in self.slots.iter().zip(shapes).enumerate() {
            let dtype = match (slot, self.config.inputs.timestep_type) {
                (Slot::Timestep, TimestepType::Int64) => i64::datum_type(),
                (Slot::Timestep, TimestepType::Int32) => i32::datum_type(),
                _ => f32::datum_type(),
            };
            model
                .set_input_fact(ix, InferenceFact::dt_shape(dtype, shape))
                .map_err(|e| self.fail(e))?;
        }
        let plan = model
            .into_optimized()
            .and_then(|m| m.into_runnable())
            .map_err(|e| self.fail(format!("cannot prepare for inputs {shapes:?} ({e})")))?;
        plans.insert(shapes.to_vec(), plan.clone());
        Ok(plan)
    }
}

impl ScoreModel for OnnxScore {
    fn schedule(&self) -> &NoiseSchedule {
        &self.schedule
    }

    fn prediction(&self) -> Prediction {
        self.config.prediction
    }

    fn branches(&self) -> usize {
        self.config.inputs.samples.len()
    }

    fn latent_scale(&self) -> f64 {
        self.config.latent_scale
    }

    fn predict(
        &self,
        noisy: &[LatentBatch],
        t: &[usize],
        cond: &Conditioning,
    ) -> Result<Vec<LatentBatch>, AagError> {
        let Some(chunk) = self.config.batch else {
            return self.run_rows(noisy, t, cond);
        };
        let n = t.len();
        let mut out: Vec<LatentBatch> = noisy
            .iter()
            .map(|b| LatentBatch {
                shape: b.shape,
                data: Vec::with_capacity(b.data.len()),
            })
            .collect();
        for start in (0..n).step_by(chunk) {
            let end = (start + chunk).min(n);
            // Rows start..end, then the last row again until the chunk is full.
            let rows: Vec<usize> = (start..start + chunk).map(|r| r.min(end - 1)).collect();
            let pick = |b: &LatentBatch| {
                let mut picked = LatentBatch::zeros([chunk, b.shape[1], b.shape[2], b.shape[3]]);
                for (i, &r) in rows.iter().enumerate() {
                    picked.item_mut(i).copy_from_slice(b.item(r));
                }
                picked
            };
            let part: Vec<LatentBatch> = noisy.iter().map(pick).collect();
            let part_t: Vec<usize> = rows.iter().map(|&r| t[r]).collect();
            let part_cond = Conditioning {
                prompts: rows.iter().map(|&r| cond.prompts[r]).collect(),
                views: rows.iter().map(|&r| cond.views[r]).collect(),
                cameras: rows.iter().map(|&r| cond.cameras[r]).collect(),
            };
            let results = self.run_rows(&part, &part_t, &part_cond)?;
            for (o, r) in out.iter_mut().zip(&results) {
                o.data
                    .extend_from_slice(&r.data[..(end - start) * r.item_len()]);
            }
        }
        Ok(out)
    }
}

impl OnnxScore {
    /// One run of the graph on all of `noisy`'s rows.
    fn run_rows(
        &self,
        noisy: &[LatentBatch],
        t: &[usize],
        cond: &Conditioning,
    ) -> Result<Vec<LatentBatch>, AagError> {
        if noisy.len() != self.branches() {
            return Err(self.fail(format!(
                "{} branch(es) given, the TOML names {}",
                noisy.len(),
                self.branches()
            )));
        }
        let n = t.len();
        if cond.len() != n || noisy.iter().any(|b| b.shape[0] != n) {
            return Err(self.fail(format!(
                "{n} timesteps, {} prompt rows and batches {:?} disagree",
                cond.len(),
                noisy.iter().map(|b| b.shape).collect::<Vec<_>>()
            )));
        }
        let text_shape = vec![n, self.prompts.tokens, self.prompts.channels];
        let shapes: Vec<Vec<usize>> = self
            .slots
            .iter()
            .map(|slot| match slot {
                Slot::Sample(k) => noisy[*k].shape.to_vec(),
                Slot::Timestep => vec![n],
                Slot::Text => text_shape.clone(),
            })
            .collect();
        let plan = self.plan(&shapes)?;
        let text = self.prompts.stacked(cond);
        let mut values: TVec<TValue> = TVec::new();
        for (slot, shape) in self.slots.iter().zip(&shapes) {
            let tensor = match slot {
                Slot::Sample(k) => TractTensor::from_shape(shape, &noisy[*k].data),
                Slot::Text => TractTensor::from_shape(shape, &text),
                Slot::Timestep => match self.config.inputs.timestep_type {
                    TimestepType::Int64 => {
                        let v: Vec<i64> = t.iter().map(|&s| s as i64).collect();
                        TractTensor::from_shape(shape, &v)
                    }
                    TimestepType::Int32 => {
                        let v: Vec<i32> = t.iter().map(|&s| s as i32).collect();
                        TractTensor::from_shape(shape, &v)
                    }
                    TimestepType::Float32 => {
                        let v: Vec<f32> = t.iter().map(|&s| s as f32).collect();
                        TractTensor::from_shape(shape, &v)
                    }
                },
            }
            .map_err(|e| self.fail(e))?;
            values.push(tensor.into_tvalue());
        }
        let outputs = plan
            .run(values)
            .map_err(|e| self.fail(format!("run failed ({e})")))?;
        self.outputs
            .iter()
            .zip(&self.config.outputs)
            .zip(noisy)
            .map(|((&ix, name), input)| {
                let view = outputs[ix]
                    .to_plain_array_view::<f32>()
                    .map_err(|e| self.fail(e))?;
                if view.shape() != input.shape {
                    return Err(self.fail(format!(
                        "output `{name}` is {:?}, expected its sample's {:?}",
                        view.shape(),
                        input.shape
                    )));
                }
                Ok(LatentBatch {
                    shape: input.shape,
                    data: view.iter().copied().collect(),
                })
            })
            .collect()
    }
}
