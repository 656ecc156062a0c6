//! Training views visited in shuffled epochs: each epoch is a fresh permutation drawn from a
//! seeded generator, taken from the back one view per step. Its state (the generator and what
//! is left of the epoch) goes into checkpoints as the metadata `rng` and `order`, so a resumed
//! run visits the same views in the same order.

use crate::checkpoint::{Checkpoint, CheckpointError};
use splatzoo_datasets::synth::rng::Rng;

#[derive(Debug, Clone, PartialEq)]
pub struct EpochOrder {
    rng: Rng,
    /// Views still to visit in this epoch (taken from the back).
    left: Vec<usize>,
}

impl EpochOrder {
    pub fn new(seed: u64) -> Self {
        Self {
            rng: Rng(seed),
            left: Vec::new(),
        }
    }

    /// The next of `views` views, starting a new epoch when this one is done.
    pub fn next(&mut self, views: usize) -> usize {
        if self.left.is_empty() {
            self.left = (0..views).collect();
            self.rng.shuffle(&mut self.left);
        }
        self.left.pop().expect("an epoch has at least one view")
    }

    pub fn save(&self, checkpoint: &mut Checkpoint) {
        checkpoint.put_meta("rng", self.rng.0);
        let left: Vec<String> = self.left.iter().map(|i| i.to_string()).collect();
        checkpoint.put_meta("order", left.join(","));
    }

    /// The state [`Self::save`] wrote, for a run over `views` views.
    pub fn load(checkpoint: &Checkpoint, views: usize) -> Result<Self, CheckpointError> {
        let left = checkpoint
            .meta("order")?
            .split(',')
            .filter(|s| !s.is_empty())
            .map(|s| s.parse::<usize>().ok().filter(|&i| i < views))
            .collect::<Option<Vec<_>>>()
            .ok_or_else(|| CheckpointError::Entry {
                file: checkpoint.origin.clone(),
                name: "order".into(),
                problem: format!("expected view indices below {views}"),
            })?;
        Ok(Self {
            rng: Rng(checkpoint.meta_parsed("rng")?),
            left,
        })
    }
}
