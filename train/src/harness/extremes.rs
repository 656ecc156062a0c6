//! The numerical-stability check every method's tests share: build a method from an extreme
//! configuration (world units ×1e-3 or ×1e3, a 1×1 or a 4K image, one view, an all-masked
//! image, joints at ±π, zero opacity, …), take one step — forward and backward — (or a few,
//! to reach a later stage) and look at what came out. The acceptable outcomes are a finite
//! loss with every saved tensor (the parameters and optimiser state the steps wrote) finite,
//! or a clear error; a panic, a non-finite loss or a NaN left in the state is a failure, named
//! with the tensor it reached.

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
    after_steps::<M>(config, device, 1)
}

/// [`one_step`] for a method whose interesting stage starts later: `steps` steps (≥ 1), each
/// loss finite, then the state checked. [`StepOutcome::Finite`] carries the last loss.
pub fn after_steps<M: Method>(
    config: M::Config,
    device: &Device,
    steps: usize,
) -> Result<StepOutcome, String> {
    assert!(steps >= 1, "after_steps takes at least one step");
    let run = catch_unwind(AssertUnwindSafe(|| {
        // As the command line does: the configuration's ranges first.
        if let Err(e) = config.validate() {
            return Ok(StepOutcome::Refused(e.to_string()));
        }
        let mut method = match M::new(config, device) {
            Ok(m) => m,
            Err(e) => return Ok(StepOutcome::Refused(e.to_string())),
        };
        let mut loss = f64::NAN;
        for step in 1..=steps {
            loss = match method.step() {
                Ok(report) => report.loss,
                Err(e) => return Ok(StepOutcome::Refused(e.to_string())),
            };
            if !loss.is_finite() {
                return Err(format!("step {step}'s loss is {loss}"));
            }
        }
        for (name, (_, values)) in &method.checkpoint().tensors {
            if let Some(bad) = values.iter().find(|v| !v.is_finite()) {
                return Err(format!("`{name}` holds {bad} after {steps} step(s)"));
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

/// What the extremes tests assert of each case: a finite step or a refusal with a message;
/// a failure panics with `what` and the failure. Returns the outcome for further checks.
pub fn assert_stable(what: &str, outcome: Result<StepOutcome, String>) -> StepOutcome {
    // Shown with `--nocapture`: which cases ran and which were refused.
    eprintln!("{what}: {outcome:?}");
    match outcome {
        Ok(StepOutcome::Refused(message)) if message.trim().is_empty() => {
            panic!("{what}: refused without a message")
        }
        Ok(outcome) => outcome,
        Err(failure) => panic!("{what}: {failure}"),
    }
}
