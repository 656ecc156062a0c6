//! What the engine's benches share: each backend measured in its own child process (so its
//! peak resident memory, `VmHWM`, which on lavapipe includes the "GPU" buffers, is its own),
//! the command line `[backend ...] [steps]`, and the child's figures passed back as numbers.

use splatzoo_train::backend::Backend;
use std::process::Command;

/// Peak resident memory of this process, MiB (NaN where the system does not say).
pub fn peak_rss_mib() -> f64 {
    splatzoo_train::harness::peak_rss_bytes().map_or(f64::NAN, |b| b as f64 / (1024.0 * 1024.0))
}

/// The bench's `main`: in a child (`--child <backend> <steps>`) prints what `child` measured;
/// otherwise prints `header`, runs one child per chosen backend and hands each one's figures
/// (or its last error line) to `row`.
pub fn run(
    default_steps: usize,
    child: impl Fn(Backend, usize) -> Vec<f64>,
    header: impl Fn(usize),
    row: impl Fn(Backend, Result<Vec<f64>, String>),
) {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .collect();
    if args.first().map(String::as_str) == Some("--child") {
        let backend = Backend::ALL
            .into_iter()
            .find(|b| b.name() == args[1])
            .expect("known backend");
        let figures = child(backend, args[2].parse().expect("steps"));
        let text: Vec<String> = figures.iter().map(f64::to_string).collect();
        println!("{}", text.join(" "));
        return;
    }
    let steps: usize = args
        .iter()
        .find_map(|a| a.parse().ok())
        .unwrap_or(default_steps);
    let chosen: Vec<Backend> = Backend::ALL
        .into_iter()
        .filter(|b| {
            args.iter().all(|a| a.parse::<usize>().is_ok()) || args.iter().any(|a| a == b.name())
        })
        .collect();
    header(steps);
    let exe = std::env::current_exe().expect("own path");
    for backend in chosen {
        let out = Command::new(&exe)
            .args(["--child", backend.name(), &steps.to_string()])
            .output()
            .expect("child runs");
        let figures: Option<Vec<f64>> = String::from_utf8_lossy(&out.stdout)
            .split_whitespace()
            .map(|f| f.parse().ok())
            .collect();
        let result = match figures {
            Some(f) if out.status.success() && !f.is_empty() => Ok(f),
            _ => Err(String::from_utf8_lossy(&out.stderr)
                .lines()
                .last()
                .unwrap_or("")
                .to_owned()),
        };
        row(backend, result);
    }
}
