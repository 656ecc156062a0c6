//! The GPU rasterizer: launches the CubeCL kernels of `kernels` on Burn's `CubeBackend`
//! (wgpu, and CUDA from the same kernels); Fusion wraps it lazily through the metadata in
//! `backend`.
//!
//! One host read-back per call: the number of (tile, splat) intersections, to size the lists.

use crate::backend::{SplatBackend, SplatForward, SplatInputGrads, SplatInputs, SplatSaved};
use crate::camera::{ColorMode, RasterMode, RasterSettings};
use crate::cpu::proj_stride;
use crate::kernels::{bin, blend, camera, project, scan};
use burn::backend::TensorMetadata;
use burn::backend::ops::FloatTensorOps;
use burn::tensor::{DType, Shape};
use burn_cubecl::CubeBackend;
use burn_cubecl::cubecl::CubeElement;
use burn_cubecl::cubecl::client::Client;
use burn_cubecl::cubecl::prelude::*;
use burn_cubecl::kernel::into_contiguous;
use burn_cubecl::ops::numeric::{empty_device_contiguous_dtype, zeros_client};
use burn_cubecl::tensor::CubeTensor;

const UNITS: u32 = 256;

/// Largest colour channel count the GPU kernels take (shared memory per tile grows with it).
pub const MAX_GPU_CHANNELS: usize = 16;

fn f32_input(t: CubeTensor) -> CubeTensor {
    let t = into_contiguous(t);
    assert_eq!(t.dtype, DType::F32, "the GPU rasterizer takes f32 tensors");
    t
}

fn buffer(t: &CubeTensor) -> BufferArg {
    t.clone().into_buffer_arg()
}

fn alloc(like: &CubeTensor, shape: Shape, dtype: DType) -> CubeTensor {
    empty_device_contiguous_dtype(like.client.clone(), like.device.clone(), shape, dtype)
}

fn zeros_u32(like: &CubeTensor, len: usize) -> CubeTensor {
    zeros_client(
        like.client.clone(),
        like.device.clone(),
        Shape::new([len]),
        DType::U32,
    )
}

fn upload_f32(like: &CubeTensor, values: &[f32]) -> CubeTensor {
    let handle = like.client.create_from_slice(f32::as_bytes(values));
    CubeTensor::new_contiguous(
        like.client.clone(),
        like.device.clone(),
        Shape::new([values.len()]),
        handle,
        DType::F32,
    )
}

fn elementwise(client: &Client, n: usize) -> (CubeCount, CubeDim) {
    let dim = CubeDim::new_1d(UNITS);
    (
        burn_cubecl::cubecl::calculate_cube_count_elemwise(client, n.max(1), dim),
        dim,
    )
}

/// Exclusive prefix sum of a `u32` tensor of length `n`.
fn exclusive_scan(input: &CubeTensor, n: usize) -> CubeTensor {
    let blocks = n.div_ceil(scan::BLOCK).max(1);
    let out = alloc(input, Shape::new([n.max(1)]), DType::U32);
    let sums = alloc(input, Shape::new([blocks]), DType::U32);
    scan::scan_blocks::launch(
        &input.client,
        CubeCount::new_1d(blocks as u32),
        CubeDim::new_1d(scan::BLOCK as u32),
        buffer(input),
        buffer(&out),
        buffer(&sums),
        n as u32,
    );
    if blocks > 1 {
        let offsets = exclusive_scan(&sums, blocks);
        let (count, dim) = elementwise(&input.client, n);
        scan::add_block_offsets::launch(
            &input.client,
            count,
            dim,
            buffer(&out),
            buffer(&offsets),
            n as u32,
        );
    }
    out
}

fn read_u32_at(t: &CubeTensor, index: usize) -> u32 {
    let handle = t
        .handle
        .clone()
        .offset_start((index * 4) as u64)
        .offset_end(0);
    let bytes = t
        .client
        .read_one(handle)
        .expect("reading the intersection count");
    u32::from_bytes(&bytes)[0]
}

/// Tile lists: `tile_offsets` (`tiles + 1`), per-intersection splat ids (tile-major, nearest
/// first), and the maps between splat-major and tile-major intersection order.
struct Bins {
    tile_offsets: CubeTensor,
    list_splat: CubeTensor,
    list_emit: CubeTensor,
    splat_offsets: CubeTensor,
    n_isect: usize,
}

