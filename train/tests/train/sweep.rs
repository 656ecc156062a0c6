//! The sweep: fronts on hand-made sets, grid expansion and bad files, and whole sweeps over a
//! scripted trainer (figures known in advance: fronts, a failing point, merging, seeds,
//! resumption) and over the real `train-3dgs`.

use splatzoo_train::sweep::labels::{LabelBox, place_labels};
use splatzoo_train::sweep::pareto::{Better, front};
use splatzoo_train::sweep::{self, Status, SweepOptions, SweepSpec, Trainer};
use std::path::{Path, PathBuf};
use std::process::Command;

#[test]
fn the_front_keeps_exactly_the_undominated_points() {
    use Better::{Higher, Lower};
    // (time, quality): lower time and higher quality are better.
    let points = [
        [10.0, 20.0],     // front (fastest)
        [20.0, 25.0],     // front
        [30.0, 24.0],     // dominated by [20, 25]
        [40.0, 30.0],     // front (best)
        [40.0, 29.0],     // dominated by [40, 30] (equal time, worse)
        [f64::NAN, 50.0], // never on the front, never dominates
        [20.0, 25.0],     // a tie with a front point: also on it
    ];
    assert_eq!(
        front(&points, [Lower, Higher]),
        [true, true, false, true, false, false, true]
    );
    // FPS, higher better on both axes.
    let fps = [[5.0, 20.0], [1.0, 25.0], [0.5, 24.0], [5.0, 19.0]];
    assert_eq!(front(&fps, [Higher, Higher]), [true, true, false, false]);
    // Lower-is-better quality (an error metric).
    let errors = [[10.0, 5.0], [20.0, 6.0], [30.0, 4.0]];
    assert_eq!(front(&errors, [Lower, Lower]), [true, false, true]);
    assert!(front(&[], [Lower, Higher]).is_empty());
}

/// Names of points that land on top of each other are spread apart: on random clusters of
/// markers, every placed label stays in the plot, clears every other label and every other
/// marker; a lone marker's name goes right above it; no markers place nothing.
#[test]
fn clustered_point_names_do_not_overlap() {
    let area = LabelBox {
        x: 0,
        y: 0,
        width: 900,
        height: 600,
    };
    let boxes = |markers: &[(i32, i32)], sizes: &[(i32, i32)], offsets: &[(i32, i32)]| {
        (0..markers.len())
            .map(|i| LabelBox {
                x: markers[i].0 + offsets[i].0,
                y: markers[i].1 + offsets[i].1,
                width: sizes[i].0,
                height: sizes[i].1,
            })
            .collect::<Vec<_>>()
    };
    let disjoint = |a: &LabelBox, b: &LabelBox| {
        a.x + a.width <= b.x
            || b.x + b.width <= a.x
            || a.y + a.height <= b.y
            || b.y + b.height <= a.y
    };
    assert!(place_labels(&[], &[], &[], area).is_empty());
    let lone = place_labels(&[(400, 300)], &[(120, 14)], &[0], area);
    assert_eq!(lone, vec![(8, -22)], "right above the marker");

    let mut state = 0x2545_f491_u64 ^ std::process::id() as u64;
    let mut next = |n: i32| {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 33) % n as u64) as i32
    };
    for trial in 0..50 {
        // Four names within a 30-pixel square in mid-plot: the Illum sweep's crowd.
        let (cx, cy) = (300 + next(300), 200 + next(200));
        let markers: Vec<(i32, i32)> = (0..4).map(|_| (cx + next(30), cy + next(30))).collect();
        let sizes: Vec<(i32, i32)> = (0..4).map(|_| (60 + next(200), 14)).collect();
        let order: Vec<usize> = (0..4).collect();
        let offsets = place_labels(&markers, &sizes, &order, area);
        let placed = boxes(&markers, &sizes, &offsets);
        for (i, a) in placed.iter().enumerate() {
            assert!(
                a.x >= 0 && a.y >= 0 && a.x + a.width <= 900 && a.y + a.height <= 600,
                "trial {trial}: label {i} leaves the plot: {a:?}"
            );
            for (j, b) in placed.iter().enumerate().skip(i + 1) {
                assert!(
                    disjoint(a, b),
                    "trial {trial}: labels {i} and {j} overlap: {placed:?}"
                );
            }
            for (j, &(mx, my)) in markers.iter().enumerate().filter(|&(j, _)| j != i) {
                let marker = LabelBox {
                    x: mx - 8,
                    y: my - 8,
                    width: 16,
                    height: 16,
                };
                assert!(
                    disjoint(a, &marker),
                    "trial {trial}: label {i} covers marker {j}"
                );
            }
        }
    }
}

