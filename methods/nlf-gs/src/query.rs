//! NLF-GS's template-guided feature query and cross-view fusion, batched over views:
//! Gaussian centres are projected into every view (Eq. 2 of NLF-GS), features are read there by
//! bilinear sampling (Eq. 3), and the per-view features are averaged with geometry-aware
//! weights (Eq. 4): orientation `max(0, n · d_v)` times a binary occlusion test against a depth
//! map of the posed body, in the four variants of its Table 6.
//!
//! Conventions: OpenCV cameras (x right, y down, z forward), world-to-camera `[R | t]`, pixel
//! centres at `+0.5`, so pixel coordinate `u ∈ [0, W]` maps to grid coordinate `2u / W − 1`
//! (`align_corners = false`) whatever the feature map's resolution.

use burn::tensor::ops::{GridSampleOptions, InterpolateMode};
use burn::tensor::{Bool, Tensor, TensorData};

/// The four fusion variants of Table 6 of NLF-GS.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize, clap::ValueEnum,
)]
#[serde(rename_all = "lowercase")]
pub enum Fusion {
    /// Every view that sees the point (in front, inside the image) weighs the same.
    Average,
    /// Binary occlusion test only.
    Occlusion,
    /// `max(0, n · d_v)` only.
    Orientation,
    /// Orientation × occlusion (the paper's method).
    Full,
}

/// `V` pinhole views as tensors (so camera refinement can flow through them).
#[derive(Debug, Clone)]
pub struct Views {
    /// `[V, 4]`: fx, fy, cx, cy in pixels.
    pub intrinsics: Tensor<2>,
    /// `[V, 3, 4]` world-to-camera `[R | t]`.
    pub world_to_camera: Tensor<3>,
    /// Image width and height in pixels (shared by the views).
    pub size: [usize; 2],
}

/// Where `P` points land in `V` views.
#[derive(Debug, Clone)]
pub struct Projection {
    /// `[V, P, 3]` camera-space positions.
    pub camera: Tensor<3>,
    /// `[V, P, 2]` pixel coordinates (Eq. 2, dehomogenised).
    pub pixels: Tensor<3>,
    /// `[V, P]` in front of the camera and inside the image.
    pub inside: Tensor<2, Bool>,
}

/// Eq. 2 of NLF-GS: `ũ = K (R x + t)`, `u = (ũ_x / ũ_z, ũ_y / ũ_z)`, for `[P, 3]` points.
pub fn project(points: Tensor<2>, views: &Views) -> Projection {
    let [p, _] = points.dims();
    let [v, _, _] = views.world_to_camera.dims();
    let r = views.world_to_camera.clone().slice([0..v, 0..3, 0..3]);
    let t = views.world_to_camera.clone().slice([0..v, 0..3, 3..4]); // [V, 3, 1]
    let x = points.transpose().unsqueeze_dim::<3>(0).expand([v, 3, p]); // [V, 3, P]
    let camera = (r.matmul(x) + t).swap_dims(1, 2); // [V, P, 3]
    let z = camera.clone().slice([0..v, 0..p, 2..3]);
    let safe_z = z.clone().clamp_min(1e-6);
    let k = views.intrinsics.clone();
    let f = k.clone().slice([0..v, 0..2]).unsqueeze_dim::<3>(1); // [V, 1, 2]
    let c = k.slice([0..v, 2..4]).unsqueeze_dim::<3>(1);
    let pixels = camera.clone().slice([0..v, 0..p, 0..2]) / safe_z * f + c;
    let [w, h] = views.size;
    let u = pixels.clone().slice([0..v, 0..p, 0..1]).reshape([v, p]);
    let y = pixels.clone().slice([0..v, 0..p, 1..2]).reshape([v, p]);
    let inside = z
        .reshape([v, p])
        .greater_elem(1e-6)
        .bool_and(u.clone().greater_equal_elem(0.0))
        .bool_and(u.lower_elem(w as f64))
        .bool_and(y.clone().greater_equal_elem(0.0))
        .bool_and(y.lower_elem(h as f64));
    Projection {
        camera,
        pixels,
        inside,
    }
}

