//! Tile binning on the GPU: per-tile counts (atomic), tile offsets (scan), intersections
//! scattered into their tile's range, each range sorted by (depth, splat) — unique keys, so the
//! final order is deterministic whatever order the atomics produced — and the maps the backward
//! uses to gather a splat's per-intersection gradients.

use super::project::tile_bound;
use burn_cubecl::cubecl;
use cubecl::prelude::*;

/// The tile rectangle of a projected row, inclusive.
#[cube]
fn rect(projected: &[f32], base: usize, tiles_x: u32, tiles_y: u32) -> (u32, u32, u32, u32) {
    let u = projected[base];
    let v = projected[base + 1];
    let r = projected[base + 7];
    (
        tile_bound(u - r, tiles_x),
        tile_bound(v - r, tiles_y),
        tile_bound(u + r, tiles_x),
        tile_bound(v + r, tiles_y),
    )
}

/// `tile_counts[t] += 1` for every tile `t` each visible splat touches.
#[cube(launch)]
pub fn tile_histogram(
    projected: &[f32],
    tile_counts: &[Atomic<u32>],
    n: u32,
    tiles_x: u32,
    tiles_y: u32,
    #[comptime] stride: usize,
) {
    let i = ABSOLUTE_POS;
    if i >= n as usize {
        terminate!();
    }
    let base = i * stride;
    if projected[base + 7] > 0.0 {
        let (x0, y0, x1, y1) = rect(projected, base, tiles_x, tiles_y);
        for ty in y0..y1 + 1 {
            for tx in x0..x1 + 1 {
                tile_counts[(ty * tiles_x + tx) as usize].fetch_add(1u32);
            }
        }
    }
}

#[cube(launch)]
pub fn copy_u32(input: &[u32], output: &mut [u32], n: u32) {
    let i = ABSOLUTE_POS;
    if i < n as usize {
        output[i] = input[i];
    }
}

/// Writes each (tile, splat) intersection into its tile's range; `emit` is the intersection's
/// index in splat-major order (`splat_offsets[i] + j`).
#[cube(launch)]
#[allow(clippy::too_many_arguments)]
pub fn emit_intersections(
    projected: &[f32],
    splat_offsets: &[u32],
    tile_cursor: &[Atomic<u32>],
    list_depth: &mut [f32],
    list_splat: &mut [u32],
    list_emit: &mut [u32],
    n: u32,
    tiles_x: u32,
    tiles_y: u32,
    #[comptime] stride: usize,
) {
    let i = ABSOLUTE_POS;
    if i >= n as usize {
        terminate!();
    }
    let base = i * stride;
    if projected[base + 7] > 0.0 {
        let depth = projected[base + 5];
        let (x0, y0, x1, y1) = rect(projected, base, tiles_x, tiles_y);
        let mut emit = splat_offsets[i];
        for ty in y0..y1 + 1 {
            for tx in x0..x1 + 1 {
                let pos = tile_cursor[(ty * tiles_x + tx) as usize].fetch_add(1u32) as usize;
                list_depth[pos] = depth;
                list_splat[pos] = i as u32;
                list_emit[pos] = emit;
                emit += 1;
            }
        }
    }
}

// Kernel code: slices have no `swap` inside `#[cube]`.
#[allow(clippy::manual_swap)]
#[cube]
fn order_swap(
    list_depth: &mut [f32],
    list_splat: &mut [u32],
    list_emit: &mut [u32],
    lo: usize,
    hi: usize,
) {
    let dl = list_depth[lo];
    let dh = list_depth[hi];
    let sl = list_splat[lo];
    let sh = list_splat[hi];
    if dl > dh || (dl == dh && sl > sh) {
        list_depth[lo] = dh;
        list_depth[hi] = dl;
        list_splat[lo] = sh;
        list_splat[hi] = sl;
        let e = list_emit[lo];
        list_emit[lo] = list_emit[hi];
        list_emit[hi] = e;
    }
}

/// Sorts each tile's range by (depth, splat): one cube per tile, a bitonic network in global
/// memory whose every comparison is ascending, so a range of any length sorts as if padded
/// with +∞.
#[cube(launch)]
pub fn sort_tiles(
    tile_offsets: &[u32],
    list_depth: &mut [f32],
    list_splat: &mut [u32],
    list_emit: &mut [u32],
) {
    let tile = CUBE_POS;
    let start = tile_offsets[tile] as usize;
    let len = tile_offsets[tile + 1] as usize - start;
    let units = CUBE_DIM as usize;
    let lid = UNIT_POS as usize;
    let mut padded = 1usize;
    while padded < len {
        padded *= 2;
    }
    let half = padded / 2;
    let mut k = 2usize;
    while k <= padded {
        // Merge step: compare mirrored pairs within each block of k.
        let hk = k / 2;
        let mut t = lid;
        while t < half {
            let block = t / hk;
            let off = t % hk;
            let lo = block * k + off;
            let hi = block * k + k - 1 - off;
            if hi < len {
                order_swap(list_depth, list_splat, list_emit, start + lo, start + hi);
            }
            t += units;
        }
        sync_cube();
        let mut j = k / 4;
        while j >= 1 {
            let mut t = lid;
            while t < half {
                let lo = (t / j) * 2 * j + t % j;
                let hi = lo + j;
                if hi < len {
                    order_swap(list_depth, list_splat, list_emit, start + lo, start + hi);
                }
                t += units;
            }
            sync_cube();
            j /= 2;
        }
        k *= 2;
    }
}

/// `sorted_from_emit[list_emit[p]] = p`.
#[cube(launch)]
pub fn invert_emit(list_emit: &[u32], sorted_from_emit: &mut [u32], n_isect: u32) {
    let p = ABSOLUTE_POS;
    if p < n_isect as usize {
        sorted_from_emit[list_emit[p] as usize] = p as u32;
    }
}

/// Sums each splat's per-intersection gradient rows, in splat-major order (deterministic).
#[cube(launch)]
pub fn gather_splat_grads(
    isect_grads: &[f32],
    splat_offsets: &[u32],
    sorted_from_emit: &[u32],
    grad_projected: &mut [f32],
    n: u32,
    #[comptime] stride: usize,
) {
    let i = ABSOLUTE_POS;
    if i >= n as usize {
        terminate!();
    }
    let start = splat_offsets[i] as usize;
    let end = splat_offsets[i + 1] as usize;
    for s in 0..stride {
        let mut acc = 0.0f32;
        for e in start..end {
            acc += isect_grads[sorted_from_emit[e] as usize * stride + s];
        }
        grad_projected[i * stride + s] = acc;
    }
}
