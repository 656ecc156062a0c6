//! The light volume of Illum (§3.2, Eq. 6): a world-space grid of probes, each holding SH
//! radiance coefficients `c_k` `[K, 3]` (the rasterizer's real basis and signs, no `+0.5`:
//! `L_k(ω) = Σ_lm c_k,lm Y_lm(ω)`) and a latent lighting feature `z_k` for the shadow decoder
//! (Eq. 8).
//!
//! Eq. 6 blends the radiance of the `n` probes around a point. The spec's choices: the `n = 8`
//! corners of the point's grid cell with trilinear weights (`Σw = 1`), queries clamped to the
//! grid. Radiance is linear in the coefficients, so interpolating the coefficients once per
//! point and evaluating afterwards equals evaluating every probe and interpolating the radiance
//! (the spec's "Linearity"); [`LightVolume::interpolate`] therefore returns blended coefficients
//! (and latents). Eq. 13's probe smoothness lives here too ([`LightVolume::probe_smoothness`]),
//! since it needs the grid's face-neighbours.
//!
//! Initialisation (spec §3): DC `= √(4π) = 1/Y₀₀` in every colour channel (uniform unit
//! radiance), higher bands 0, latents `~ N(0, 0.01²)` from a seed.
//!
//! A probe's coefficients are `c_k = e + r_k`: a global SH environment `e` shared by every
//! probe plus the probe's own `r_k`. A new volume has `e = 0`, so `r_k` is the whole probe, as
//! in the paper. [`LightVolume::split_environment`] moves the probes' mean into `e` (our
//! choice, `light.shared_environment`, on by default): the trainer then fits one environment
//! for the whole scene, which every pixel's gradient reaches, with the probes as residuals on
//! it. The light field is the same; only how it is learned changes. Eq. 13 sees only
//! differences between probes, so it smooths the residuals and leaves `e` free.
//!
//! Each Burn-ops function has a scalar f64 reference beside it for the tests:
//! [`interpolate_reference`] (a sum of tent functions over every probe, not a corner lookup) and
//! [`probe_smoothness_reference`].

use crate::IllumError;
use burn::module::{Module, Param};
use burn::tensor::{Device, Int, Tensor, TensorData};
use splatzoo_rasterizer::sh::{SH_C0, coeff_count};

/// The DC coefficient of uniform unit radiance: `√(4π) = 1/Y₀₀`, so `c₀ Y₀₀ = 1`.
pub const UNIT_RADIANCE_DC: f64 = 1.0 / SH_C0;

/// Standard deviation of the initial latents (spec §3).
pub const LATENT_INIT_STD: f64 = 0.01;

/// Grid face-neighbours of a probe at most (±x, ±y, ±z).
const FACE_NEIGHBOURS: usize = 6;

/// A regular probe grid: probe `(i, j, k)` sits at `origin + spacing · (i, j, k)`, and its
/// index is `i + dims₀ (j + dims₁ k)` (x fastest).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProbeGrid {
    /// World position of probe `(0, 0, 0)`.
    pub origin: [f64; 3],
    /// Distance between neighbouring probes, the same on every axis.
    pub spacing: f64,
    /// Probes per axis (each ≥ 1).
    pub dims: [usize; 3],
}

