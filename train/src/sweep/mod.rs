//! `sweep`: measures a method's speed/accuracy trade over a grid of `--set` overrides.
//!
//! Each point of the sweep file ([`grid`]) runs the method's own `train-<method>` binary in a
//! child process ([`runner`]) on the same data with the same held-out evaluation, once per seed;
//! what the harness wrote into `metrics.json` (held-out PSNR/SSIM/LPIPS, the method's headline
//! metric, optimiser-step time, steps/s, render FPS, Gaussians, peak resident memory) and the
//! run's bytes on disk
//! become a [`PointRecord`]. The sweep is resumable: a run whose record exists for the same
//! effective configuration is not run again (a warning says when the trainer was rebuilt since;
//! `rerun` measures everything again), and a failed run is recorded and the sweep goes on. A
//! point with a failed seed is left off the fronts. At the end it writes `sweep.csv` (one row per run), `sweep.json` (runs and per-point
//! summaries over seeds) and two Pareto figures ([`pareto`], [`plot`]): quality against training
//! time and against render FPS, as PNG and SVG.
//!
//! The sweep runs binaries by name so that the engine names no method.

pub mod grid;
pub mod labels;
pub mod pareto;
pub mod plot;
pub mod record;
pub mod runner;

pub use grid::{Mode, Point, Quality, SweepSpec};
pub use record::{PointRecord, PointSummary, Spread, Status};
pub use runner::{RunSpec, Trainer};

use crate::error::TrainError;
use indicatif::{ProgressBar, ProgressStyle};
use pareto::{Better, front};
use plot::{FrontPlot, PlotPoint};
use plotters::chart::SeriesLabelPosition;
use serde::Serialize;
use splatzoo_datasets::DatasetError;
use splatzoo_datasets::files::write_bytes;
use std::path::{Path, PathBuf};

/// How a sweep runs.
#[derive(Debug, Clone)]
pub struct SweepOptions {
    /// Seeds per point (`seed=0..seeds`; one seed leaves the configuration's own).
    pub seeds: u64,
    /// The sweep's folder: `runs/`, `logs/`, `records/` and the outputs.
    pub out: PathBuf,
    /// More `--set` overrides for every point (after the file's `base`).
    pub base: Vec<String>,
    /// Runs again the runs recorded as failed.
    pub retry_failed: bool,
    /// Runs every run again, whatever is recorded.
    pub rerun: bool,
}

/// What `sweep.json` holds.
#[derive(Debug, Clone, Serialize)]
pub struct SweepReport {
    pub method: String,
    pub quality: String,
    pub seeds: u64,
    pub base: Vec<String>,
    pub runs: Vec<PointRecord>,
    pub points: Vec<PointSummary>,
}

/// A point and its runs, one per seed.
#[derive(Debug, Clone)]
pub struct PlannedPoint {
    pub point: Point,
    pub runs: Vec<PlannedRun>,
}

/// A run and the hash of its effective configuration.
#[derive(Debug, Clone)]
pub struct PlannedRun {
    pub spec: RunSpec,
    pub config_hash: String,
}

/// The points of `spec` (merged where two name the same effective configuration, as the
/// trainer's `--print-config` prints it) and their runs; `say` hears about every merge.
pub fn plan(
    spec: &SweepSpec,
    trainer: &Trainer,
    options: &SweepOptions,
    say: &mut dyn FnMut(&str),
) -> Result<Vec<PlannedPoint>, TrainError> {
    let base: Vec<String> = spec.base.iter().chain(&options.base).cloned().collect();
    let mut planned: Vec<PlannedPoint> = Vec::new();
    for point in spec.expand() {
        let mut runs = Vec::new();
        for seed in 0..options.seeds.max(1) {
            let mut set: Vec<String> = base.iter().chain(&point.set).cloned().collect();
            if options.seeds > 1 {
                set.push(format!("seed={seed}"));
            }
            runs.push(PlannedRun {
                config_hash: grid::fnv1a_hex(&trainer.effective_config(&set)?),
                spec: RunSpec {
                    point: point.id.clone(),
                    seed,
                    set,
                },
            });
        }
        if let Some(same) = planned
            .iter()
            .find(|p| p.runs[0].config_hash == runs[0].config_hash)
        {
            say(&format!(
                "point {} is the same configuration as {}: not run twice",
                point.id, same.point.id
            ));
            continue;
        }
        planned.push(PlannedPoint { point, runs });
    }
    Ok(planned)
}

