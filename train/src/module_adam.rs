//! Adam over every float parameter of a Burn module, its moments keyed by the parameter's
//! dotted field path (`encoder.lateral.0.weight`) rather than by Burn's per-process parameter
//! id, so that they go into a [`Checkpoint`] under PyTorch-like names
//! (`optimizer.<path>.exp_avg`, `.exp_avg_sq`) and a network rebuilt from that checkpoint
//! resumes exactly. The update is [`AdamState::step`], the one the Gaussian optimiser uses.

use crate::adam::{AdamConfig, AdamState};
use crate::checkpoint::{Checkpoint, CheckpointError};
use burn::module::{Module, ModuleMapper, Param};
use burn::tensor::Gradients;
use burn::tensor::{Tensor, TensorData};
use std::collections::BTreeMap;

/// PyTorch's defaults (β = 0.9, 0.999; ε = 1e-8).
pub const NETWORK_ADAM: AdamConfig = AdamConfig {
    beta1: 0.9,
    beta2: 0.999,
    epsilon: 1e-8,
};

#[derive(Debug, Clone)]
pub struct ModuleAdam {
    pub config: AdamConfig,
    /// Flattened moments per parameter path.
    states: BTreeMap<String, AdamState<1>>,
    /// Moments read from a checkpoint, placed on the parameter's device at its next step.
    pending: BTreeMap<String, (Vec<f32>, Vec<f32>)>,
    pending_steps: u64,
}

impl ModuleAdam {
    pub fn new(config: AdamConfig) -> Self {
        Self {
            config,
            states: BTreeMap::new(),
            pending: BTreeMap::new(),
            pending_steps: 0,
        }
    }

