//! Exclusive prefix sum of `u32` counts: a shared-memory scan per block of 256, recursively
//! over the block totals, then the block offsets added back.

use burn_cubecl::cubecl;
use cubecl::prelude::*;

pub const BLOCK: usize = 256;

/// Exclusive scan of each block of `BLOCK` values; `block_sums[b]` gets the block's total.
#[cube(launch)]
pub fn scan_blocks(input: &[u32], output: &mut [u32], block_sums: &mut [u32], n: u32) {
    let mut buf = Shared::<[u32]>::new_slice(BLOCK);
    let i = ABSOLUTE_POS;
    let lid = UNIT_POS as usize;
    let mut v = 0u32;
    if i < n as usize {
        v = input[i];
    }
    buf[lid] = v;
    sync_cube();
    // Hillis–Steele inclusive scan.
    let mut offset = 1usize;
    while offset < BLOCK {
        let mut add = 0u32;
        if lid >= offset {
            add = buf[lid - offset];
        }
        sync_cube();
        buf[lid] += add;
        sync_cube();
        offset *= 2;
    }
    if i < n as usize {
        output[i] = buf[lid] - v;
    }
    if lid == BLOCK - 1 {
        block_sums[CUBE_POS] = buf[lid];
    }
}

/// Adds each block's offset to its values.
#[cube(launch)]
pub fn add_block_offsets(values: &mut [u32], block_offsets: &[u32], n: u32) {
    let i = ABSOLUTE_POS;
    if i < n as usize {
        values[i] += block_offsets[i / BLOCK];
    }
}
