//! The learned light volume against the analytic light the synthetic renderer used: one
//! per-channel gain (the albedo–light scale ambiguity), the relative error over the whole
//! grid and over the probes shading can read, and that error per SH band and as the
//! irradiance a Lambertian surface receives. Every score here needs the capture's truth.

use crate::data::CaptureTruth;
use crate::eval::{TruthScores, channel_gains};
use crate::trainer::IllumTrainer;
use serde::{Deserialize, Serialize};
use splatzoo_train::host_f32;

/// One SH band of the learned probes against the gain-scaled analytic light.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ProbeBand {
    pub band: usize,
    pub learned_rms: f64,
    pub truth_rms: f64,
    pub relative_error: f64,
    /// `⟨learned, truth⟩ / (‖learned‖ ‖truth‖)` over the band's coefficients: free of the
    /// gain, 1 where the learned band points as the light's does, 0 where it is unrelated.
    pub cosine: f64,
}

/// The cosine lobe's SH convolution weights `A_l / π` for bands 0..=3 (Ramamoorthi and
/// Hanrahan 2001; band 3 is 0).
const LAMBERT_BAND_WEIGHT: [f64; 4] = [1.0, 2.0 / 3.0, 0.25, 0.0];

/// The learned probes on the host beside the analytic light at each probe, read once for
/// every score.
struct ProbeTable {
    /// Coefficients per probe, `K`.
    k: usize,
    /// `[P, K, 3]` learned coefficients.
    learned: Vec<f32>,
    /// The analytic SH (degree 2) at each probe.
    truth: Vec<[[f64; 3]; 9]>,
}

impl ProbeTable {
    fn learned(&self, p: usize, j: usize, c: usize) -> f64 {
        f64::from(self.learned[(p * self.k + j) * 3 + c])
    }

    /// The probes `among` keeps (all where `None`).
    fn kept<'a>(&'a self, among: Option<&'a [bool]>) -> impl Iterator<Item = usize> + 'a {
        (0..self.truth.len()).filter(move |&p| among.is_none_or(|keep| keep[p]))
    }

    /// The per-channel least-squares gain of the truth onto the learned probes kept.
    fn gain(&self, among: Option<&[bool]>) -> [f64; 3] {
        let pairs: Vec<([f64; 3], [f64; 3])> = self
            .kept(among)
            .flat_map(|p| {
                (0..self.k.min(9))
                    .map(move |j| (self.truth[p][j], [0, 1, 2].map(|c| self.learned(p, j, c))))
            })
            .collect();
        channel_gains(&pairs)
    }

    /// Relative RMS error of `gain × truth` against the learned probes kept (bands the
    /// analytic light lacks count against 0).
    fn error(&self, gain: [f64; 3], among: Option<&[bool]>) -> f64 {
        let (mut err, mut norm) = (0.0, 0.0);
        for p in self.kept(among) {
            for j in 0..self.k {
                for (c, g) in gain.iter().enumerate() {
                    let t = if j < 9 { g * self.truth[p][j][c] } else { 0.0 };
                    err += (self.learned(p, j, c) - t).powi(2);
                    norm += t * t;
                }
            }
        }
        (err / norm.max(1e-20)).sqrt()
    }

    /// Per-band sums over the probes kept of `learned²`, `(gain × truth)²`, their squared
    /// difference and `learned · gain × truth`, for the bands the analytic light has (0..=2).
    fn band_sums(&self, gain: [f64; 3], among: &[bool]) -> Vec<[f64; 4]> {
        let bands = (self.k as f64).sqrt() as usize;
        let mut sums = vec![[0.0; 4]; bands.min(3)];
        for p in self.kept(Some(among)) {
            for j in 0..self.k.min(9) {
                let band = (j as f64).sqrt() as usize;
                for (c, g) in gain.iter().enumerate() {
                    let (learned, t) = (self.learned(p, j, c), g * self.truth[p][j][c]);
                    sums[band][0] += learned * learned;
                    sums[band][1] += t * t;
                    sums[band][2] += (learned - t).powi(2);
                    sums[band][3] += learned * t;
                }
            }
        }
        sums
    }
}