fn bin_splats(
    projected: &CubeTensor,
    tiles_touched: &CubeTensor,
    n: usize,
    settings: &RasterSettings,
    channels: usize,
) -> Bins {
    let client = &projected.client;
    let (tiles_x, tiles_y) = tiles(settings);
    let n_tiles = (tiles_x * tiles_y) as usize;
    let stride = proj_stride(channels);
    let splat_offsets = exclusive_scan(tiles_touched, n + 1);
    let n_isect = read_u32_at(&splat_offsets, n) as usize;

    let tile_counts = zeros_u32(projected, n_tiles + 1);
    let (count, dim) = elementwise(client, n);
    bin::tile_histogram::launch(
        client,
        count.clone(),
        dim,
        buffer(projected),
        buffer(&tile_counts),
        n as u32,
        tiles_x,
        tiles_y,
        stride,
    );
    let tile_offsets = exclusive_scan(&tile_counts, n_tiles + 1);
    let cursor = alloc(projected, Shape::new([n_tiles + 1]), DType::U32);
    let (count_t, dim_t) = elementwise(client, n_tiles + 1);
    bin::copy_u32::launch(
        client,
        count_t,
        dim_t,
        buffer(&tile_offsets),
        buffer(&cursor),
        (n_tiles + 1) as u32,
    );

    let len = n_isect.max(1);
    let list_depth = alloc(projected, Shape::new([len]), DType::F32);
    let list_splat = alloc(projected, Shape::new([len]), DType::U32);
    let list_emit = alloc(projected, Shape::new([len]), DType::U32);
    bin::emit_intersections::launch(
        client,
        count,
        dim,
        buffer(projected),
        buffer(&splat_offsets),
        buffer(&cursor),
        buffer(&list_depth),
        buffer(&list_splat),
        buffer(&list_emit),
        n as u32,
        tiles_x,
        tiles_y,
        stride,
    );
    bin::sort_tiles::launch(
        client,
        CubeCount::Static(tiles_x, tiles_y, 1),
        CubeDim::new_1d(UNITS),
        buffer(&tile_offsets),
        buffer(&list_depth),
        buffer(&list_splat),
        buffer(&list_emit),
    );
    Bins {
        tile_offsets,
        list_splat,
        list_emit,
        splat_offsets,
        n_isect,
    }
}

fn tiles(settings: &RasterSettings) -> (u32, u32) {
    let t = blend::TILE;
    (
        settings.camera.width.div_ceil(t),
        settings.camera.height.div_ceil(t),
    )
}

fn color_mode(settings: &RasterSettings) -> u32 {
    match settings.color {
        ColorMode::Sh { degree } => degree,
        ColorMode::Features => project::FEATURES,
    }
}

struct Prepared {
    means: CubeTensor,
    quats: CubeTensor,
    log_scales: CubeTensor,
    opacity_logits: CubeTensor,
    colors: CubeTensor,
    background: CubeTensor,
    offsets: CubeTensor,
    camera: CubeTensor,
    n: usize,
    coeffs: usize,
    channels: usize,
}

fn prepare(inputs: SplatInputs<CubeBackend>, settings: &RasterSettings) -> Prepared {
    let [n, coeffs, channels] = inputs.colors.shape().dims::<3>();
    assert!(
        channels <= MAX_GPU_CHANNELS,
        "the GPU rasterizer renders at most {MAX_GPU_CHANNELS} channels, got {channels}"
    );
    let means = f32_input(inputs.means);
    let camera = upload_f32(&means, &camera::pack(settings));
    Prepared {
        quats: f32_input(inputs.quats),
        log_scales: f32_input(inputs.log_scales),
        opacity_logits: f32_input(inputs.opacity_logits),
        colors: f32_input(inputs.colors),
        background: f32_input(inputs.background),
        offsets: f32_input(inputs.screen_offsets),
        means,
        camera,
        n,
        coeffs,
        channels,
    }
}