/// Eq. 3 of NLF-GS: bilinear samples of `[V, C, h, w]` feature maps at the projected pixels →
/// `[V, P, C]` (zero outside the image). Reads the four neighbouring feature rows by index
/// (`select`): on Flex, for 56k points, 256 channels and 3 views, 0.38 s forward and 0.67 s
/// backward against `grid_sample_2d`'s 2.9 s and 3.1 s. [`sample_by_grid`] is the reference it
/// is tested against.
pub fn sample(features: Tensor<4>, projection: &Projection, size: [usize; 2]) -> Tensor<3> {
    let [v, c, h, w] = features.dims();
    let [_, p, _] = projection.pixels.dims();
    let device = features.device();
    // Feature-map coordinates whose integers are feature-pixel centres.
    let coordinate = |axis: usize, scale: f64| {
        projection
            .pixels
            .clone()
            .slice([0..v, 0..p, axis..axis + 1])
            .reshape([v * p])
            * scale
            - 0.5
    };
    let x = coordinate(0, w as f64 / size[0] as f64);
    let y = coordinate(1, h as f64 / size[1] as f64);
    let x0 = x.clone().detach().floor();
    let y0 = y.clone().detach().floor();
    let fx = x - x0.clone();
    let fy = y - y0.clone();
    let view_start: Vec<f32> = (0..v)
        .flat_map(|k| std::iter::repeat_n((k * h * w) as f32, p))
        .collect();
    let view_start = Tensor::<1>::from_data(TensorData::new(view_start, [v * p]), &device);
    let rows_from_texel = features.permute([0, 2, 3, 1]).reshape([v * h * w, c]);
    let mut out: Option<Tensor<2>> = None;
    for (dx, dy) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)] {
        let xi = x0.clone() + dx;
        let yi = y0.clone() + dy;
        let valid = xi
            .clone()
            .greater_equal_elem(0.0)
            .bool_and(xi.clone().lower_elem(w as f64))
            .bool_and(yi.clone().greater_equal_elem(0.0))
            .bool_and(yi.clone().lower_elem(h as f64));
        let texel = view_start.clone()
            + yi.clamp(0.0, (h - 1) as f64) * w as f64
            + xi.clamp(0.0, (w - 1) as f64);
        let wx = if dx == 0.0 {
            -fx.clone() + 1.0
        } else {
            fx.clone()
        };
        let wy = if dy == 0.0 {
            -fy.clone() + 1.0
        } else {
            fy.clone()
        };
        let weight = (wx * wy * valid.float()).reshape([v * p, 1]);
        let term = rows_from_texel.clone().select(0, texel.int()) * weight;
        out = Some(match out {
            Some(acc) => acc + term,
            None => term,
        });
    }
    out.expect("four corners").reshape([v, p, c])
}

/// [`sample`] through `grid_sample_2d` (`align_corners = false`, zero padding): the plain
/// reference.
pub fn sample_by_grid(features: Tensor<4>, projection: &Projection, size: [usize; 2]) -> Tensor<3> {
    let [v, p, _] = projection.pixels.dims();
    let device = features.device();
    let scale = Tensor::<1>::from_floats([2.0 / size[0] as f32, 2.0 / size[1] as f32], &device)
        .reshape([1, 1, 2]);
    let grid = (projection.pixels.clone() * scale - 1.0).reshape([v, 1, p, 2]);
    let sampled = features.grid_sample_2d(grid, GridSampleOptions::new(InterpolateMode::Bilinear));
    let [_, c, _, _] = sampled.dims();
    sampled.reshape([v, c, p]).swap_dims(1, 2)
}