fn spec(text: &str) -> SweepSpec {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sweep.toml");
    std::fs::write(&path, text).unwrap();
    SweepSpec::read(&path).unwrap()
}

#[test]
fn axes_vary_one_knob_at_a_time_and_grids_take_every_combination() {
    let knobs = r#"
        method = "x"
        base = ["iterations=50"]
        [[knob]]
        key = "a.b"
        values = [1, 2, 3]
        [[knob]]
        key = "backend"
        values = ["flex", "ndarray"]
        [[point]]
        name = "tiny run"
        set = ["size=8", "a.b=9"]
    "#;
    let axes = spec(knobs).expand();
    let sets: Vec<String> = axes.iter().map(|p| p.set.join(" ")).collect();
    assert_eq!(
        sets,
        [
            "",
            "a.b=1",
            "a.b=2",
            "a.b=3",
            "backend=\"flex\"",
            "backend=\"ndarray\"",
            "size=8 a.b=9"
        ]
    );
    let ids: Vec<&str> = axes.iter().map(|p| p.id.as_str()).collect();
    assert_eq!(ids[0], "default");
    assert_eq!(ids[4], "backend=flex");
    assert_eq!(ids[6], "tiny_run");
    let grid = spec(&knobs.replace("base =", "mode = \"grid\"\nbase =")).expand();
    assert_eq!(grid.len(), 1 + 3 * 2 + 1);
    assert_eq!(grid[1].set, ["a.b=1", "backend=\"flex\""]);
    assert_eq!(grid[6].set, ["a.b=3", "backend=\"ndarray\""]);
    let mut unique: Vec<&str> = grid.iter().map(|p| p.id.as_str()).collect();
    unique.sort_unstable();
    unique.dedup();
    assert_eq!(unique.len(), grid.len(), "ids are unique");
}

#[test]
fn bad_sweep_files_are_named_with_the_problem() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        ("method = \"x\"\n", "nothing to sweep"),
        (
            "method = \"x\"\n[[knob]]\nkey = \"a\"\nvalues = []\n",
            "knob `a` has no values",
        ),
        (
            "method = \"x\"\nquality = \"headline\"\n[[knob]]\nkey = \"a\"\nvalues = [1]\n",
            "needs a `headline`",
        ),
        (
            "method = \"x\"\nknobs = 3\n[[knob]]\nkey = \"a\"\nvalues = [1]\n",
            "unknown field `knobs`",
        ),
        (
            "method = \"x\"\nbase = [\"iterations\"]\n[[knob]]\nkey = \"a\"\nvalues = [1]\n",
            "not key=value",
        ),
    ];
    for (k, (text, expected)) in cases.iter().enumerate() {
        let path = dir.path().join(format!("bad{k}.toml"));
        std::fs::write(&path, text).unwrap();
        let error = SweepSpec::read(&path).unwrap_err().to_string();
        assert!(
            error.contains(expected) && error.contains(&format!("bad{k}.toml")),
            "{error}"
        );
    }
    let missing = SweepSpec::read(&dir.path().join("none.toml")).unwrap_err();
    assert!(missing.to_string().contains("cannot read"), "{missing}");
}