impl ProbeGrid {
    /// The grid covering the box `[min, max]` padded by `pad` on every side (spec §2, Eq. 6:
    /// the human's AABB ∪ the shadow boxes, padded `0.3·H`, spacing `0.15·H`), centred on it.
    /// When an axis would need more than `max_per_axis` probes (spec: 32), the spacing is
    /// enlarged until the widest axis fits exactly. The grid reaches the padded box to within
    /// `1e-9` spacings; queries beyond are clamped anyway.
    pub fn covering(
        min: [f64; 3],
        max: [f64; 3],
        pad: f64,
        spacing: f64,
        max_per_axis: usize,
    ) -> Result<Self, IllumError> {
        if !(spacing.is_finite() && spacing > 0.0) {
            return Err(IllumError::input(
                "probe spacing",
                format!("must be positive and finite, got {spacing}"),
            ));
        }
        if !(pad.is_finite() && pad >= 0.0) {
            return Err(IllumError::input(
                "light-volume padding",
                format!("must be finite and ≥ 0, got {pad}"),
            ));
        }
        if max_per_axis == 0 {
            return Err(IllumError::input("probes per axis", "must be at least 1"));
        }
        let lo = [0, 1, 2].map(|a| min[a] - pad);
        let hi = [0, 1, 2].map(|a| max[a] + pad);
        let extent = [0, 1, 2].map(|a| hi[a] - lo[a]);
        for a in 0..3 {
            if !(min[a].is_finite() && max[a].is_finite() && extent[a].is_finite()) {
                return Err(IllumError::input(
                    "light-volume bounds",
                    format!("min {min:?} and max {max:?} must be finite"),
                ));
            }
            if min[a] > max[a] {
                return Err(IllumError::input(
                    "light-volume bounds",
                    format!("min {} exceeds max {} on axis {a}", min[a], max[a]),
                ));
            }
        }
        // Probes along an extent: enough cells of `s` to span it (less a rounding tolerance).
        let probes = |s: f64| extent.map(|e| (e / s - 1e-9).ceil().max(0.0) as usize + 1);
        let widest = extent.iter().copied().fold(0.0, f64::max);
        let mut spacing = spacing;
        if probes(spacing).iter().any(|&n| n > max_per_axis) {
            if max_per_axis == 1 {
                return Err(IllumError::input(
                    "probes per axis",
                    format!("one probe per axis cannot span an extent of {widest}"),
                ));
            }
            spacing = widest / (max_per_axis - 1) as f64;
        }
        let dims = probes(spacing);
        let origin =
            [0, 1, 2].map(|a| 0.5 * (lo[a] + hi[a]) - 0.5 * (dims[a] - 1) as f64 * spacing);
        Ok(Self {
            origin,
            spacing,
            dims,
        })
    }

    /// Checks the grid can hold probes: finite origin, positive finite spacing, every axis at
    /// least one probe, and a probe count that fits in memory indices.
    pub fn validate(&self) -> Result<(), IllumError> {
        if !(self.spacing.is_finite() && self.spacing > 0.0) {
            return Err(IllumError::input(
                "probe spacing",
                format!("must be positive and finite, got {}", self.spacing),
            ));
        }
        if self.origin.iter().any(|v| !v.is_finite()) {
            return Err(IllumError::input(
                "probe grid origin",
                format!("must be finite, got {:?}", self.origin),
            ));
        }
        let count = self.dims.iter().try_fold(1usize, |n, &d| n.checked_mul(d));
        match count {
            Some(n) if n > 0 && n <= i64::MAX as usize => Ok(()),
            _ => Err(IllumError::input(
                "probe grid",
                format!("dims {:?} must each be ≥ 1 (and not overflow)", self.dims),
            )),
        }
    }

    /// Number of probes `P`.
    pub fn count(&self) -> usize {
        self.dims.iter().product()
    }

    /// The index of probe `(i, j, k)`.
    pub fn index(&self, cell: [usize; 3]) -> usize {
        cell[0] + self.dims[0] * (cell[1] + self.dims[1] * cell[2])
    }

    /// The grid coordinates `(i, j, k)` of probe `index`.
    pub fn cell(&self, index: usize) -> [usize; 3] {
        let [dx, dy, _] = self.dims;
        [index % dx, (index / dx) % dy, index / (dx * dy)]
    }

    /// The world position of probe `index`.
    pub fn position(&self, index: usize) -> [f64; 3] {
        let cell = self.cell(index);
        [0, 1, 2].map(|a| self.origin[a] + self.spacing * cell[a] as f64)
    }

    /// The face-neighbours of probe `index` (≤ 6; fewer at the border), ordered −x, +x, −y,
    /// +y, −z, +z.
    pub fn face_neighbours(&self, index: usize) -> Vec<usize> {
        let cell = self.cell(index);
        let mut out = Vec::with_capacity(FACE_NEIGHBOURS);
        for a in 0..3 {
            if cell[a] > 0 {
                let mut c = cell;
                c[a] -= 1;
                out.push(self.index(c));
            }
            if cell[a] + 1 < self.dims[a] {
                let mut c = cell;
                c[a] += 1;
                out.push(self.index(c));
            }
        }
        out
    }

