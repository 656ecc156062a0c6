//! GauHuman's density control by Kullback–Leibler divergence (Hu et al., CVPR 2024, §3.3),
//! for Gaussians that should tile a surface rather than pile up: the screen-gradient
//! statistics of ADC say *where* the image wants more Gaussians, and the divergence of each
//! Gaussian from its nearest neighbour says *whether* it is redundant there.
//!
//! At each decision step, with `KL(i) = KL(G_i ‖ G_nn(i))` (the closed form between two 3-D
//! Gaussians, [`gaussian_kl`]; `nn` by centre distance):
//! - **prune** when the opacity is below `min_opacity`, or, given the surface the Gaussians
//!   should tile ([`SurfacePrune`]), when the centre is farther than its `max_distance` from
//!   that mesh (GauHuman's rule for the body: its SMPL mesh, in the node's frame);
//! - **merge** `i` with its nearest neighbour when `KL(i) < kl_merge` (each Gaussian merges at
//!   most once): one Gaussian at the mean of the two centres, with the mean of their
//!   log-scales, opacity logits and colours and `i`'s rotation (our reading: GauHuman averages
//!   the pair);
//! - **grow** as ADC (clone when small, split in two when larger than `percent_dense`·extent)
//!   when the mean screen gradient reaches `grad_threshold` *and* `KL(i) > kl_split`.
//!
//! Every row after the decision records the row it came from (a merged row its first parent),
//! so per-row data beside the set can follow.

use super::strategy::{DensityStrategy, RowEdit};
use super::{DensifyConfig, DensifyReport, DensityStats, Strategy, push_split, replace_rows};
use crate::checkpoint::{Checkpoint, CheckpointError};
use crate::gaussians::GaussianRows;
use crate::host_f32 as host;
use burn::tensor::{Device, Gradients};
use splatzoo_models::closest_face::FaceIndex;
use splatzoo_models::knn::PointIndex;
use splatzoo_rasterizer::Render;
use std::ops::Range;

/// One Gaussian as the divergence sees it: centre, standard deviations and rotation
/// (columns are the principal axes).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GaussianShape {
    pub mean: [f64; 3],
    pub scale: [f64; 3],
    pub rotation: [[f64; 3]; 3],
}

impl GaussianShape {
    fn covariance(&self) -> [[f64; 3]; 3] {
        let (r, s) = (&self.rotation, &self.scale);
        std::array::from_fn(|a| {
            std::array::from_fn(|b| (0..3).map(|k| r[a][k] * s[k] * s[k] * r[b][k]).sum())
        })
    }

    fn inverse_covariance(&self) -> [[f64; 3]; 3] {
        let (r, s) = (&self.rotation, &self.scale);
        std::array::from_fn(|a| {
            std::array::from_fn(|b| (0..3).map(|k| r[a][k] * r[b][k] / (s[k] * s[k])).sum())
        })
    }
}

/// `KL(N₀ ‖ N₁) = ½ [tr(Σ₁⁻¹Σ₀) + (μ₁ − μ₀)ᵀ Σ₁⁻¹ (μ₁ − μ₀) − 3 + ln(det Σ₁ / det Σ₀)]`.
/// Scales are floored at `1e-12` so a flat Gaussian gives a large finite value.
pub fn gaussian_kl(p: &GaussianShape, q: &GaussianShape) -> f64 {
    let floor = |g: &GaussianShape| GaussianShape {
        scale: g.scale.map(|s| s.abs().max(1e-12)),
        ..*g
    };
    let (p, q) = (floor(p), floor(q));
    let (sigma_p, inverse_q) = (p.covariance(), q.inverse_covariance());
    let trace: f64 = (0..3)
        .map(|a| (0..3).map(|b| inverse_q[a][b] * sigma_p[b][a]).sum::<f64>())
        .sum();
    let d: [f64; 3] = std::array::from_fn(|a| q.mean[a] - p.mean[a]);
    let mahalanobis: f64 = (0..3)
        .map(|a| (0..3).map(|b| d[a] * inverse_q[a][b] * d[b]).sum::<f64>())
        .sum();
    let log_det = |g: &GaussianShape| g.scale.iter().map(|s| 2.0 * s.ln()).sum::<f64>();
    0.5 * (trace + mahalanobis - 3.0 + log_det(&q) - log_det(&p))
}

fn shape(rows: &GaussianRows, i: usize) -> GaussianShape {
    GaussianShape {
        mean: rows.mean(i).map(f64::from),
        scale: rows.scale(i).map(f64::from),
        rotation: rows.rotation(i).map(|r| r.map(f64::from)),
    }
}

/// Each row's nearest other row by centre (itself when it is alone).
fn nearest(rows: &GaussianRows) -> Vec<usize> {
    let centres: Vec<[f32; 3]> = (0..rows.len()).map(|i| rows.mean(i)).collect();
    let index = PointIndex::new(&centres);
    (0..rows.len())
        .map(|i| {
            index
                .k_nearest(centres[i], 1, Some(i))
                .first()
                .map_or(i, |&(j, _)| j)
        })
        .collect()
}

/// GauHuman's distance-to-mesh prune: the mesh, in the frame of the node's Gaussians, and how
/// far from it a centre may lie.
#[derive(Debug, Clone)]
pub struct SurfacePrune {
    pub mesh: FaceIndex,
    pub max_distance: f64,
}