/// A stand-in `train-<method>`: `iterations` (default 100) sets PSNR 20 + it/100 (+0.1 per
/// seed, − `penalty`), loop time it/10 s and 1000/it FPS; `fail=true` fails like a NaN loss;
/// every training call is appended to `calls.txt` beside the runs folder.
const FAKE_TRAINER: &str = r#"#!/bin/sh
runs=""; name=""; sets=""; print=0
while [ $# -gt 0 ]; do
  case "$1" in
    --set) sets="$sets $2"; shift 2;;
    --runs) runs="$2"; shift 2;;
    --name) name="$2"; shift 2;;
    --print-config) print=1; shift;;
    *) echo "error: unknown argument $1" >&2; exit 2;;
  esac
done
iterations=100; seed=0; fail=false; penalty=0
for s in $sets; do
  key=${s%%=*}; value=${s#*=}
  case "$key" in
    iterations) iterations=$value;;
    seed) seed=$value;;
    fail) fail=$value;;
    penalty) penalty=$value;;
    *) echo "error: configuration: unknown field \`$key\`" >&2; exit 1;;
  esac
done
if [ $print = 1 ]; then
  printf 'iterations = %s\nseed = %s\nfail = %s\npenalty = %s\n' $iterations $seed $fail $penalty
  exit 0
fi
echo "$name" >> "$runs/../calls.txt"
echo "step 1: loss 0.5"
if [ "$fail" = true ]; then echo "error: step 3: the loss is NaN" >&2; exit 1; fi
dir="$runs/fake/$name"; mkdir -p "$dir"
head -c $iterations /dev/zero > "$dir/checkpoint.safetensors"
psnr=$(awk "BEGIN{print 20 + $iterations/100 + $seed*0.1 - $penalty}")
secs=$(awk "BEGIN{print $iterations/10}")
loop=$(awk "BEGIN{print $iterations/10 + 1.5}")
fps=$(awk "BEGIN{print 1000/$iterations}")
cat > "$dir/metrics.json" <<JSON
{"method":"fake","evaluations":[],"final":{"step":$iterations,"psnr":$psnr,"ssim":0.9,"lpips":null,"fake":{"face_psnr":$psnr}},"seconds":1.5,"loop_seconds":$loop,"step_seconds":$secs,"steps_per_second":10,"render_fps":$fps,"gaussians":$iterations,"peak_rss_bytes":2097152}
JSON
"#;

fn fake_trainer(dir: &Path) -> Trainer {
    use std::os::unix::fs::PermissionsExt;
    let binary = dir.join("train-fake");
    std::fs::write(&binary, FAKE_TRAINER).unwrap();
    std::fs::set_permissions(&binary, std::fs::Permissions::from_mode(0o755)).unwrap();
    Trainer { binary }
}

const FAKE_SWEEP: &str = r#"
method = "fake"
headline = { name = "face PSNR", pointer = "/final/fake/face_psnr" }
[[knob]]
key = "iterations"
values = [50, 100, 200, 400]
[[point]]
name = "wasteful"
set = ["iterations=400", "penalty=5"]
[[point]]
name = "broken"
set = ["fail=true"]
"#;

fn call_names(out: &Path) -> Vec<String> {
    std::fs::read_to_string(out.join("calls.txt"))
        .unwrap_or_default()
        .lines()
        .map(str::to_owned)
        .collect()
}

fn calls(out: &Path) -> usize {
    call_names(out).len()
}

