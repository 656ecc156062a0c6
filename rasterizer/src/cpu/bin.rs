//! Tile binning: which splats touch which 16×16 tile, each tile's list sorted front to back.

use super::real::Real;
use super::{PROJ_DEPTH, PROJ_RADIUS, TILE};
use rayon::prelude::*;

/// Per-tile splat lists, concatenated tile by tile in row-major tile order.
pub struct TileBins {
    pub tiles_x: usize,
    pub tiles_y: usize,
    /// `ids[offsets[t]..offsets[t + 1]]` are the splats of tile `t`, nearest first.
    pub offsets: Vec<usize>,
    pub splat_from_isect: Vec<u32>,
}

impl TileBins {
    pub fn tile_range(&self, tile: usize) -> std::ops::Range<usize> {
        self.offsets[tile]..self.offsets[tile + 1]
    }
}

/// Inclusive tile rectangle `(x0, y0, x1, y1)` a projected splat may touch, or `None`.
fn tile_rect<T: Real>(row: &[T], tiles_x: usize, tiles_y: usize) -> Option<[usize; 4]> {
    let radius = row[PROJ_RADIUS];
    if !(radius > T::zero()) {
        return None;
    }
    let tile = T::of(TILE as f64);
    let clamp = |v: T, n: usize| -> usize {
        let t = (v / tile).floor();
        if t < T::zero() {
            0
        } else {
            t.to_usize().unwrap_or(usize::MAX).min(n - 1)
        }
    };
    Some([
        clamp(row[0] - radius, tiles_x),
        clamp(row[1] - radius, tiles_y),
        clamp(row[0] + radius, tiles_x),
        clamp(row[1] + radius, tiles_y),
    ])
}

/// Bins projected splats (`stride` values a row) into tiles of an image `width × height`.
pub fn bin<T: Real>(projected: &[T], stride: usize, width: usize, height: usize) -> TileBins {
    let tiles_x = width.div_ceil(TILE);
    let tiles_y = height.div_ceil(TILE);
    let n_tiles = tiles_x * tiles_y;
    let rects: Vec<Option<[usize; 4]>> = projected
        .par_chunks(stride)
        .map(|row| tile_rect(row, tiles_x, tiles_y))
        .collect();
    let mut counts = vec![0usize; n_tiles + 1];
    for [x0, y0, x1, y1] in rects.iter().flatten() {
        for ty in *y0..=*y1 {
            for tx in *x0..=*x1 {
                counts[ty * tiles_x + tx + 1] += 1;
            }
        }
    }
    for t in 0..n_tiles {
        counts[t + 1] += counts[t];
    }
    let offsets = counts;
    let mut cursor = offsets.clone();
    let mut splat_from_isect = vec![0u32; offsets[n_tiles]];
    for (id, rect) in rects.iter().enumerate() {
        let Some([x0, y0, x1, y1]) = *rect else {
            continue;
        };
        for ty in y0..=y1 {
            for tx in x0..=x1 {
                let tile = ty * tiles_x + tx;
                splat_from_isect[cursor[tile]] = id as u32;
                cursor[tile] += 1;
            }
        }
    }
    // Sort each tile's list by depth; ties keep splat order, so the result is deterministic.
    let mut lists: Vec<&mut [u32]> = Vec::with_capacity(n_tiles);
    let mut rest = splat_from_isect.as_mut_slice();
    for t in 0..n_tiles {
        let (head, tail) = rest.split_at_mut(offsets[t + 1] - offsets[t]);
        lists.push(head);
        rest = tail;
    }
    lists.into_par_iter().for_each(|list| {
        list.sort_by(|&a, &b| {
            let da = projected[a as usize * stride + PROJ_DEPTH];
            let db = projected[b as usize * stride + PROJ_DEPTH];
            da.partial_cmp(&db)
                .unwrap_or(std::cmp::Ordering::Equal)
                .then(a.cmp(&b))
        });
    });
    TileBins {
        tiles_x,
        tiles_y,
        offsets,
        splat_from_isect,
    }
}
