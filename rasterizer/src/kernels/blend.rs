//! Compositing on the GPU: one cube per 16×16 tile, one unit per pixel, splats staged through
//! shared memory in batches of 256. Same cut-offs and order as `crate::cpu::blend`.

use burn_cubecl::cubecl;
use cubecl::prelude::*;

pub const TILE: u32 = 16;
/// Splats staged per batch: one per unit of a 16×16 tile (the max-reduction halves from 128).
const BATCH: usize = 256;
const ALPHA_MAX: f32 = 0.99;
const T_MIN: f32 = 0.0001;

/// The pixel this unit shades: cube = tile (row-major), unit = pixel within the 16×16 tile.
#[cube]
fn unit_pixel(tiles_x: u32) -> (u32, u32) {
    let tile = CUBE_POS as u32;
    (
        (tile % tiles_x) * TILE + UNIT_POS % TILE,
        (tile / tiles_x) * TILE + UNIT_POS / TILE,
    )
}

#[cube(launch)]
#[allow(clippy::too_many_arguments)]
pub fn blend_forward(
    projected: &[f32],
    tile_offsets: &[u32],
    list_splat: &[u32],
    background: &[f32],
    image: &mut [f32],
    final_transmittance: &mut [f32],
    contributors: &mut [f32],
    width: u32,
    height: u32,
    tiles_x: u32,
    sigma_max: f32,
    alpha_min: f32,
    #[comptime] channels: usize,
) {
    let stride = comptime!(8 + channels);
    let tile = CUBE_POS;
    let lid = UNIT_POS as usize;
    let (x, y) = unit_pixel(tiles_x);
    let inside = x < width && y < height;
    let pxf = f32::cast_from(x) + 0.5;
    let pyf = f32::cast_from(y) + 0.5;

    let mut sh_geo = Shared::<[f32]>::new_slice(BATCH * 7);
    let mut sh_color = Shared::<[f32]>::new_slice(comptime!(BATCH * channels));
    let mut sh_busy = Shared::<[u32]>::new_slice(1usize);

    let start = tile_offsets[tile] as usize;
    let end = tile_offsets[tile + 1] as usize;
    let mut t = 1.0f32;
    let mut depth = 0.0f32;
    let mut last = 0u32;
    let mut done = !inside;
    let mut color = Array::<f32>::new(channels);
    for ch in 0..channels {
        color[ch] = 0.0;
    }
    let mut batch = start;
    while batch < end {
        let idx = batch + lid;
        if idx < end {
            let base = list_splat[idx] as usize * stride;
            for k in 0..7usize {
                sh_geo[lid * 7 + k] = projected[base + k];
            }
            for ch in 0..channels {
                sh_color[lid * channels + ch] = projected[base + 8 + ch];
            }
        }
        sync_cube();
        let count = (end - batch).min(BATCH);
        for j in 0..count {
            if !done {
                let dx = pxf - sh_geo[j * 7];
                let dy = pyf - sh_geo[j * 7 + 1];
                let sigma = 0.5 * (sh_geo[j * 7 + 2] * dx * dx + sh_geo[j * 7 + 4] * dy * dy)
                    + sh_geo[j * 7 + 3] * dx * dy;
                if sigma >= 0.0 && sigma <= sigma_max {
                    let alpha = (sh_geo[j * 7 + 6] * (-sigma).exp()).min(ALPHA_MAX);
                    if alpha >= alpha_min && alpha > 0.0 {
                        let next_t = t * (1.0 - alpha);
                        if next_t < T_MIN {
                            done = true;
                        } else {
                            let w = alpha * t;
                            for ch in 0..channels {
                                color[ch] += sh_color[j * channels + ch] * w;
                            }
                            depth += sh_geo[j * 7 + 5] * w;
                            t = next_t;
                            last = (batch - start + j + 1) as u32;
                        }
                    }
                }
            }
        }
        // Stop early once no pixel of the tile is still accumulating.
        if lid == 0 {
            sh_busy[0] = 0;
        }
        sync_cube();
        if !done {
            sh_busy[0] = 1;
        }
        sync_cube();
        batch += BATCH;
        if sh_busy[0] == 0 {
            batch = end;
        }
    }
    if inside {
        let p = (y * width + x) as usize;
        let out = p * (channels + 2);
        for ch in 0..channels {
            image[out + ch] = color[ch] + t * background[ch];
        }
        image[out + channels] = 1.0 - t;
        image[out + channels + 1] = depth;
        final_transmittance[p] = t;
        contributors[p] = f32::cast_from(last);
    }
}