/// Runs the sweep (see the module docs); `say` hears one line per event.
pub fn run(
    spec: &SweepSpec,
    trainer: &Trainer,
    options: &SweepOptions,
    say: &mut dyn FnMut(&str),
) -> Result<SweepReport, TrainError> {
    let planned = plan(spec, trainer, options, say)?;
    let [runs_dir, logs, records] = ["runs", "logs", "records"].map(|d| options.out.join(d));
    for dir in [&runs_dir, &logs, &records] {
        std::fs::create_dir_all(dir)
            .map_err(|e| DatasetError::file(dir, format!("cannot create ({e})")))?;
    }
    let total: usize = planned.iter().map(|p| p.runs.len()).sum();
    let bar = ProgressBar::new(total as u64);
    bar.set_style(
        ProgressStyle::with_template("{bar:30} {pos}/{len} runs, eta {eta} {msg}")
            .expect("valid template"),
    );
    let headline = spec.headline.as_ref().map(|h| h.pointer.as_str());
    let mut all = Vec::new();
    for planned_point in &planned {
        for PlannedRun {
            spec: run,
            config_hash: hash,
        } in &planned_point.runs
        {
            let record_path = records.join(format!("{}.json", run.name()));
            let previous = read_record(&record_path).filter(|r| {
                !options.rerun
                    && r.config_hash == *hash
                    && (r.status == Status::Ok || !options.retry_failed)
            });
            let record = match previous {
                Some(r) => {
                    let rebuilt = if r.binary_modified != trainer.modified() {
                        format!(
                            "; {} was rebuilt since (--rerun measures it again)",
                            trainer.binary.display()
                        )
                    } else {
                        String::new()
                    };
                    show(
                        &bar,
                        &format!("{}: recorded before ({:?}){rebuilt}", run.name(), r.status),
                    );
                    r
                }
                None => {
                    bar.set_message(run.name());
                    let log = logs.join(format!("{}.log", run.name()));
                    let mut r = trainer.run(run, &runs_dir, &log, headline)?;
                    r.config_hash.clone_from(hash);
                    write_json(&record_path, &r)?;
                    show(&bar, &describe(&r));
                    r
                }
            };
            bar.inc(1);
            all.push(record);
        }
    }
    bar.finish_and_clear();
    let points = summarise(spec, &planned, &all);
    let report = SweepReport {
        method: spec.method.clone(),
        quality: quality_name(spec),
        seeds: options.seeds.max(1),
        base: spec.base.iter().chain(&options.base).cloned().collect(),
        runs: all,
        points,
    };
    write_outputs(spec, &report, &options.out)?;
    say(&format!(
        "wrote {}: sweep.csv, sweep.json, pareto_time.png/.svg, pareto_fps.png/.svg",
        options.out.display()
    ));
    Ok(report)
}

/// A line above the progress bar, or on stdout where the bar is hidden (not a terminal).
fn show(bar: &ProgressBar, line: &str) {
    if bar.is_hidden() {
        println!("{line}");
    } else {
        bar.println(line);
    }
}

fn describe(r: &PointRecord) -> String {
    match r.status {
        Status::Ok => format!(
            "{}: PSNR {:.2} dB, {:.0} s training, {:.2} FPS, {} Gaussians",
            r.point_seed(),
            r.psnr.unwrap_or(f64::NAN),
            r.train_seconds.unwrap_or(f64::NAN),
            r.render_fps.unwrap_or(f64::NAN),
            r.gaussians.map_or("?".into(), |g| g.to_string())
        ),
        Status::Failed => format!(
            "{}: FAILED ({})",
            r.point_seed(),
            r.error.as_deref().unwrap_or("?")
        ),
    }
}

impl PointRecord {
    fn point_seed(&self) -> String {
        format!("{} seed {}", self.point, self.seed)
    }

    /// The figure the fronts use.
    fn quality(&self, spec: &SweepSpec) -> Option<f64> {
        match spec.quality {
            Quality::Psnr => self.psnr,
            Quality::Ssim => self.ssim,
            Quality::Headline => self.headline,
        }
    }
}

fn quality_name(spec: &SweepSpec) -> String {
    match (spec.quality, &spec.headline) {
        (Quality::Psnr, _) => "held-out PSNR (dB)".into(),
        (Quality::Ssim, _) => "held-out SSIM".into(),
        (Quality::Headline, Some(h)) => h.name.clone(),
        (Quality::Headline, None) => "headline".into(),
    }
}

/// Per-point spreads over the successful seeds, and both fronts.
fn summarise(
    spec: &SweepSpec,
    planned: &[PlannedPoint],
    records: &[PointRecord],
) -> Vec<PointSummary> {
    let mut points: Vec<PointSummary> = planned
        .iter()
        .map(|PlannedPoint { point, .. }| {
            let mine: Vec<&PointRecord> = records.iter().filter(|r| r.point == point.id).collect();
            let ok: Vec<&&PointRecord> = mine.iter().filter(|r| r.status == Status::Ok).collect();
            let spread = |f: &dyn Fn(&PointRecord) -> Option<f64>| {
                Spread::of(ok.iter().filter_map(|r| f(r)))
            };
            PointSummary {
                point: point.id.clone(),
                set: point.set.clone(),
                default: point.id == "default",
                seeds: ok.len(),
                failed: mine.len() - ok.len(),
                quality: spread(&|r| r.quality(spec)),
                psnr: spread(&|r| r.psnr),
                headline: spread(&|r| r.headline),
                train_seconds: spread(&|r| r.train_seconds),
                render_fps: spread(&|r| r.render_fps),
                peak_rss_mib: spread(&|r| r.peak_rss_mib),
                gaussians: spread(&|r| r.gaussians.map(|g| g as f64)),
                time_front: false,
                fps_front: false,
            }
        })
        .collect();
    let y_better = match (&spec.quality, &spec.headline) {
        (Quality::Headline, Some(h)) if !h.higher_is_better => Better::Lower,
        _ => Better::Higher,
    };
    // A point with a failed seed stays off the fronts (its mean is over fewer runs).
    let mean = |p: &PointSummary, s: Option<Spread>| match s {
        Some(s) if p.failed == 0 => s.mean,
        _ => f64::NAN,
    };
    let time: Vec<[f64; 2]> = points
        .iter()
        .map(|p| [mean(p, p.train_seconds), mean(p, p.quality)])
        .collect();
    let fps: Vec<[f64; 2]> = points
        .iter()
        .map(|p| [mean(p, p.render_fps), mean(p, p.quality)])
        .collect();
    let on_time = front(&time, [Better::Lower, y_better]);
    let on_fps = front(&fps, [Better::Higher, y_better]);
    for ((p, t), f) in points.iter_mut().zip(on_time).zip(on_fps) {
        p.time_front = t;
        p.fps_front = f;
    }
    points
}

