//! Rasterizer benchmark: forward and forward+backward time and peak host memory for
//! N ∈ {10k, 100k, 1M} splats at 256², 512² and 1920×1080 on every backend built in.
//!
//! `cargo bench --workspace --bench raster [-- --quick] [-- --backends flex,ndarray]`
//! prints a Markdown table. Peak memory is the high-water mark of host allocations during the
//! measured call (a counting allocator), above what was live before it; GPU device memory is
//! not measured.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use burn::tensor::{Device, Tensor};
use splatzoo_rasterizer::testing::{SceneSpec, random_scene};
use splatzoo_rasterizer::{ColorMode, Splats, rasterize};

struct Counting;
static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            let live = LIVE.fetch_add(layout.size(), Ordering::Relaxed) + layout.size();
            PEAK.fetch_max(live, Ordering::Relaxed);
        }
        p
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) };
        LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// Runs `f` `iters` times; returns the median seconds and the peak extra bytes.
fn measure(iters: usize, mut f: impl FnMut()) -> (f64, usize) {
    f(); // warm-up (kernel compilation, allocator pools)
    let mut times = Vec::with_capacity(iters);
    let mut peak = 0;
    for _ in 0..iters {
        let base = LIVE.load(Ordering::Relaxed);
        PEAK.store(base, Ordering::Relaxed);
        let start = Instant::now();
        f();
        times.push(start.elapsed().as_secs_f64());
        peak = peak.max(PEAK.load(Ordering::Relaxed).saturating_sub(base));
    }
    times.sort_by(|a, b| a.partial_cmp(b).unwrap());
    (times[times.len() / 2], peak)
}

fn sum_now(t: Tensor<1>) -> f32 {
    t.into_data()
        .convert::<f32>()
        .try_into_vec::<f32>()
        .unwrap()[0]
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let quick = args.iter().any(|a| a == "--quick");
    let backends: Vec<String> = args
        .iter()
        .position(|a| a == "--backends")
        .and_then(|i| args.get(i + 1))
        .map(|s| s.split(',').map(str::to_owned).collect())
        .unwrap_or_else(|| vec!["flex".into(), "ndarray".into()]);
    let counts: &[usize] = if quick {
        &[10_000, 100_000]
    } else {
        &[10_000, 100_000, 1_000_000]
    };
    let sizes: &[(u32, u32)] = if quick {
        &[(256, 256), (512, 512)]
    } else {
        &[(256, 256), (512, 512), (1920, 1080)]
    };
    println!(
        "threads: {}, SH degree 3, classic mode\n",
        rayon::current_num_threads()
    );
    println!("| backend | N | image | forward ms | fwd+bwd ms | peak host MiB (fwd+bwd) |");
    println!("|---|---:|---|---:|---:|---:|");
    for backend in &backends {
        let device = match backend.as_str() {
            "flex" => Device::flex(),
            #[allow(deprecated)] // served although deprecated upstream
            "ndarray" => Device::ndarray(),
            "wgpu" => Device::wgpu(Default::default()),
            other => {
                eprintln!("unknown backend {other}");
                continue;
            }
        };
        for &n in counts {
            for &(w, h) in sizes {
                let mut spec = SceneSpec::new(n, w, h, ColorMode::Sh { degree: 3 });
                let s = 0.3 * (1000.0 / n as f32).cbrt();
                spec.scale_range = (0.3 * s, s);
                let (scene, settings) = random_scene(1, &spec);
                let iters = if n >= 1_000_000 || w >= 1920 { 2 } else { 5 };
                let (splats, bg) = scene.tensors(&device);
                let (fwd, _) = measure(iters, || {
                    let r = rasterize(&splats, bg.clone(), &settings).unwrap();
                    std::hint::black_box(sum_now(r.color.sum()));
                });
                let ad = device.clone().autodiff();
                let (splats_ad, bg_ad) = scene.tensors(&ad);
                let leaves = Splats {
                    means: splats_ad.means.require_grad(),
                    quats: splats_ad.quats.require_grad(),
                    log_scales: splats_ad.log_scales.require_grad(),
                    opacity_logits: splats_ad.opacity_logits.require_grad(),
                    colors: splats_ad.colors.require_grad(),
                };
                let bg_ad = bg_ad.require_grad();
                let (both, peak) = measure(iters, || {
                    let r = rasterize(&leaves, bg_ad.clone(), &settings).unwrap();
                    let grads = r.color.sum().backward();
                    let g = leaves.means.grad(&grads).unwrap();
                    std::hint::black_box(sum_now(g.sum()));
                });
                // Device memory of GPU backends is not measured: their host peak says nothing.
                let peak = if backend == "wgpu" {
                    "n/a".to_owned()
                } else {
                    format!("{:.0}", peak as f64 / (1 << 20) as f64)
                };
                println!(
                    "| {backend} | {n} | {w}×{h} | {:.1} | {:.1} | {peak} |",
                    fwd * 1e3,
                    both * 1e3,
                );
            }
        }
    }
}
