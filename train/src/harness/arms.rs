//! What every ablation binary (`ablate-<method>`) shares: choosing arms by name, creating the
//! output folder, and writing its table and per-arm files atomically.

use crate::TrainError;
use std::path::Path;

/// The arms of `all` named in `wanted` (all of them when `wanted` is empty), in `all`'s order;
/// an unknown name is an error listing the arms.
pub fn select<'a, T>(
    all: &'a [(&'a str, T)],
    wanted: &[String],
) -> Result<Vec<&'a (&'a str, T)>, TrainError> {
    if let Some(unknown) = wanted.iter().find(|w| !all.iter().any(|(n, _)| n == w)) {
        let names: Vec<&str> = all.iter().map(|(n, _)| *n).collect();
        return Err(TrainError::Config(format!(
            "no arm named `{unknown}`; the arms are {}",
            names.join(", ")
        )));
    }
    Ok(all
        .iter()
        .filter(|(name, _)| wanted.is_empty() || wanted.iter().any(|w| w == name))
        .collect())
}

/// Creates `dir` (and its parents).
pub fn create_dir(dir: &Path) -> Result<(), TrainError> {
    std::fs::create_dir_all(dir).map_err(|source| TrainError::System {
        what: format!("cannot create {}", dir.display()),
        source,
    })
}

/// Writes `text` to `path` through a temporary file, so a reader never sees half of it.
pub fn write_text(path: &Path, text: &str) -> Result<(), TrainError> {
    splatzoo_models::files::write_atomically(path, |tmp| std::fs::write(tmp, text))
        .map_err(|e| TrainError::Config(format!("{}: {e}", path.display())))
}