    /// One step on every parameter of `module` that has a gradient in `grads`.
    pub fn step<M: Module>(&mut self, module: M, grads: &Gradients, lr: f64) -> M {
        struct Step<'a> {
            path: Vec<String>,
            adam: &'a mut ModuleAdam,
            grads: &'a Gradients,
            lr: f64,
        }
        impl ModuleMapper for Step<'_> {
            fn enter_module(&mut self, name: &str, _: &str) {
                self.path.push(name.to_owned());
            }
            fn exit_module(&mut self, _: &str, _: &str) {
                self.path.pop();
            }
            fn map_float<const D: usize>(&mut self, param: Param<Tensor<D>>) -> Param<Tensor<D>> {
                let value = param.val();
                let Some(grad) = value.grad(self.grads) else {
                    return param;
                };
                let shape = value.dims();
                let n = shape.iter().product::<usize>();
                let flat = value.inner().reshape([n]);
                let path = self.path.join(".");
                let adam = &mut *self.adam;
                let state = adam.states.entry(path.clone()).or_insert_with(|| {
                    match adam.pending.remove(&path) {
                        Some((first, second)) => {
                            let device = flat.device();
                            AdamState {
                                first: Tensor::from_data(TensorData::new(first, [n]), &device),
                                second: Tensor::from_data(TensorData::new(second, [n]), &device),
                                steps: adam.pending_steps,
                            }
                        }
                        None => AdamState::new(&flat),
                    }
                });
                let updated = state.step(flat, grad.reshape([n]), self.lr, &adam.config);
                param.map(|_| updated.reshape(shape).autodiff().require_grad())
            }
        }
        module.map(&mut Step {
            path: Vec::new(),
            adam: self,
            grads,
            lr,
        })
    }

    /// Writes the moments as `optimizer.<path>.exp_avg` and `.exp_avg_sq`, in the shapes of
    /// `module`'s parameters, the step count as `optimizer.steps` and the parameters that have
    /// moments (those that have had a gradient) as `optimizer.paths`.
    pub fn save<M: Module>(&self, module: &M, checkpoint: &mut Checkpoint) {
        self.save_under(module, checkpoint, "optimizer");
    }

    /// [`Self::save`] under `prefix` instead of `optimizer` (a method with several networks,
    /// each with its own optimiser, gives each its own prefix).
    pub fn save_under<M: Module>(&self, module: &M, checkpoint: &mut Checkpoint, prefix: &str) {
        let shapes = shapes(module);
        let mut steps = self.pending_steps;
        let mut put = |path: &str, first: Vec<f32>, second: Vec<f32>| {
            let shape = shapes[path].clone();
            let name = |suffix: &str| format!("{prefix}.{path}.{suffix}");
            checkpoint
                .tensors
                .insert(name("exp_avg"), (shape.clone(), first));
            checkpoint
                .tensors
                .insert(name("exp_avg_sq"), (shape, second));
        };
        for (path, state) in &self.states {
            put(
                path,
                crate::host_f32(&state.first),
                crate::host_f32(&state.second),
            );
            steps = state.steps;
        }
        for (path, (first, second)) in &self.pending {
            put(path, first.clone(), second.clone());
        }
        checkpoint.put_meta(&format!("{prefix}.steps"), steps);
        // Which parameters have moments: one that never had a gradient has none yet.
        let paths: Vec<&str> = self
            .states
            .keys()
            .chain(self.pending.keys())
            .map(String::as_str)
            .collect();
        checkpoint.put_meta(&format!("{prefix}.paths"), paths.join(","));
    }

    /// The moments [`save`](Self::save) wrote, for every parameter of `module`, each checked
    /// against its parameter's shape.
    pub fn load<M: Module>(
        config: AdamConfig,
        module: &M,
        checkpoint: &Checkpoint,
    ) -> Result<Self, CheckpointError> {
        Self::load_under(config, module, checkpoint, "optimizer")
    }

    /// What [`Self::save_under`] wrote under `prefix`.
    pub fn load_under<M: Module>(
        config: AdamConfig,
        module: &M,
        checkpoint: &Checkpoint,
        prefix: &str,
    ) -> Result<Self, CheckpointError> {
        let entry = |name: &str, problem: String| CheckpointError::Entry {
            file: checkpoint.origin.clone(),
            name: name.to_owned(),
            problem,
        };
        // Checkpoints that list their parameters with moments hold exactly those; older ones
        // hold every parameter's.
        let listed: Option<Vec<String>> =
            checkpoint
                .metadata
                .get(&format!("{prefix}.paths"))
                .map(|p| {
                    p.split(',')
                        .filter(|s| !s.is_empty())
                        .map(str::to_owned)
                        .collect()
                });
        let shapes = shapes(module);
        if let Some(listed) = &listed
            && let Some(unknown) = listed.iter().find(|p| !shapes.contains_key(*p))
        {
            return Err(entry(
                &format!("{prefix}.paths"),
                format!("`{unknown}` is not a parameter of the network"),
            ));
        }
        let mut pending = BTreeMap::new();
        for (path, shape) in shapes {
            if listed.as_ref().is_some_and(|l| !l.contains(&path)) {
                continue;
            }
            let read = |suffix: &str| -> Result<Vec<f32>, CheckpointError> {
                let name = format!("{prefix}.{path}.{suffix}");
                let (stored, values) = checkpoint
                    .tensors
                    .get(&name)
                    .ok_or_else(|| entry(&name, "missing".into()))?;
                if stored != &shape {
                    return Err(entry(
                        &name,
                        format!("shape {stored:?}, expected {shape:?}"),
                    ));
                }
                if let Some(bad) = values.iter().position(|v| !v.is_finite()) {
                    return Err(entry(
                        &name,
                        format!("non-finite value at flat index {bad}"),
                    ));
                }
                Ok(values.clone())
            };
            pending.insert(path.clone(), (read("exp_avg")?, read("exp_avg_sq")?));
        }
        Ok(Self {
            config,
            states: BTreeMap::new(),
            pending,
            pending_steps: checkpoint.meta_parsed(&format!("{prefix}.steps"))?,
        })
    }
}

/// Every float parameter's shape under its dotted path (no values are read).
fn shapes<M: Module>(module: &M) -> BTreeMap<String, Vec<usize>> {
    struct Collect {
        path: Vec<String>,
        out: BTreeMap<String, Vec<usize>>,
    }
    impl burn::module::ModuleVisitor for Collect {
        fn enter_module(&mut self, name: &str, _: &str) {
            self.path.push(name.to_owned());
        }
        fn exit_module(&mut self, _: &str, _: &str) {
            self.path.pop();
        }
        fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
            self.out
                .insert(self.path.join("."), param.val().dims().to_vec());
        }
    }
    let mut c = Collect {
        path: Vec::new(),
        out: BTreeMap::new(),
    };
    module.visit(&mut c);
    c.out
}
