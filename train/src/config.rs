//! Configuration files: every knob of a binary is a field of one serde struct, read as TOML over
//! the built-in defaults, then overridden by `--set section.key=value` arguments; the effective
//! configuration is written into the run directory so that a run can be repeated exactly.

use serde::Serialize;
use serde::de::DeserializeOwned;
use std::path::Path;

#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    #[error("{file}: {problem}")]
    File { file: String, problem: String },
    #[error("--set {argument}: {problem}")]
    Override { argument: String, problem: String },
    #[error("configuration ({source_name}): {problem}")]
    Invalid {
        source_name: String,
        problem: String,
    },
}

/// `base` (normally `T::default()`, or a resumed run's configuration), overlaid with the TOML
/// file `file` (tables merge key by key) and then with each `key.path=value` in `overrides` (the
/// value is read as TOML, or as a bare string). Unknown keys and wrongly typed values are errors
/// naming where they came from.
pub fn load<T: Serialize + DeserializeOwned>(
    base: &T,
    file: Option<&Path>,
    overrides: &[String],
) -> Result<T, ConfigError> {
    let mut table = toml::Table::try_from(base).expect("configurations serialise to a table");
    if let Some(file) = file {
        let text = std::fs::read_to_string(file).map_err(|e| ConfigError::File {
            file: file.display().to_string(),
            problem: format!("cannot read ({e})"),
        })?;
        let user: toml::Table = text.parse().map_err(|e| ConfigError::File {
            file: file.display().to_string(),
            problem: format!("not valid TOML: {e}"),
        })?;
        merge(&mut table, user);
    }
    for argument in overrides {
        let bad = |problem: &str| ConfigError::Override {
            argument: argument.clone(),
            problem: problem.to_owned(),
        };
        let (key, raw) = argument
            .split_once('=')
            .ok_or_else(|| bad("expected key=value, e.g. densify.strategy=\"mcmc\""))?;
        let value = format!("v = {raw}")
            .parse::<toml::Table>()
            .ok()
            .and_then(|mut t| t.remove("v"))
            .unwrap_or_else(|| toml::Value::String(raw.to_owned()));
        let path: Vec<&str> = key.trim().split('.').collect();
        let (last, parents) = path.split_last().expect("split yields one part");
        let mut at = &mut table;
        for part in parents {
            at = at
                .entry(part.to_string())
                .or_insert_with(|| toml::Value::Table(Default::default()))
                .as_table_mut()
                .ok_or_else(|| bad(&format!("`{part}` is not a section")))?;
        }
        at.insert(last.to_string(), value);
    }
    let source_name = match (file, overrides.is_empty()) {
        (Some(f), true) => f.display().to_string(),
        (Some(f), false) => format!("{} with --set overrides", f.display()),
        (None, false) => "--set overrides".to_owned(),
        (None, true) => "built-in".to_owned(),
    };
    T::deserialize(toml::Value::Table(table)).map_err(|e| ConfigError::Invalid {
        source_name,
        problem: e.to_string().trim().to_owned(),
    })
}

/// The TOML text of `config` (what a run directory keeps as `config.toml`).
pub fn to_toml<T: Serialize>(config: &T) -> String {
    toml::to_string_pretty(config).expect("configurations serialise to TOML")
}

fn merge(base: &mut toml::Table, over: toml::Table) {
    for (key, value) in over {
        match (base.get_mut(&key), value) {
            (Some(toml::Value::Table(b)), toml::Value::Table(o)) => merge(b, o),
            (_, value) => {
                base.insert(key, value);
            }
        }
    }
}