#[test]
fn a_sweep_measures_every_point_records_failures_and_resumes() {
    let dir = tempfile::tempdir().unwrap();
    let trainer = fake_trainer(dir.path());
    let spec = spec(FAKE_SWEEP);
    let out = dir.path().join("sweep");
    let options = SweepOptions {
        seeds: 1,
        out: out.clone(),
        base: vec![],
        retry_failed: true,
        rerun: false,
    };
    let mut lines = Vec::new();
    let report = sweep::run(&spec, &trainer, &options, &mut |l| lines.push(l.to_owned())).unwrap();
    assert!(
        lines
            .iter()
            .any(|l| l.contains("iterations=100 is the same configuration as default")),
        "{lines:?}"
    );
    let ids: Vec<&str> = report.points.iter().map(|p| p.point.as_str()).collect();
    assert_eq!(
        ids,
        [
            "default",
            "iterations=50",
            "iterations=200",
            "iterations=400",
            "wasteful",
            "broken"
        ]
    );
    assert_eq!(calls(&out), 6, "one training per distinct point");
    let broken = report.runs.iter().find(|r| r.point == "broken").unwrap();
    assert_eq!(broken.status, Status::Failed);
    assert!(
        broken
            .error
            .as_deref()
            .unwrap()
            .contains("exit 1: error: step 3: the loss is NaN"),
        "{broken:?}"
    );
    let default = &report.runs[0];
    assert_eq!(default.status, Status::Ok);
    assert_eq!(default.psnr, Some(21.0));
    assert_eq!(default.headline, Some(21.0));
    assert_eq!(default.train_seconds, Some(10.0));
    assert_eq!(default.render_fps, Some(10.0));
    assert_eq!(default.gaussians, Some(100));
    assert_eq!(default.peak_rss_mib, Some(2.0));
    assert_eq!(default.checkpoint_bytes, Some(100));
    assert!(default.run_bytes.unwrap() > 100);
    let fronts: Vec<(bool, bool)> = report
        .points
        .iter()
        .map(|p| (p.time_front, p.fps_front))
        .collect();
    // More iterations: better and slower, so every honest point is on both fronts; the
    // wasteful one is dominated and the broken one has no figures.
    assert_eq!(
        fronts,
        [
            (true, true),
            (true, true),
            (true, true),
            (true, true),
            (false, false),
            (false, false)
        ]
    );
    assert!(report.points[0].default && !report.points[1].default);
    let csv = std::fs::read_to_string(out.join("sweep.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 6);
    assert!(csv.lines().nth(1).unwrap().starts_with("default,0,ok,21,"));
    assert!(csv.contains("broken,0,failed,"));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("sweep.json")).unwrap()).unwrap();
    assert_eq!(json["points"].as_array().unwrap().len(), 6);
    for figure in ["pareto_time", "pareto_fps"] {
        let png = image::open(out.join(format!("{figure}.png")))
            .unwrap()
            .to_rgb8();
        assert_eq!(png.dimensions(), (960, 640));
        let mut colours: Vec<[u8; 3]> = png.pixels().map(|p| p.0).collect();
        colours.sort_unstable();
        colours.dedup();
        assert!(colours.len() > 20, "{figure}: drawn, with antialiased text");
        let svg = std::fs::read_to_string(out.join(format!("{figure}.svg"))).unwrap();
        for text in ["Pareto front", "default", "wasteful", "PSNR"] {
            assert!(svg.contains(text), "{figure}.svg lacks {text}");
        }
    }
    let table = sweep::table(&report);
    assert!(
        table.contains("| default (default) | – | 21.000 | 10 | 10.00 | 100 | 2 | time, FPS |"),
        "{table}"
    );

    // Again: the finished runs are reused, the failed one is run again.
    let again = sweep::run(&spec, &trainer, &options, &mut |_| {}).unwrap();
    assert_eq!(calls(&out), 7);
    for (a, r) in again.runs.iter().zip(&report.runs) {
        if r.point != "broken" {
            assert_eq!(a, r, "reused as recorded");
        }
    }
    // Kept failures: nothing runs.
    let keep = SweepOptions {
        retry_failed: false,
        ..options.clone()
    };
    sweep::run(&spec, &trainer, &keep, &mut |_| {}).unwrap();
    assert_eq!(calls(&out), 7);
    // A base override changes the configuration of every point it is not overridden in: those
    // run again (the broken one too: its configuration changed, so its record does not
    // count); `wasteful` sets its own penalty, so its configuration and record stand.
    let changed = SweepOptions {
        base: vec!["penalty=1".into()],
        ..keep
    };
    let shifted = sweep::run(&spec, &trainer, &changed, &mut |_| {}).unwrap();
    assert_eq!(
        call_names(&out)[7..],
        [
            "default-s0",
            "iterations=50-s0",
            "iterations=200-s0",
            "iterations=400-s0",
            "broken-s0"
        ]
    );
    assert_eq!(shifted.runs[0].psnr, Some(20.0));
    // --rerun measures everything again.
    let rerun = SweepOptions {
        rerun: true,
        ..changed
    };
    sweep::run(&spec, &trainer, &rerun, &mut |_| {}).unwrap();
    assert_eq!(calls(&out), 12 + 6);
}

