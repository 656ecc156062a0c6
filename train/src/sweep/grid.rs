//! What a sweep varies: the TOML file (`configs/sweep.toml` of each method) and the points it
//! expands to. Every point is a list of `--set` overrides on top of the file's `base`; `axes`
//! varies each knob alone around the default, `grid` takes every combination, and `[[point]]`
//! tables add hand-picked points. Points whose overrides name the same effective configuration
//! are merged later, by the trainer's own `--print-config` (see [`super::runner`]).

use crate::config::ConfigError;
use serde::Deserialize;
use std::path::Path;

/// The parsed sweep file.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepSpec {
    /// The method: the sweep runs `train-<method>`.
    pub method: String,
    /// How knobs combine.
    #[serde(default)]
    pub mode: Mode,
    /// `--set` overrides every point gets (the default point is `base` alone).
    #[serde(default)]
    pub base: Vec<String>,
    /// The method's own headline metric, read from `metrics.json`.
    pub headline: Option<Headline>,
    /// The quality the Pareto fronts use.
    #[serde(default)]
    pub quality: Quality,
    #[serde(default, rename = "knob")]
    pub knobs: Vec<Knob>,
    #[serde(default, rename = "point")]
    pub points: Vec<NamedPoint>,
}

/// How the knobs' values combine into points.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Mode {
    /// The default, then each knob's values one at a time (the others at their defaults).
    #[default]
    Axes,
    /// Every combination of every knob's values.
    Grid,
}

/// A metric of `metrics.json` by JSON pointer, e.g. `/final/aag/face_psnr`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Headline {
    pub name: String,
    pub pointer: String,
    #[serde(default = "higher")]
    pub higher_is_better: bool,
}

fn higher() -> bool {
    true
}

/// Which score the fronts trade against time and speed.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Quality {
    /// The held-out PSNR the harness reports (`final.psnr`).
    #[default]
    Psnr,
    Ssim,
    /// The file's `headline`.
    Headline,
}

/// One configuration key and the values it takes.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Knob {
    /// A dotted configuration key, as `--set` takes it.
    pub key: String,
    pub values: Vec<toml::Value>,
}

/// A hand-picked point.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NamedPoint {
    pub name: String,
    pub set: Vec<String>,
}

/// One configuration of the sweep (before seeds).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Point {
    /// A file-name-safe identifier, unique in the sweep.
    pub id: String,
    /// The point's own overrides (after `base`); empty for the default point.
    pub set: Vec<String>,
}

impl SweepSpec {
    /// Reads and checks a sweep file; errors name the file.
    pub fn read(path: &Path) -> Result<Self, ConfigError> {
        let bad = |problem: String| ConfigError::File {
            file: path.display().to_string(),
            problem,
        };
        let text = std::fs::read_to_string(path).map_err(|e| bad(format!("cannot read ({e})")))?;
        let spec: Self =
            toml::from_str(&text).map_err(|e| bad(format!("not a sweep file: {e}")))?;
        spec.check().map_err(bad)?;
        Ok(spec)
    }

    fn check(&self) -> Result<(), String> {
        if self.method.trim().is_empty() {
            return Err("`method` is empty".into());
        }
        for knob in &self.knobs {
            if knob.key.trim().is_empty() || knob.key.contains('=') {
                return Err(format!("knob key `{}` must be a dotted key", knob.key));
            }
            if knob.values.is_empty() {
                return Err(format!("knob `{}` has no values", knob.key));
            }
        }
        for set in self
            .base
            .iter()
            .chain(self.points.iter().flat_map(|p| &p.set))
        {
            if !set.contains('=') {
                return Err(format!("`{set}` is not key=value"));
            }
        }
        if self.quality == Quality::Headline && self.headline.is_none() {
            return Err("`quality = \"headline\"` needs a `headline` table".into());
        }
        if self.knobs.is_empty() && self.points.is_empty() {
            return Err("nothing to sweep: no [[knob]] and no [[point]]".into());
        }
        Ok(())
    }

    /// The points in order: the default, the knobs' points, then the named ones. Ids are unique
    /// (a repeated one gets a numeric suffix).
    pub fn expand(&self) -> Vec<Point> {
        let mut sets: Vec<(Option<String>, Vec<String>)> = vec![(Some("default".into()), vec![])];
        match self.mode {
            Mode::Axes => {
                for knob in &self.knobs {
                    for value in &knob.values {
                        sets.push((None, vec![assignment(&knob.key, value)]));
                    }
                }
            }
            Mode::Grid => {
                let mut combos: Vec<Vec<String>> = vec![vec![]];
                for knob in &self.knobs {
                    combos = combos
                        .into_iter()
                        .flat_map(|c| {
                            knob.values.iter().map(move |v| {
                                let mut c = c.clone();
                                c.push(assignment(&knob.key, v));
                                c
                            })
                        })
                        .collect();
                }
                sets.extend(
                    combos
                        .into_iter()
                        .filter(|c| !c.is_empty())
                        .map(|c| (None, c)),
                );
            }
        }
        for p in &self.points {
            sets.push((Some(p.name.clone()), p.set.clone()));
        }
        let mut points: Vec<Point> = Vec::new();
        for (name, set) in sets {
            let stem = slug(&name.unwrap_or_else(|| set.join(",")));
            let mut id = stem.clone();
            let mut n = 2;
            while points.iter().any(|p| p.id == id) {
                id = format!("{stem}-{n}");
                n += 1;
            }
            points.push(Point { id, set });
        }
        points
    }
}

/// `key=value` with the value written as TOML (strings quoted).
pub fn assignment(key: &str, value: &toml::Value) -> String {
    format!("{key}={value}")
}

/// A file-name-safe form of `text` (at most 80 characters; longer ones end in a hash).
pub fn slug(text: &str) -> String {
    let clean: String = text
        .chars()
        .filter(|c| *c != '"' && *c != '\'')
        .map(|c| {
            if c.is_ascii_alphanumeric() || "._=,-".contains(c) {
                c
            } else {
                '_'
            }
        })
        .collect();
    // A leading `-` would read as an option where the id becomes a run name.
    let clean = if clean.starts_with('-') {
        format!("p{clean}")
    } else {
        clean
    };
    if clean.len() <= 80 {
        return clean;
    }
    format!("{}-{}", &clean[..63], fnv1a_hex(text))
}

/// FNV-1a of `text` as 16 hex digits (run ids and configuration hashes).
pub(crate) fn fnv1a_hex(text: &str) -> String {
    let hash = text.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x100_0000_01b3)
    });
    format!("{hash:016x}")
}