/// Projection on the GPU: `[N + 1]` tile counts (last 0) and `[N, 8 + C]` rows.
fn project_all(p: &Prepared, settings: &RasterSettings) -> (CubeTensor, CubeTensor) {
    let stride = proj_stride(p.channels);
    let (tiles_x, tiles_y) = tiles(settings);
    let projected = alloc(&p.means, Shape::new([p.n.max(1), stride]), DType::F32);
    let tiles_touched = zeros_u32(&p.means, p.n + 1);
    let (count, dim) = elementwise(&p.means.client, p.n);
    project::project_forward::launch(
        &p.means.client,
        count,
        dim,
        buffer(&p.means),
        buffer(&p.quats),
        buffer(&p.log_scales),
        buffer(&p.opacity_logits),
        buffer(&p.colors),
        buffer(&p.offsets),
        buffer(&p.camera),
        buffer(&projected),
        buffer(&tiles_touched),
        p.n as u32,
        tiles_x,
        tiles_y,
        p.channels,
        p.coeffs,
        color_mode(settings),
        settings.mode == RasterMode::AntiAliased,
    );
    (projected, tiles_touched)
}

fn with_shape(t: CubeTensor, shape: Shape) -> CubeTensor {
    CubeBackend::float_reshape(t, shape)
}

impl SplatBackend for CubeBackend {
    fn splat_forward(inputs: SplatInputs<Self>, settings: RasterSettings) -> SplatForward<Self> {
        let p = prepare(inputs, &settings);
        let (h, w) = (
            settings.camera.height as usize,
            settings.camera.width as usize,
        );
        let stride = proj_stride(p.channels);
        let (projected, tiles_touched) = project_all(&p, &settings);
        let bins = bin_splats(&projected, &tiles_touched, p.n, &settings, p.channels);
        let image = alloc(&p.means, Shape::new([h, w, p.channels + 2]), DType::F32);
        let final_transmittance = alloc(&p.means, Shape::new([h, w]), DType::F32);
        let contributors = alloc(&p.means, Shape::new([h, w]), DType::F32);
        let (tiles_x, tiles_y) = tiles(&settings);
        let clip = settings.clip_sigmas;
        blend::blend_forward::launch(
            &p.means.client,
            CubeCount::Static(tiles_x, tiles_y, 1),
            CubeDim::new_1d(UNITS),
            buffer(&projected),
            buffer(&bins.tile_offsets),
            buffer(&bins.list_splat),
            buffer(&p.background),
            buffer(&image),
            buffer(&final_transmittance),
            buffer(&contributors),
            w as u32,
            h as u32,
            tiles_x,
            0.5 * clip * clip,
            settings.alpha_min,
            p.channels,
        );
        let projected = if p.n == 0 {
            CubeBackend::float_slice(
                projected,
                &[
                    burn::tensor::Slice::from(0..0),
                    burn::tensor::Slice::from(0..stride),
                ],
            )
        } else {
            projected
        };
        SplatForward {
            image,
            saved: SplatSaved {
                projected,
                final_transmittance,
                contributors,
            },
        }
    }

