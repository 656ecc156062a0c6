//! The numerical-stability check every method's tests share: build a method from an extreme
//! configuration (world units ×1e-3 or ×1e3, a 1×1 or a 4K image, one view, an all-masked
//! image, joints at ±π, zero opacity, …), take one step — forward and backward — and look at
//! what came out. The acceptable outcomes are a finite loss with every saved tensor (the
//! parameters and optimiser state the step wrote) finite, or a clear error; a panic, a
//! non-finite loss or a NaN left in the state is a failure, named with the tensor it reached.

use super::{Method, MethodConfig};
use burn::tensor::Device;
use std::panic::{AssertUnwindSafe, catch_unwind};

/// What one step under an extreme input gave.
#[derive(Debug, Clone, PartialEq)]
pub enum StepOutcome {
    /// The step ran: its loss, every state tensor finite.
    Finite { loss: f64 },
    /// The method refused the input with this message (building it or stepping).
    Refused(String),
}

/// Validates `config`, builds `M` from it, takes one step and checks the outcome (module docs).
/// `Err` describes a failure: a panic, a non-finite loss, or the first state tensor holding a
/// non-finite value.
pub fn one_step<M: Method>(config: M::Config, device: &Device) -> Result<StepOutcome, String> {
    let run = catch_unwind(AssertUnwindSafe(|| {
        // As the command line does: the configuration's ranges first.
        if let Err(e) = config.validate() {
            return Ok(StepOutcome::Refused(e.to_string()));
        }
        let mut method = match M::new(config, device) {
            Ok(m) => m,
            Err(e) => return Ok(StepOutcome::Refused(e.to_string())),
        };
        let loss = match method.step() {
            Ok(report) => report.loss,
            Err(e) => return Ok(StepOutcome::Refused(e.to_string())),
        };
        if !loss.is_finite() {
            return Err(format!("the step's loss is {loss}"));
        }
        for (name, (_, values)) in &method.checkpoint().tensors {
            if let Some(bad) = values.iter().find(|v| !v.is_finite()) {
                return Err(format!("`{name}` holds {bad} after one step"));
            }
        }
        Ok(StepOutcome::Finite { loss })
    }));
    match run {
        Ok(outcome) => outcome,
        Err(panic) => {
            let message = panic
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| panic.downcast_ref::<&str>().map(|s| (*s).to_owned()))
                .unwrap_or_else(|| "a panic without a message".to_owned());
            Err(format!("panicked: {message}"))
        }
    }
}
