//! Adam (Kingma & Ba) over plain tensors, one learning rate per parameter group, with moment
//! buffers that follow the parameters when densification adds or removes rows (3DGS and gsplat
//! keep one Adam state per parameter tensor the same way).

use crate::checkpoint::{Checkpoint, CheckpointError};
use burn::tensor::{Int, Tensor};

/// Hyper-parameters shared by every group.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AdamConfig {
    pub beta1: f64,
    pub beta2: f64,
    pub epsilon: f64,
}

impl Default for AdamConfig {
    /// The 3DGS settings (ε = 1e-15).
    fn default() -> Self {
        Self {
            beta1: 0.9,
            beta2: 0.999,
            epsilon: 1e-15,
        }
    }
}

/// The state of one parameter tensor `[N, ...]`.
#[derive(Debug, Clone)]
pub struct AdamState<const D: usize> {
    pub first: Tensor<D>,
    pub second: Tensor<D>,
    /// Steps taken (for bias correction).
    pub steps: u64,
}

impl<const D: usize> AdamState<D> {
    pub fn new(like: &Tensor<D>) -> Self {
        Self {
            first: like.zeros_like(),
            second: like.zeros_like(),
            steps: 0,
        }
    }

    /// One step: returns the updated parameter.
    pub fn step(
        &mut self,
        param: Tensor<D>,
        grad: Tensor<D>,
        lr: f64,
        config: &AdamConfig,
    ) -> Tensor<D> {
        self.steps += 1;
        self.first = self.first.clone() * config.beta1 + grad.clone() * (1.0 - config.beta1);
        self.second =
            self.second.clone() * config.beta2 + grad.powi_scalar(2) * (1.0 - config.beta2);
        let t = self.steps as i32;
        let c1 = 1.0 - config.beta1.powi(t);
        let c2 = 1.0 - config.beta2.powi(t);
        let update =
            (self.first.clone() / c1) / ((self.second.clone() / c2).sqrt() + config.epsilon);
        param - update * lr
    }

    /// Keeps the rows `index` `[M]` (in that order).
    pub fn select(&mut self, index: Tensor<1, Int>) {
        self.first = self.first.clone().select(0, index.clone());
        self.second = self.second.clone().select(0, index);
    }

    /// Appends `count` rows of zero moments (new Gaussians start fresh, as in 3DGS).
    pub fn grow(&mut self, count: usize) {
        let mut shape = self.first.dims();
        shape[0] = count;
        let zeros = Tensor::<D>::zeros(shape, &self.first.device());
        self.first = Tensor::cat(vec![self.first.clone(), zeros.clone()], 0);
        self.second = Tensor::cat(vec![self.second.clone(), zeros], 0);
    }

    /// Multiplies row `i` of both moments by `factor[i]` (`[N]`; 0 restarts a row).
    pub fn scale_rows(&mut self, factor: Tensor<1>) {
        let mut shape = [1; D];
        shape[0] = factor.dims()[0];
        let factor = factor.reshape(shape);
        self.first = self.first.clone() * factor.clone();
        self.second = self.second.clone() * factor;
    }

    /// Restarts every row.
    pub fn reset(&mut self) {
        self.first = self.first.zeros_like();
        self.second = self.second.zeros_like();
    }

    /// Stores the moments as `{prefix}.exp_avg` / `{prefix}.exp_avg_sq` (PyTorch's names) and
    /// the step count as metadata.
    pub fn save(&self, checkpoint: &mut Checkpoint, prefix: &str) {
        checkpoint.put(&format!("{prefix}.exp_avg"), &self.first);
        checkpoint.put(&format!("{prefix}.exp_avg_sq"), &self.second);
        checkpoint.put_meta(&format!("{prefix}.step"), self.steps);
    }

    /// The state saved under `prefix` for a parameter shaped like `like`.
    pub fn load(
        checkpoint: &Checkpoint,
        prefix: &str,
        like: &Tensor<D>,
    ) -> Result<Self, CheckpointError> {
        let shape = like.dims().map(Some);
        let device = like.device();
        Ok(Self {
            first: checkpoint.tensor(&format!("{prefix}.exp_avg"), shape, &device)?,
            second: checkpoint.tensor(&format!("{prefix}.exp_avg_sq"), shape, &device)?,
            steps: checkpoint.meta_parsed(&format!("{prefix}.step"))?,
        })
    }
}