    fn splat_backward(
        inputs: SplatInputs<Self>,
        saved: SplatSaved<Self>,
        grad_image: FloatTensor<Self>,
        settings: RasterSettings,
    ) -> SplatInputGrads<Self> {
        let shapes = inputs.shapes();
        let p = prepare(inputs, &settings);
        let (h, w) = (
            settings.camera.height as usize,
            settings.camera.width as usize,
        );
        let c = p.channels;
        let stride = proj_stride(c);
        let client = p.means.client.clone();
        // Recompute the tile lists (deterministic), from fresh tile counts.
        let (projected, tiles_touched) = project_all(&p, &settings);
        let bins = bin_splats(&projected, &tiles_touched, p.n, &settings, c);
        let final_transmittance = f32_input(saved.final_transmittance);
        let contributors = f32_input(saved.contributors);
        let grad_image = f32_input(grad_image);

        // Zeroed: the blend backward skips entries past the tile's last contributor.
        let isect_grads = zeros_client(
            client.clone(),
            p.means.device.clone(),
            Shape::new([bins.n_isect.max(1) * stride]),
            DType::F32,
        );
        let (tiles_x, tiles_y) = tiles(&settings);
        let clip = settings.clip_sigmas;
        blend::blend_backward::launch(
            &client,
            CubeCount::Static(tiles_x, tiles_y, 1),
            CubeDim::new_1d(UNITS),
            buffer(&projected),
            buffer(&bins.tile_offsets),
            buffer(&bins.list_splat),
            buffer(&p.background),
            buffer(&final_transmittance),
            buffer(&contributors),
            buffer(&grad_image),
            buffer(&isect_grads),
            w as u32,
            h as u32,
            tiles_x,
            0.5 * clip * clip,
            settings.alpha_min,
            c,
        );
        let sorted_from_emit = alloc(&p.means, Shape::new([bins.n_isect.max(1)]), DType::U32);
        let (count_i, dim_i) = elementwise(&client, bins.n_isect);
        bin::invert_emit::launch(
            &client,
            count_i,
            dim_i,
            buffer(&bins.list_emit),
            buffer(&sorted_from_emit),
            bins.n_isect as u32,
        );
        let grad_projected = alloc(&p.means, Shape::new([p.n.max(1) * stride]), DType::F32);
        let (count, dim) = elementwise(&client, p.n);
        bin::gather_splat_grads::launch(
            &client,
            count.clone(),
            dim,
            buffer(&isect_grads),
            buffer(&bins.splat_offsets),
            buffer(&sorted_from_emit),
            buffer(&grad_projected),
            p.n as u32,
            stride,
        );

        let k = p.coeffs * c;
        let g_means = alloc(&p.means, Shape::new([p.n.max(1) * 3]), DType::F32);
        let g_quats = alloc(&p.means, Shape::new([p.n.max(1) * 4]), DType::F32);
        let g_scales = alloc(&p.means, Shape::new([p.n.max(1) * 3]), DType::F32);
        let g_opacity = alloc(&p.means, Shape::new([p.n.max(1)]), DType::F32);
        let g_colors = alloc(&p.means, Shape::new([p.n.max(1) * k]), DType::F32);
        let g_offsets = alloc(&p.means, Shape::new([p.n.max(1) * 2]), DType::F32);
        project::project_backward::launch(
            &client,
            count,
            dim,
            buffer(&p.means),
            buffer(&p.quats),
            buffer(&p.log_scales),
            buffer(&p.opacity_logits),
            buffer(&p.colors),
            buffer(&p.offsets),
            buffer(&p.camera),
            buffer(&grad_projected),
            buffer(&g_means),
            buffer(&g_quats),
            buffer(&g_scales),
            buffer(&g_opacity),
            buffer(&g_colors),
            buffer(&g_offsets),
            p.n as u32,
            c,
            p.coeffs,
            color_mode(&settings),
            settings.mode == RasterMode::AntiAliased,
        );

        // dL/dbackground = Σ_pixels dL/dcolour · T_final.
        let g_color = CubeBackend::float_slice(
            grad_image,
            &[
                burn::tensor::Slice::from(0..h),
                burn::tensor::Slice::from(0..w),
                burn::tensor::Slice::from(0..c),
            ],
        );
        let t = with_shape(final_transmittance, Shape::new([h, w, 1]));
        let weighted = CubeBackend::float_mul(g_color, t);
        let g_background = with_shape(
            CubeBackend::float_sum_dim(with_shape(weighted, Shape::new([h * w, c])), 0),
            Shape::new([c]),
        );

        let [
            means,
            quats,
            log_scales,
            opacity_logits,
            colors,
            _,
            screen_offsets,
        ] = shapes;
        let fit = |t: CubeTensor, shape: Shape| {
            if p.n == 0 {
                CubeBackend::float_zeros(shape, &t.device, burn::tensor::FloatDType::F32)
            } else {
                with_shape(t, shape)
            }
        };
        SplatInputGrads {
            means: fit(g_means, means),
            quats: fit(g_quats, quats),
            log_scales: fit(g_scales, log_scales),
            opacity_logits: fit(g_opacity, opacity_logits),
            colors: fit(g_colors, colors),
            background: g_background,
            screen_offsets: fit(g_offsets, screen_offsets),
        }
    }
}

use burn::backend::tensor::FloatTensor;