/// Per-view weights `[V, P]` of Eq. 4 for `variant`: `normals` `[P, 3]` (unit, world),
/// `centres` `[V, 3]` camera centres (world), `depth` `[V, H, W]` depth maps of the posed body
/// (camera z, metres; ∞ where empty) with relative tolerance `tolerance` for the occlusion test.
///
/// # Panics
/// If `variant` has the occlusion test and `depth` is `None` (the variant would silently
/// become another).
pub fn weights(
    variant: Fusion,
    points: Tensor<2>,
    normals: Tensor<2>,
    centres: Tensor<2>,
    projection: &Projection,
    depth: Option<Tensor<3>>,
    tolerance: f64,
) -> Tensor<2> {
    let [v, p, _] = projection.camera.dims();
    let mut w = projection.inside.clone().float();
    if matches!(variant, Fusion::Orientation | Fusion::Full) {
        // d_v: unit direction from the point towards camera v.
        let d = centres.unsqueeze_dim::<3>(1).expand([v, p, 3])
            - points.unsqueeze_dim::<3>(0).expand([v, p, 3]);
        let d = d.clone() / (d.powi_scalar(2).sum_dim(2).sqrt() + 1e-12);
        let cos = (d * normals.unsqueeze_dim::<3>(0).expand([v, p, 3]))
            .sum_dim(2)
            .reshape([v, p]);
        w = w * cos.clamp_min(0.0);
    }
    if matches!(variant, Fusion::Occlusion | Fusion::Full) {
        let depth = depth.unwrap_or_else(|| {
            panic!("fusion `{variant:?}` tests occlusion and needs the input views' depth maps")
        });
        let [_, h, width] = depth.dims();
        // Nearest depth pixel under each projection.
        let px = projection.pixels.clone().detach();
        let col = px
            .clone()
            .slice([0..v, 0..p, 0..1])
            .reshape([v, p])
            .floor()
            .clamp(0.0, (width - 1) as f64);
        let row = px
            .slice([0..v, 0..p, 1..2])
            .reshape([v, p])
            .floor()
            .clamp(0.0, (h - 1) as f64);
        let flat = (row * width as f64 + col).int();
        let surface = depth.reshape([v, h * width]).gather(1, flat);
        let z = projection
            .camera
            .clone()
            .detach()
            .slice([0..v, 0..p, 2..3])
            .reshape([v, p]);
        let visible = z.lower_equal(surface * (1.0 + tolerance));
        w = w * visible.float();
    }
    w
}

/// The fused feature `[P, C]`: `Σ_v w_v q_v / Σ_v w_v` (zero where no view counts).
pub fn fuse(features: Tensor<3>, weights: Tensor<2>) -> Tensor<2> {
    let [v, p, c] = features.dims();
    let w = weights.reshape([v, p, 1]);
    let total = w.clone().sum_dim(0).reshape([p, 1]);
    let sum = (features * w).sum_dim(0).reshape([p, c]);
    sum / total.clamp_min(1e-6)
}

/// [`sample`] then [`fuse`] one view at a time, so that the `[V, P, C]` stack of per-view
/// features never exists (with 56k Gaussians, 256 channels and 3 views it would take 172 MB,
/// over lavapipe's largest buffer). Same result.
pub fn sample_and_fuse(
    features: Tensor<4>,
    projection: &Projection,
    weights: Tensor<2>,
    size: [usize; 2],
) -> Tensor<2> {
    let [v, c, h, w] = features.dims();
    let [_, p, _] = projection.pixels.dims();
    let mut sum: Option<Tensor<2>> = None;
    for view in 0..v {
        let one = Projection {
            camera: projection
                .camera
                .clone()
                .slice([view..view + 1, 0..p, 0..3]),
            pixels: projection
                .pixels
                .clone()
                .slice([view..view + 1, 0..p, 0..2]),
            inside: projection.inside.clone().slice([view..view + 1, 0..p]),
        };
        let q = sample(
            features.clone().slice([view..view + 1, 0..c, 0..h, 0..w]),
            &one,
            size,
        )
        .reshape([p, c]);
        let wv = weights
            .clone()
            .slice([view..view + 1, 0..p])
            .reshape([p, 1]);
        let term = q * wv;
        sum = Some(match sum {
            Some(s) => s + term,
            None => term,
        });
    }
    let total = weights.sum_dim(0).reshape([p, 1]);
    sum.expect("at least one view") / total.clamp_min(1e-6)
}