    /// The 8 cell corners and trilinear weights of `[N, 3]` world points (Eq. 6 with `n = 8`):
    /// probe indices `[N, 8]` and weights `[N, 8]` (≥ 0, summing to 1). Corner `c` has bit `a`
    /// set when it is the upper probe along axis `a`. Coordinates are clamped to the grid (a
    /// query outside reads the nearest boundary point); NaN reads as the origin. An axis with
    /// one probe has a single, zero-width cell: both corners along it are that probe. The
    /// weights are differentiable in the points within a cell.
    pub fn corner_weights(&self, points: Tensor<2>) -> (Tensor<2, Int>, Tensor<2>) {
        let [n, d] = points.dims();
        assert_eq!(
            d, 3,
            "corner_weights: points must be [N, 3], got [{n}, {d}]"
        );
        // Per axis: the lower and upper probe coordinates [N, 1] and the fraction t [N, 1].
        let axes: Vec<(Tensor<2, Int>, Tensor<2, Int>, Tensor<2>)> = (0..3)
            .map(|a| {
                let last = (self.dims[a] - 1) as f64;
                let u = points
                    .clone()
                    .slice_dim(1, a..a + 1)
                    .sub_scalar(self.origin[a])
                    .div_scalar(self.spacing);
                let u = u.clone().mask_fill(u.is_nan(), 0.0).clamp(0.0, last);
                let lower = u.clone().detach().floor().clamp(0.0, (last - 1.0).max(0.0));
                let t = u - lower.clone();
                let lower = lower.int();
                let upper = lower.clone().add_scalar(1i64).clamp_max(last as i64);
                (lower, upper, t)
            })
            .collect();
        let strides = [1, self.dims[0], self.dims[0] * self.dims[1]];
        let (indices, weights): (Vec<_>, Vec<_>) = (0..8)
            .map(|c| {
                let upper = |a: usize| (c >> a) & 1 == 1;
                let index = (0..3)
                    .map(|a| {
                        let (lower, up, _) = &axes[a];
                        let coordinate = if upper(a) { up.clone() } else { lower.clone() };
                        coordinate.mul_scalar(strides[a] as i64)
                    })
                    .reduce(|x, y| x + y)
                    .expect("three axes");
                let weight = (0..3)
                    .map(|a| {
                        let t = axes[a].2.clone();
                        if upper(a) { t } else { t.neg().add_scalar(1.0) }
                    })
                    .reduce(|x, y| x * y)
                    .expect("three axes");
                (index, weight)
            })
            .unzip();
        (Tensor::cat(indices, 1), Tensor::cat(weights, 1))
    }

    /// Per probe, its face-neighbours and weights `1/count`, padded to 6 with the probe itself
    /// at weight 0 (`[P·6]` each). A probe without neighbours (a one-probe grid) lists itself
    /// at weight 1, so its smoothness term is 0.
    fn neighbour_table(&self) -> (Vec<i64>, Vec<f32>) {
        (0..self.count())
            .flat_map(|i| {
                let mut neighbours = self.face_neighbours(i);
                if neighbours.is_empty() {
                    neighbours.push(i);
                }
                let w = 1.0 / neighbours.len() as f32;
                (0..FACE_NEIGHBOURS).map(move |slot| match neighbours.get(slot) {
                    Some(&j) => (j as i64, w),
                    None => (i as i64, 0.0),
                })
            })
            .unzip()
    }
}

/// Eq. 6's probes: SH radiance `[P, K, 3]` (a shared environment `[K, 3]` plus each probe's
/// own part) and latents `[P, d_z]` on a [`ProbeGrid`].
#[derive(Module, Debug)]
pub struct LightVolume {
    /// `[P, K, 3]` real-SH radiance coefficients per probe (no `+0.5`), on top of
    /// [`Self::environment`]: the whole probe while that is 0 (the default), a residual
    /// otherwise.
    pub sh: Param<Tensor<3>>,
    /// `[K, 3]` the SH environment every probe adds (zero unless split off).
    pub environment: Param<Tensor<2>>,
    /// `[P, d_z]` latent lighting features (Eq. 8's `z`).
    pub latent: Param<Tensor<2>>,
    #[module(skip)]
    grid: ProbeGrid,
}

impl LightVolume {
    /// Probes of SH `degree` (≤ 3) on `grid` with `latent_dim` latents: uniform unit radiance
    /// (DC [`UNIT_RADIANCE_DC`], higher bands 0) and latents `~ N(0, 0.01²)` drawn from `seed`.
    pub fn new(
        grid: ProbeGrid,
        degree: u32,
        latent_dim: usize,
        seed: u64,
        device: &Device,
    ) -> Result<Self, IllumError> {
        grid.validate()?;
        if degree > 3 {
            return Err(IllumError::input(
                "light-volume SH degree",
                format!("must be ≤ 3, got {degree}"),
            ));
        }
        if latent_dim == 0 {
            return Err(IllumError::input(
                "light-volume latent width",
                "must be ≥ 1",
            ));
        }
        let (p, k) = (grid.count(), coeff_count(degree));
        let sh: Vec<f32> = (0..p * k * 3)
            .map(|i| {
                if (i / 3) % k == 0 {
                    UNIT_RADIANCE_DC as f32
                } else {
                    0.0
                }
            })
            .collect();
        let latent = normal_draws(seed, p * latent_dim, LATENT_INIT_STD);
        Ok(Self {
            sh: Param::from_tensor(Tensor::from_data(TensorData::new(sh, [p, k, 3]), device)),
            environment: Param::from_tensor(Tensor::zeros([k, 3], device)),
            latent: Param::from_tensor(Tensor::from_data(
                TensorData::new(latent, [p, latent_dim]),
                device,
            )),
            grid,
        })
    }

