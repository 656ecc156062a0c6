//! Runs one point of a sweep: the method's own `train-<method>` binary in a child process with
//! the point's `--set` overrides, its output into a log file, then the figures read back from
//! the run directory (`metrics.json`, the checkpoint's size). A child that fails is a record
//! with its last error line, not an error of the sweep.

use super::record::{PointRecord, Status};
use crate::error::TrainError;
use splatzoo_datasets::DatasetError;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Instant;

/// A `train-<method>` binary.
#[derive(Debug, Clone)]
pub struct Trainer {
    pub binary: PathBuf,
}

/// One run of the sweep: a point's overrides at one seed.
#[derive(Debug, Clone)]
pub struct RunSpec {
    pub point: String,
    pub seed: u64,
    /// Every `--set` of the run (base, the point's, then the seed's).
    pub set: Vec<String>,
}

impl RunSpec {
    /// The run's name under the sweep's `runs/<method>/`.
    pub fn name(&self) -> String {
        format!("{}-s{}", self.point, self.seed)
    }
}

impl Trainer {
    /// `train-<method>` in `dir`; a clear error when it is not there.
    pub fn find(dir: &Path, method: &str) -> Result<Self, TrainError> {
        let name = format!("train-{method}{}", std::env::consts::EXE_SUFFIX);
        let binary = dir.join(&name);
        if binary.is_file() {
            Ok(Self { binary })
        } else {
            Err(DatasetError::file(
                &binary,
                format!(
                    "not found: build it first (`cargo build --release --bin train-{method}`, or \
                     `--workspace --bins` for every method), or give its folder with --bin-dir"
                ),
            )
            .into())
        }
    }

    /// The binary's modification time, seconds since the epoch.
    pub fn modified(&self) -> Option<u64> {
        let time = std::fs::metadata(&self.binary).ok()?.modified().ok()?;
        Some(time.duration_since(std::time::UNIX_EPOCH).ok()?.as_secs())
    }

    fn command(&self, set: &[String]) -> Command {
        let mut command = Command::new(&self.binary);
        for s in set {
            command.arg("--set").arg(s);
        }
        command
    }

    /// The effective configuration of `set` as the trainer prints it (unknown keys and bad
    /// values are errors naming the override).
    pub fn effective_config(&self, set: &[String]) -> Result<String, TrainError> {
        let out = self
            .command(set)
            .arg("--print-config")
            .stdin(Stdio::null())
            .output()
            .map_err(|e| DatasetError::file(&self.binary, format!("cannot start ({e})")))?;
        if out.status.success() {
            Ok(String::from_utf8_lossy(&out.stdout).into_owned())
        } else {
            Err(TrainError::Config(format!(
                "{} rejects `--set {}`: {}",
                self.binary.display(),
                set.join(" --set "),
                last_line(&String::from_utf8_lossy(&out.stderr))
            )))
        }
    }

    /// Trains `run` with its runs under `runs` and its output in `log`; the record of what it
    /// measured (a failed record when the child fails or writes no summary). `headline` is a
    /// JSON pointer into `metrics.json`.
    pub fn run(
        &self,
        run: &RunSpec,
        runs: &Path,
        log: &Path,
        headline: Option<&str>,
    ) -> Result<PointRecord, TrainError> {
        // A fresh run: whatever an earlier run of this name left (its log, exports) goes.
        if let Ok(methods) = std::fs::read_dir(runs) {
            for method in methods.filter_map(Result::ok) {
                let old = method.path().join(run.name());
                if old.is_dir() {
                    std::fs::remove_dir_all(&old).map_err(|e| {
                        DatasetError::file(&old, format!("cannot clear the earlier run ({e})"))
                    })?;
                }
            }
        }
        let file = std::fs::File::create(log)
            .map_err(|e| DatasetError::file(log, format!("cannot create ({e})")))?;
        let err = file
            .try_clone()
            .map_err(|e| DatasetError::file(log, format!("cannot share ({e})")))?;
        let start = Instant::now();
        let status = self
            .command(&run.set)
            .arg("--runs")
            .arg(runs)
            .arg("--name")
            .arg(run.name())
            .stdin(Stdio::null())
            .stdout(file)
            .stderr(err)
            .status()
            .map_err(|e| DatasetError::file(&self.binary, format!("cannot start ({e})")))?;
        let wall = start.elapsed().as_secs_f64();
        let mut record = PointRecord::new(run);
        record.wall_seconds = Some(wall);
        record.binary_modified = self.modified();
        let text = std::fs::read_to_string(log).unwrap_or_default();
        if !status.success() {
            record.status = Status::Failed;
            record.error = Some(format!("{}: {}", exit_code(status), error_line(&text)));
            return Ok(record);
        }
        match run_dir(runs, &run.name()) {
            Some(dir) => record.read_run(&dir, headline),
            None => {
                record.status = Status::Failed;
                record.error = Some(format!(
                    "no metrics.json under {}/*/{}",
                    runs.display(),
                    run.name()
                ));
            }
        }
        Ok(record)
    }
}

/// `runs/<any method name>/<name>/` that holds a `metrics.json`.
pub fn run_dir(runs: &Path, name: &str) -> Option<PathBuf> {
    std::fs::read_dir(runs)
        .ok()?
        .filter_map(Result::ok)
        .map(|e| e.path().join(name))
        .find(|dir| dir.join("metrics.json").is_file())
}

/// `exit 1`, or `killed by signal 9`.
fn exit_code(status: std::process::ExitStatus) -> String {
    if let Some(code) = status.code() {
        return format!("exit {code}");
    }
    #[cfg(unix)]
    {
        use std::os::unix::process::ExitStatusExt;
        if let Some(signal) = status.signal() {
            return format!("killed by signal {signal}");
        }
    }
    "killed".to_owned()
}

/// The line that says what went wrong: the last one starting with `error` or holding
/// `panicked`, else the last non-empty one.
fn error_line(text: &str) -> String {
    text.lines()
        .rev()
        .map(str::trim)
        .find(|l| l.starts_with("error") || l.contains("panicked"))
        .map_or_else(|| last_line(text), str::to_owned)
}

/// The last non-empty line of `text` (a failed child's error message).
fn last_line(text: &str) -> String {
    text.lines()
        .rev()
        .map(str::trim)
        .find(|l| !l.is_empty())
        .unwrap_or("(no output)")
        .to_owned()
}