/// Backward of `blend_forward`: walks each tile's list back to front in lockstep, each pixel
/// computing its gradient contribution to the current entry, summed over the tile's pixels in
/// shared memory (a fixed order: deterministic, no float atomics) into `isect_grads`
/// (one `8 + C` row per intersection, projected-row layout, radius slot 0).
#[cube(launch)]
#[allow(clippy::too_many_arguments)]
pub fn blend_backward(
    projected: &[f32],
    tile_offsets: &[u32],
    list_splat: &[u32],
    background: &[f32],
    final_transmittance: &[f32],
    contributors: &[f32],
    grad_image: &[f32],
    isect_grads: &mut [f32],
    width: u32,
    height: u32,
    tiles_x: u32,
    sigma_max: f32,
    alpha_min: f32,
    #[comptime] channels: usize,
) {
    let stride = comptime!(8 + channels);
    let lanes = comptime!((BATCH / (8 + channels)).max(1));
    let tile = CUBE_POS;
    let lid = UNIT_POS as usize;
    let (x, y) = unit_pixel(tiles_x);
    let inside = x < width && y < height;
    let pxf = f32::cast_from(x) + 0.5;
    let pyf = f32::cast_from(y) + 0.5;
    let p = (y * width + x) as usize;

    let mut sh_geo = Shared::<[f32]>::new_slice(BATCH * 7);
    let mut sh_color = Shared::<[f32]>::new_slice(comptime!(BATCH * channels));
    let mut red = Shared::<[f32]>::new_slice(comptime!(BATCH * (8 + channels)));
    let mut red2 = Shared::<[f32]>::new_slice(comptime!(lanes * (8 + channels)));
    let mut sh_last = Shared::<[u32]>::new_slice(BATCH);

    let start = tile_offsets[tile] as usize;

    let mut t_final = 1.0f32;
    let mut last = 0usize;
    let mut g_alpha = 0.0f32;
    let mut g_depth = 0.0f32;
    let mut g_color = Array::<f32>::new(channels);
    let mut acc = Array::<f32>::new(channels);
    for ch in 0..channels {
        g_color[ch] = 0.0;
        acc[ch] = 0.0;
    }
    if inside {
        t_final = final_transmittance[p];
        last = u32::cast_from(contributors[p]) as usize;
        let g = p * (channels + 2);
        for ch in 0..channels {
            g_color[ch] = grad_image[g + ch];
            acc[ch] = background[ch] * t_final;
        }
        g_alpha = grad_image[g + channels];
        g_depth = grad_image[g + channels + 1];
    }
    // Entries past every pixel's last contributor add nothing: walk only up to the tile's max.
    let last_u32 = last as u32;
    sh_last[lid] = last_u32;
    sync_cube();
    // A runtime counter (a `const` expression here would be a compile-time value).
    let mut half = 128usize;
    while half > 0 {
        if lid < half {
            let mine = sh_last[lid];
            let other = sh_last[lid + half];
            sh_last[lid] = select(other > mine, other, mine);
        }
        sync_cube();
        half /= 2;
    }
    let tile_max = sh_last[0];
    let end = start + tile_max as usize;
    let mut acc_depth = 0.0f32;
    let mut t = t_final;
    let mut contrib = Array::<f32>::new(comptime!(8 + channels));

    // Batches from the back: entries [batch_start, batch_end).
    let mut batch_end = end;
    while batch_end > start {
        let count = (batch_end - start).min(BATCH);
        let batch_start = batch_end - count;
        if lid < count {
            let base = list_splat[batch_start + lid] as usize * stride;
            for k in 0..7usize {
                sh_geo[lid * 7 + k] = projected[base + k];
            }
            for ch in 0..channels {
                sh_color[lid * channels + ch] = projected[base + 8 + ch];
            }
        }
        sync_cube();
        for jj in 0..count {
            let j = count - 1 - jj;
            let entry = batch_start + j;
            for s in 0..stride {
                contrib[s] = 0.0;
            }
            if inside && entry - start < last {
                let ux = sh_geo[j * 7];
                let uy = sh_geo[j * 7 + 1];
                let ka = sh_geo[j * 7 + 2];
                let kb = sh_geo[j * 7 + 3];
                let kc = sh_geo[j * 7 + 4];
                let zd = sh_geo[j * 7 + 5];
                let op = sh_geo[j * 7 + 6];
                let dx = pxf - ux;
                let dy = pyf - uy;
                let sigma = 0.5 * (ka * dx * dx + kc * dy * dy) + kb * dx * dy;
                if sigma >= 0.0 && sigma <= sigma_max {
                    let fall = (-sigma).exp();
                    let raw = op * fall;
                    let alpha = raw.min(ALPHA_MAX);
                    if alpha >= alpha_min && alpha > 0.0 {
                        let one_minus = 1.0 - alpha;
                        let t_i = t / one_minus;
                        let w = alpha * t_i;
                        let mut dl_dalpha = g_alpha * t_final / one_minus
                            + g_depth * (zd * t_i - acc_depth / one_minus);
                        for ch in 0..channels {
                            let cval = sh_color[j * channels + ch];
                            contrib[8 + ch] = g_color[ch] * w;
                            dl_dalpha += g_color[ch] * (cval * t_i - acc[ch] / one_minus);
                            acc[ch] += cval * w;
                        }
                        contrib[5] = g_depth * w;
                        acc_depth += zd * w;
                        t = t_i;
                        if raw < ALPHA_MAX {
                            contrib[6] = dl_dalpha * fall;
                            let g_sigma = -dl_dalpha * alpha;
                            contrib[2] = g_sigma * 0.5 * dx * dx;
                            contrib[3] = g_sigma * dx * dy;
                            contrib[4] = g_sigma * 0.5 * dy * dy;
                            contrib[0] = -g_sigma * (ka * dx + kb * dy);
                            contrib[1] = -g_sigma * (kb * dx + kc * dy);
                        }
                    }
                }
            }
            // Sum the 256 pixels' contributions: per component, `lanes` strided partial sums,
            // then one unit per component adds the partials.
            for s in 0..stride {
                red[lid * stride + s] = contrib[s];
            }
            sync_cube();
            if lid < lanes * stride {
                let s = lid / lanes;
                let lane = lid % lanes;
                let mut partial = 0.0f32;
                let mut q = lane;
                while q < BATCH {
                    partial += red[q * stride + s];
                    q += lanes;
                }
                red2[s * lanes + lane] = partial;
            }
            sync_cube();
            if lid < stride {
                let mut total = 0.0f32;
                for lane in 0..lanes {
                    total += red2[lid * lanes + lane];
                }
                isect_grads[entry * stride + lid] = total;
            }
        }
        sync_cube();
        batch_end = batch_start;
    }
}