    /// The probe grid.
    pub fn grid(&self) -> &ProbeGrid {
        &self.grid
    }

    /// Moves the mean of the probes' own coefficients into the shared environment: every
    /// probe's total `e + r_k` is unchanged (to rounding); on a fresh volume `e` becomes the
    /// uniform unit radiance and every `r_k` exactly 0 (the mean is taken in f64 on the host).
    pub fn split_environment(mut self) -> Self {
        let sh = self.sh.val();
        let [p, k, c] = sh.dims();
        let device = sh.device();
        let own: Vec<f64> = sh
            .into_data()
            .convert::<f64>()
            .try_into_vec::<f64>()
            .expect("f64 coefficients");
        let width = k * c;
        let mean: Vec<f64> = (0..width)
            .map(|j| (0..p).map(|i| own[i * width + j]).sum::<f64>() / p as f64)
            .collect();
        let residual: Vec<f32> = own
            .iter()
            .enumerate()
            .map(|(i, v)| (v - mean[i % width]) as f32)
            .collect();
        let shared: Vec<f32> = mean.iter().map(|&m| m as f32).collect();
        let environment =
            self.environment.val() + Tensor::from_data(TensorData::new(shared, [k, c]), &device);
        self.sh = Param::from_tensor(Tensor::from_data(
            TensorData::new(residual, [p, k, c]),
            &device,
        ));
        self.environment = Param::from_tensor(environment.detach());
        self
    }

    /// Every probe's whole coefficients `e + r_k`, `[P, K, 3]`.
    pub fn coefficients(&self) -> Tensor<3> {
        let sh = self.sh.val();
        let [_, k, c] = sh.dims();
        sh + self.environment.val().reshape([1, k, c])
    }

    /// The SH degree, from the coefficient count `K = (degree + 1)²`.
    pub fn degree(&self) -> u32 {
        let k = self.sh.val().dims()[1];
        (k as f64).sqrt().round() as u32 - 1
    }

    /// `d_z`, the latent width.
    pub fn latent_dim(&self) -> usize {
        self.latent.val().dims()[1]
    }

    /// Eq. 6 at `[N, 3]` world points: the trilinear blend of the 8 corner probes'
    /// coefficients `[N, K, 3]` and latents `[N, d_z]`. Evaluating the blended coefficients at
    /// any direction equals blending the corner probes' radiance (linearity).
    pub fn interpolate(&self, points: Tensor<2>) -> (Tensor<3>, Tensor<2>) {
        let n = points.dims()[0];
        let sh = self.sh.val();
        let [p, k, c] = sh.dims();
        let (indices, weights) = self.grid.corner_weights(points);
        let own = blend(sh.reshape([p, k * c]), indices.clone(), weights.clone());
        // The corner weights sum to 1, so the shared environment adds once (broadcast over the
        // points, so no points add nothing).
        let shared = self.environment.val().reshape([1, k * c]);
        (
            (own + shared).reshape([n, k, c]),
            blend(self.latent.val(), indices, weights),
        )
    }

    /// The latent half of [`Self::interpolate`], `[N, d_z]` (Eq. 8's `z` at scene points).
    pub fn interpolate_latent(&self, points: Tensor<2>) -> Tensor<2> {
        let (indices, weights) = self.grid.corner_weights(points);
        blend(self.latent.val(), indices, weights)
    }

    /// Writes one SH environment `[K, 3]` into every probe (relighting, spec §5(a)): the
    /// shared environment becomes `sh` and every probe's own part 0, both fresh parameters;
    /// latents stay. (For inference: a trainer's optimiser state no longer matches them.)
    pub fn set_environment(&mut self, sh: Tensor<2>) {
        let [p, k, c] = self.sh.val().dims();
        assert_eq!(
            sh.dims(),
            [k, c],
            "set_environment: the environment must be [{k}, {c}]"
        );
        self.sh = Param::from_tensor(Tensor::zeros([p, k, c], &sh.device()));
        self.environment = Param::from_tensor(sh.detach());
    }

