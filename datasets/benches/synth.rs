//! Synthetic-scene render speed against accuracy, for each anti-aliasing level and shadow-map
//! resolution: one frame of the 16-camera multi-view ring at 256² (the NLF-GS preset), and one
//! frame of the monocular room (two 320×240 views, a point light casting floor shadows through
//! six cube-map faces). Timed on all cores; each setting's mean absolute colour error is against
//! a 4×4-supersampled, 4096²-shadow-map reference of the same scene.
//! Run with `cargo bench --workspace --bench synth`.

use burn::tensor::Device;
use splatzoo_datasets::synth::{Preset, Scene, SceneConfig};
use std::time::Instant;

fn scene(preset: Preset, supersample: usize, shadow_resolution: Option<usize>) -> Scene {
    SceneConfig {
        supersample,
        shadow_resolution,
        frames: Some(1),
        ..SceneConfig::new(preset, 0)
    }
    .build(&Device::flex())
}

/// Seconds per 16-view frame (best of `repeats`) and the views.
fn time_frame(scene: &Scene, repeats: usize) -> (f64, Vec<Vec<[f32; 3]>>) {
    let mut best = f64::INFINITY;
    let mut views = Vec::new();
    for _ in 0..repeats {
        let start = Instant::now();
        let rendered = scene.render_frame(0);
        best = best.min(start.elapsed().as_secs_f64());
        views = rendered.into_iter().map(|v| v.render.color).collect();
    }
    (best, views)
}

fn mean_abs_error(a: &[Vec<[f32; 3]>], b: &[Vec<[f32; 3]>]) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for (va, vb) in a.iter().zip(b) {
        for (p, q) in va.iter().zip(vb) {
            for c in 0..3 {
                sum += (p[c] - q[c]).abs() as f64;
                n += 1;
            }
        }
    }
    sum / n as f64
}

fn main() {
    let quick = std::env::args().any(|a| a == "--quick");
    let repeats = if quick { 1 } else { 3 };
    println!(
        "{} rayon threads, best of {repeats}",
        rayon::current_num_threads()
    );
    for preset in [Preset::Multiview, Preset::Monocular] {
        let reference_scene = scene(preset, 4, Some(4096));
        let (_, reference) = time_frame(&reference_scene, 1);
        let camera = reference_scene.tracks[0].cameras[0];
        println!(
            "\n{preset:?}: {} views × {}×{}",
            reference_scene.tracks.len(),
            camera.width,
            camera.height
        );
        println!(
            "| supersample | shadow map | s / frame | ms / view | mean |Δ colour| vs reference |"
        );
        println!("|---|---|---|---|---|");
        for (supersample, shadows) in [
            (1, None),
            (1, Some(1024)),
            (2, None),
            (2, Some(512)),
            (2, Some(1024)),
            (2, Some(2048)),
            (3, Some(1024)),
        ] {
            let s = scene(preset, supersample, shadows);
            let (seconds, views) = time_frame(&s, repeats);
            println!(
                "| {supersample}×{supersample} | {} | {seconds:.3} | {:.1} | {:.5} |",
                shadows.map_or("off".to_string(), |r| format!("{r}²")),
                1000.0 * seconds / s.tracks.len() as f64,
                mean_abs_error(&views, &reference)
            );
        }
    }
}
