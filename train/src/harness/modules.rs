//! What a scene gets: each optional module a method can build (a background node, an accessory
//! node, view-dependent colour, a shadow decoder, …), whether this run built it, and why — from
//! what the data contains, or forced by a configuration key. The harness prints the list at the
//! start and keeps it in `metrics.json` (`modules`), so a sweep or a user can see what a scene
//! was given and what forcing a module either way costs.

use serde::{Deserialize, Serialize};

/// One module's decision.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ModuleChoice {
    pub module: String,
    pub enabled: bool,
    /// What in the data decided it (kept when a key forced it, so the override is visible).
    pub reason: String,
    /// The configuration key that forced it; `None` when the data decided.
    pub forced_by: Option<String>,
}

impl ModuleChoice {
    /// `forced` (the value of configuration key `key`, absent to let the data decide) wins;
    /// otherwise the module is built when `needed`, for the reason `why`.
    pub fn decide(
        module: impl Into<String>,
        key: &str,
        forced: Option<bool>,
        needed: bool,
        why: impl Into<String>,
    ) -> Self {
        let why = why.into();
        match forced {
            Some(on) => Self {
                module: module.into(),
                enabled: on,
                reason: format!("forced by {key} = {on}; from the data alone: {why}"),
                forced_by: Some(key.to_owned()),
            },
            None => Self {
                module: module.into(),
                enabled: needed,
                reason: why,
                forced_by: None,
            },
        }
    }

    /// A module the method always builds (no rule; `why` says what it is for).
    pub fn always(module: impl Into<String>, why: impl Into<String>) -> Self {
        Self {
            module: module.into(),
            enabled: true,
            reason: why.into(),
            forced_by: None,
        }
    }

    /// A module built or not by a configuration key alone (no data rule).
    pub fn configured(module: impl Into<String>, key: &str, on: bool) -> Self {
        Self {
            module: module.into(),
            enabled: on,
            reason: format!("{key} = {on}"),
            forced_by: Some(key.to_owned()),
        }
    }

    /// `module: on — reason` (the line printed at start).
    pub fn line(&self) -> String {
        format!(
            "module {}: {} — {}",
            self.module,
            if self.enabled { "on" } else { "off" },
            self.reason
        )
    }
}