    /// Eq. 13 with the spec's reading: the mean over probes of
    /// `‖c_i − mean_{j ∈ faces(i)} c_j‖₁` over each probe's whole coefficient vector `[K·3]`
    /// (radiance is linear in it), the neighbours being the ≤ 6 grid face-neighbours (fewer at
    /// the border). Latents are not smoothed. Zero on a constant field. The shared environment
    /// cancels in every difference, so only the probes' own parts are read.
    pub fn probe_smoothness(&self) -> Tensor<1> {
        let sh = self.sh.val();
        let [p, k, c] = sh.dims();
        let device = sh.device();
        let (indices, weights) = self.grid.neighbour_table();
        let indices =
            Tensor::<1, Int>::from_data(TensorData::new(indices, [p * FACE_NEIGHBOURS]), &device);
        let weights =
            Tensor::<3>::from_data(TensorData::new(weights, [p, FACE_NEIGHBOURS, 1]), &device);
        let own = sh.reshape([p, k * c]);
        let mean = (own
            .clone()
            .select(0, indices)
            .reshape([p, FACE_NEIGHBOURS, k * c])
            * weights)
            .sum_dim(1)
            .reshape([p, k * c]);
        (own - mean).abs().sum_dim(1).mean()
    }
}

/// `Σ_corners w · values[index]`: `values` `[P, W]`, indices and weights `[N, 8]` → `[N, W]`.
/// Its backward scatter-adds into the corner rows only.
fn blend(values: Tensor<2>, indices: Tensor<2, Int>, weights: Tensor<2>) -> Tensor<2> {
    let [n, corners] = indices.dims();
    let width = values.dims()[1];
    if n == 0 {
        return Tensor::zeros([0, width], &values.device());
    }
    let gathered = values
        .select(0, indices.reshape([n * corners]))
        .reshape([n, corners, width]);
    (gathered * weights.reshape([n, corners, 1]))
        .sum_dim(1)
        .reshape([n, width])
}

/// [`LightVolume::interpolate`] in f64 for one point, on row-major probe values `[P, W]` (any
/// width `W`): `Σ_probes Π_a max(0, 1 − |u_a − i_a|) · values`, with `u` the point's grid
/// coordinates clamped to `[0, dims − 1]`.
pub fn interpolate_reference(grid: &ProbeGrid, probe_values: &[f64], point: [f64; 3]) -> Vec<f64> {
    let p = grid.count();
    assert_eq!(probe_values.len() % p, 0, "values must be [P, W]");
    let width = probe_values.len() / p;
    let u = [0, 1, 2].map(|a| {
        ((point[a] - grid.origin[a]) / grid.spacing).clamp(0.0, (grid.dims[a] - 1) as f64)
    });
    let mut out = vec![0.0; width];
    for probe in 0..p {
        let cell = grid.cell(probe);
        let weight: f64 = (0..3)
            .map(|a| (1.0 - (u[a] - cell[a] as f64).abs()).max(0.0))
            .product();
        for (o, v) in out.iter_mut().zip(&probe_values[probe * width..][..width]) {
            *o += weight * v;
        }
    }
    out
}

/// [`LightVolume::probe_smoothness`] in f64 on row-major coefficients `[P, W]`.
pub fn probe_smoothness_reference(grid: &ProbeGrid, coefficients: &[f64]) -> f64 {
    let p = grid.count();
    let width = coefficients.len() / p;
    let row = |i: usize| &coefficients[i * width..(i + 1) * width];
    let mut total = 0.0;
    for i in 0..p {
        let neighbours = grid.face_neighbours(i);
        if neighbours.is_empty() {
            continue;
        }
        for j in 0..width {
            let mean = neighbours.iter().map(|&q| row(q)[j]).sum::<f64>() / neighbours.len() as f64;
            total += (row(i)[j] - mean).abs();
        }
    }
    total / p as f64
}

/// `count` draws of `N(0, std²)`: SplitMix64 uniforms through Box–Muller, so a seed fixes the
/// latents on every platform.
fn normal_draws(seed: u64, count: usize, std: f64) -> Vec<f32> {
    let mut state = seed;
    let mut uniform = move || {
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        // In (0, 1): never 0, so the logarithm is finite.
        ((z >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    };
    (0..count)
        .map(|_| {
            let (u1, u2) = (uniform(), uniform());
            (std * (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()) as f32
        })
        .collect()
}