#[test]
fn seeds_give_ranges_and_bad_overrides_are_refused_before_any_run() {
    let dir = tempfile::tempdir().unwrap();
    let trainer = fake_trainer(dir.path());
    let out = dir.path().join("seeds");
    let options = SweepOptions {
        seeds: 2,
        out: out.clone(),
        base: vec![],
        retry_failed: true,
        rerun: false,
    };
    let spec2 = spec(
        "method = \"fake\"\nquality = \"headline\"\nheadline = { name = \"face PSNR\", pointer = \"/final/fake/face_psnr\" }\n[[knob]]\nkey = \"iterations\"\nvalues = [200]\n",
    );
    let report = sweep::run(&spec2, &trainer, &options, &mut |_| {}).unwrap();
    assert_eq!(report.runs.len(), 4);
    assert_eq!(report.runs[1].set, ["seed=1"]);
    let default = &report.points[0];
    assert_eq!(default.seeds, 2);
    let q = default.quality.unwrap();
    assert!(
        (q.min - 21.0).abs() < 1e-9 && (q.max - 21.1).abs() < 1e-9,
        "{q:?}"
    );
    assert!((q.mean - 21.05).abs() < 1e-9);
    assert!(
        std::fs::read_to_string(out.join("pareto_time.svg"))
            .unwrap()
            .contains("2 seeds")
    );

    let bad = SweepOptions {
        base: vec!["no_such_knob=1".into()],
        out: dir.path().join("bad"),
        ..options
    };
    let error = sweep::run(&spec2, &trainer, &bad, &mut |_| {})
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("no_such_knob") && error.contains("unknown field"),
        "{error}"
    );
    assert_eq!(calls(&dir.path().join("bad")), 0);
}

fn bin_dir() -> PathBuf {
    Path::new(env!("CARGO_BIN_EXE_train-3dgs"))
        .parent()
        .unwrap()
        .to_path_buf()
}

#[test]
fn the_sweep_binary_runs_train_3dgs_and_names_a_missing_trainer() {
    let dir = tempfile::tempdir().unwrap();
    let grid = dir.path().join("sweep.toml");
    std::fs::write(
        &grid,
        "method = \"3dgs\"\nbase = [\"iterations=12\", \"data.size=24\", \"eval_every=0\"]\n\
         [[knob]]\nkey = \"iterations\"\nvalues = [4]\n",
    )
    .unwrap();
    let sweep = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_sweep"))
            .args(["--grid", grid.to_str().unwrap()])
            .args(args)
            .current_dir(dir.path())
            .output()
            .unwrap()
    };
    let out = sweep(&["--bin-dir", bin_dir().to_str().unwrap()]);
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.status.success(), "{text}");
    let folder = dir.path().join("runs/sweep/3dgs/sweep");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(folder.join("sweep.json")).unwrap()).unwrap();
    let runs = json["runs"].as_array().unwrap();
    assert_eq!(runs.len(), 2, "{json}");
    for run in runs {
        assert_eq!(run["status"], "ok", "{run}");
        for key in ["psnr", "train_seconds", "render_fps", "peak_rss_mib"] {
            let v = run[key].as_f64().unwrap_or(f64::NAN);
            assert!(v.is_finite() && v > 0.0, "{key}: {run}");
        }
        assert!(run["gaussians"].as_u64().unwrap() > 0);
    }
    assert!(text.contains("| default (default) |"), "{text}");

    let wrong = sweep(&["--method", "aag"]);
    assert!(!wrong.status.success());
    assert!(String::from_utf8_lossy(&wrong.stderr).contains("sweeps `3dgs`"));
    let missing = sweep(&["--bin-dir", dir.path().to_str().unwrap()]);
    let error = String::from_utf8_lossy(&missing.stderr);
    assert!(
        !missing.status.success() && error.contains("train-3dgs") && error.contains("cargo build"),
        "{error}"
    );
}
