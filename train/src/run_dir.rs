//! Run directories, `runs/<method>/<name>/`: the effective `config.toml`, a `log.txt` that every
//! message is appended to (and echoed to the terminal), `metrics.json` holding every evaluation
//! (rewritten atomically after each), the checkpoint, exports and renders.

use serde::Serialize;
use splatzoo_datasets::DatasetError;
use splatzoo_datasets::files::write_bytes;
use std::io::Write;
use std::path::{Path, PathBuf};

pub struct RunDir {
    pub path: PathBuf,
    log: std::fs::File,
}

impl RunDir {
    /// Creates (or reopens, when resuming) `root/method/name`.
    pub fn open(root: &Path, method: &str, name: &str) -> Result<Self, DatasetError> {
        let path = root.join(method).join(name);
        let fail = |e: std::io::Error| DatasetError::file(&path, format!("cannot create ({e})"));
        std::fs::create_dir_all(&path).map_err(fail)?;
        let log = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(path.join("log.txt"))
            .map_err(fail)?;
        Ok(Self { path, log })
    }

    pub fn file(&self, name: &str) -> PathBuf {
        self.path.join(name)
    }

    /// Appends `line` to `log.txt` (a failing log write is reported once on stderr, never fatal).
    pub fn log(&mut self, line: &str) {
        if let Err(e) = writeln!(self.log, "{line}") {
            eprintln!("warning: {}: {e}", self.path.join("log.txt").display());
        }
    }

    /// Writes `name` (inside the run) as pretty JSON, atomically.
    pub fn write_json<T: Serialize>(&self, name: &str, value: &T) -> Result<(), DatasetError> {
        let text = serde_json::to_string_pretty(value).expect("plain data serialises");
        write_bytes(&self.file(name), text.as_bytes())
    }

    pub fn write_text(&self, name: &str, text: &str) -> Result<(), DatasetError> {
        write_bytes(&self.file(name), text.as_bytes())
    }
}