/// The per-point summary as a Markdown table (for the terminal and the READMEs).
pub fn table(report: &SweepReport) -> String {
    let cell = |s: Option<Spread>, digits: usize| match s {
        None => "–".to_owned(),
        Some(s) if s.max > s.min => {
            format!("{:.d$} ({:.d$}–{:.d$})", s.mean, s.min, s.max, d = digits)
        }
        Some(s) => format!("{:.d$}", s.mean, d = digits),
    };
    let mut text = format!(
        "| point | overrides | {} | training s | render FPS | Gaussians | peak RSS MiB | front |\n\
         |---|---|---|---|---|---|---|---|\n",
        report.quality
    );
    for p in &report.points {
        let fronts: Vec<&str> = [(p.time_front, "time"), (p.fps_front, "FPS")]
            .into_iter()
            .filter_map(|(on, name)| on.then_some(name))
            .collect();
        let failed = if p.failed > 0 {
            format!(" ({} failed)", p.failed)
        } else {
            String::new()
        };
        text.push_str(&format!(
            "| {}{}{failed} | {} | {} | {} | {} | {} | {} | {} |\n",
            p.point,
            if p.default { " (default)" } else { "" },
            if p.set.is_empty() {
                "–".to_owned()
            } else {
                format!("`{}`", p.set.join(" "))
            },
            cell(p.quality, 3),
            cell(p.train_seconds, 0),
            cell(p.render_fps, 2),
            cell(p.gaussians, 0),
            cell(p.peak_rss_mib, 0),
            fronts.join(", ")
        ));
    }
    text
}

fn write_json<T: Serialize>(path: &Path, value: &T) -> Result<(), TrainError> {
    let text = serde_json::to_string_pretty(value).expect("plain data serialises");
    Ok(write_bytes(path, text.as_bytes())?)
}

fn read_record(path: &Path) -> Option<PointRecord> {
    serde_json::from_str(&std::fs::read_to_string(path).ok()?).ok()
}

/// `sweep.csv`, `sweep.json` and the two figures.
fn write_outputs(spec: &SweepSpec, report: &SweepReport, out: &Path) -> Result<(), TrainError> {
    let mut csv = String::from(record::CSV_HEADER);
    csv.push('\n');
    for r in &report.runs {
        csv.push_str(&r.csv_row());
        csv.push('\n');
    }
    write_bytes(&out.join("sweep.csv"), csv.as_bytes())?;
    write_json(&out.join("sweep.json"), report)?;
    let y_label = match (&spec.quality, &spec.headline) {
        (Quality::Headline, Some(h)) if !h.higher_is_better => {
            format!("{} (lower is better)", report.quality)
        }
        _ => report.quality.clone(),
    };
    let seeds = if report.seeds > 1 {
        format!(", {} seeds (bars: range)", report.seeds)
    } else {
        String::new()
    };
    let figure = |x_label: &str, x_better: Better, x: fn(&PointSummary) -> Option<Spread>| {
        let front = |p: &PointSummary| match x_better {
            Better::Lower => p.time_front,
            Better::Higher => p.fps_front,
        };
        // A time front rises to the right, an FPS front falls: the legend takes the corner
        // above the front's far end.
        let legend = match x_better {
            Better::Lower => SeriesLabelPosition::UpperLeft,
            Better::Higher => SeriesLabelPosition::UpperRight,
        };
        FrontPlot {
            title: format!(
                "{}: {} against {}{seeds}",
                spec.method, report.quality, x_label
            ),
            x_label: x_label.to_owned(),
            y_label: y_label.clone(),
            legend,
            points: report
                .points
                .iter()
                .filter_map(|p| {
                    Some(PlotPoint {
                        label: p.point.clone(),
                        x: x(p)?,
                        y: p.quality?,
                        front: front(p),
                        default: p.default,
                    })
                })
                .collect(),
        }
    };
    figure("training time (s)", Better::Lower, |p| p.train_seconds)
        .write(&out.join("pareto_time"))?;
    figure("render FPS", Better::Higher, |p| p.render_fps).write(&out.join("pareto_fps"))?;
    Ok(())
}