impl SurfacePrune {
    /// Whether the centre `p` lies farther than `max_distance` from the mesh (a non-finite
    /// centre does; a mesh without faces keeps everything).
    pub fn is_off(&self, p: [f32; 3]) -> bool {
        if self.mesh.face_count() == 0 {
            return false;
        }
        self.mesh
            .nearest(p.map(f64::from))
            .is_none_or(|closest| closest.squared_distance > self.max_distance.powi(2))
    }
}

/// One KL decision (module docs); `old_from_new` receives the lineage.
pub fn kl_density_control(
    config: &DensifyConfig,
    edit: RowEdit<'_>,
    stats: &mut DensityStats,
    extent: f64,
    surface: Option<&SurfacePrune>,
) -> DensifyReport {
    let RowEdit {
        set,
        optimizer,
        rng,
        old_from_new,
        ..
    } = edit;
    let rows = set.to_rows();
    let n = rows.len();
    let (grad_sum, count) = (host(&stats.grad_sum), host(&stats.count));
    let near = nearest(&rows);
    let kl: Vec<f64> = (0..n)
        .map(|i| gaussian_kl(&shape(&rows, i), &shape(&rows, near[i])))
        .collect();
    let mut report = DensifyReport::default();
    let mut done = vec![false; n];
    let mut keep = Vec::with_capacity(n);
    let mut added = GaussianRows::default();
    let mut added_from = Vec::new();
    let mut budget = config.max_gaussians.saturating_sub(n);
    let dense = (config.percent_dense * extent) as f32;
    for (i, dead) in done.iter_mut().enumerate() {
        if (rows.opacity(i) as f64) < config.min_opacity {
            *dead = true;
            report.pruned += 1;
        } else if surface.is_some_and(|s| s.is_off(std::array::from_fn(|a| rows.means[3 * i + a])))
        {
            *dead = true;
            report.pruned += 1;
            report.off_surface += 1;
        }
    }
    for i in 0..n {
        if done[i] {
            continue;
        }
        let j = near[i];
        if j != i && !done[j] && kl[i] < config.kl_merge {
            done[i] = true;
            done[j] = true;
            let row = added.len();
            added.push_from(&rows, i);
            added_from.push(i);
            let average = |a: f32, b: f32| 0.5 * (a + b);
            for a in 0..3 {
                added.means[3 * row + a] = average(rows.means[3 * i + a], rows.means[3 * j + a]);
                added.log_scales[3 * row + a] =
                    average(rows.log_scales[3 * i + a], rows.log_scales[3 * j + a]);
            }
            added.opacity_logits[row] = average(rows.opacity_logits[i], rows.opacity_logits[j]);
            for (to, from, width) in [
                (&mut added.sh_dc, &rows.sh_dc, 3),
                (
                    &mut added.sh_rest,
                    &rows.sh_rest,
                    3 * crate::gaussians::SH_REST,
                ),
            ] {
                for k in 0..width {
                    to[width * row + k] = average(from[width * i + k], from[width * j + k]);
                }
            }
            report.merged += 1;
            continue;
        }
        done[i] = true;
        keep.push(i);
        let mean_grad = grad_sum[i] / count[i].max(1.0);
        if budget == 0 || (mean_grad as f64) < config.grad_threshold || kl[i] <= config.kl_split {
            continue;
        }
        let scale = rows.scale(i);
        if scale[0].max(scale[1]).max(scale[2]) <= dense {
            added.push_from(&rows, i);
            added_from.push(i);
            report.cloned += 1;
        } else {
            push_split(&rows, i, &mut added, &mut added_from, rng);
            // The split parent is replaced by its two children.
            keep.pop();
            report.split += 1;
        }
        budget -= 1;
    }
    replace_rows(
        set,
        optimizer,
        stats,
        keep,
        &added,
        added_from,
        old_from_new,
    );
    report
}

/// The strategy: ADC's statistics, [`kl_density_control`] on the schedule.
pub struct KlDensity {
    pub config: DensifyConfig,
    pub stats: DensityStats,
    pub extent: f64,
    /// The distance-to-mesh prune, where the node's owner gives the mesh.
    pub surface: Option<SurfacePrune>,
}

impl DensityStrategy for KlDensity {
    fn kind(&self) -> Strategy {
        Strategy::Kl
    }

    fn observe(&mut self, render: &Render, grads: &Gradients, rows: Range<usize>) {
        self.stats.record(render, grads, rows);
    }

    fn after_step(&mut self, edit: RowEdit<'_>) -> Option<DensifyReport> {
        self.config.refines_at(edit.step).then(|| {
            kl_density_control(
                &self.config,
                edit,
                &mut self.stats,
                self.extent,
                self.surface.as_ref(),
            )
        })
    }

    fn save(&self, checkpoint: &mut Checkpoint, prefix: &str) {
        self.stats.save(checkpoint, prefix);
    }

    fn load(
        &mut self,
        checkpoint: &Checkpoint,
        prefix: &str,
        rows: usize,
        device: &Device,
    ) -> Result<(), CheckpointError> {
        self.stats = DensityStats::load(checkpoint, prefix, rows, device)?;
        Ok(())
    }
}