impl IllumTrainer {
    fn probe_table(&self, truth: &CaptureTruth) -> ProbeTable {
        let grid = *self.volume.grid();
        let learned = host_f32(&self.volume.coefficients());
        ProbeTable {
            k: learned.len() / (3 * grid.count()),
            learned,
            truth: (0..grid.count())
                .map(|p| truth.probe_truth(grid.position(p)))
                .collect(),
        }
    }

    /// The learned probes' per-channel gain against the analytic SH of the training light
    /// (`None` where the capture does not know its light).
    pub fn probe_gain(&self) -> Option<[f64; 3]> {
        Some(self.probe_gain_against(self.capture.truth.as_ref()?, None))
    }

    /// The probes shading can read: the 8 corners of every cell holding a vertex of a
    /// training frame's posed body.
    pub fn seen_probes(&self) -> Vec<bool> {
        let grid = *self.volume.grid();
        let mut seen = vec![false; grid.count()];
        for &k in &self.train {
            let posed = self.frame_pose(self.capture.frames[k].frame, false).posed;
            let vertices = posed.vertices.reshape([self.mesh.vertex_count(), 3]);
            let (corners, _) = grid.corner_weights(vertices);
            for index in host_f32(&corners.float()) {
                seen[index as usize] = true;
            }
        }
        seen
    }

    /// The per-channel gain over the probes `among` keeps (all where `None`).
    pub(crate) fn probe_gain_against(
        &self,
        truth: &CaptureTruth,
        among: Option<&[bool]>,
    ) -> [f64; 3] {
        self.probe_table(truth).gain(among)
    }

    /// [`TruthScores::probe_bands_seen`] and [`TruthScores::probe_irradiance_error_seen`].
    pub fn probe_band_scores(
        &self,
        truth: &CaptureTruth,
        gain: [f64; 3],
        among: &[bool],
    ) -> (Vec<ProbeBand>, f64) {
        band_scores(&self.probe_table(truth), gain, among)
    }

    /// The probe scores of [`TruthScores`] against the whole grid's `gain`.
    pub fn probe_scores(&self, truth: &CaptureTruth, gain: [f64; 3], scores: &mut TruthScores) {
        let table = self.probe_table(truth);
        scores.probe_relative_error = Some(table.error(gain, None));
        let seen = self.seen_probes();
        let seen_gain = table.gain(Some(&seen));
        scores.probe_relative_error_seen = Some(table.error(seen_gain, Some(&seen)));
        scores.probes_seen = Some(seen.iter().filter(|&&s| s).count());
        let (bands, irradiance) = band_scores(&table, seen_gain, &seen);
        scores.probe_bands_seen = Some(bands);
        scores.probe_irradiance_error_seen = Some(irradiance);
    }
}

/// Each band's scores and the lobe-weighted irradiance error over the probes `among` keeps.
fn band_scores(table: &ProbeTable, gain: [f64; 3], among: &[bool]) -> (Vec<ProbeBand>, f64) {
    let sums = table.band_sums(gain, among);
    let count = among.iter().filter(|&&s| s).count().max(1) as f64;
    let bands = sums
        .iter()
        .enumerate()
        .map(|(band, [learned, t, diff, dot])| {
            let per = 3.0 * (2 * band + 1) as f64 * count;
            ProbeBand {
                band,
                learned_rms: (learned / per).sqrt(),
                truth_rms: (t / per).sqrt(),
                relative_error: (diff / t.max(1e-20)).sqrt(),
                cosine: dot / (learned * t).sqrt().max(1e-20),
            }
        })
        .collect();
    let weighted = |i: usize| -> f64 {
        sums.iter()
            .zip(LAMBERT_BAND_WEIGHT)
            .map(|(s, a)| a * a * s[i])
            .sum()
    };
    (bands, (weighted(2) / weighted(1).max(1e-20)).sqrt())
}
