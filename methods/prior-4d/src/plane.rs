//! The floor plane π: n·x + d = 0 (§4.2 of Prior-4D), fitted by RANSAC to the scene prior's 3-D
//! ground points, and the initial global scale σ₀ derived from it. Host-side f64 code; the plane
//! is held constant in stage D.

use glam::{DMat3, DVec3};

use crate::Prior4dError;

/// π: n·x + d = 0 with ‖n‖ = 1.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Plane {
    /// The unit normal n.
    pub normal: [f64; 3],
    /// The offset d, in scene units.
    pub offset: f64,
}

impl Plane {
    /// From a normal (any length, not zero) and offset; normalises both by ‖n‖.
    ///
    /// Errors on a zero or non-finite normal, or a non-finite offset.
    pub fn new(normal: [f64; 3], offset: f64) -> Result<Plane, Prior4dError> {
        let n = DVec3::from(normal);
        let len = n.length();
        if !(n.is_finite() && len.is_finite() && len > 0.0) {
            return Err(Prior4dError::input(
                "plane",
                format!("the normal {normal:?} must be finite and not zero"),
            ));
        }
        let d = offset / len;
        if !d.is_finite() {
            return Err(Prior4dError::input(
                "plane",
                format!("the offset must be finite, got {offset}"),
            ));
        }
        Ok(Plane {
            normal: (n / len).to_array(),
            offset: d,
        })
    }

    /// Signed distance n·x + d.
    pub fn signed_distance(&self, x: [f64; 3]) -> f64 {
        DVec3::from(self.normal).dot(DVec3::from(x)) + self.offset
    }

    /// The plane with n flipped so that `reference` (e.g. a camera centre) has positive signed
    /// distance.
    pub fn oriented_towards(self, reference: [f64; 3]) -> Plane {
        if self.signed_distance(reference) < 0.0 {
            Plane {
                normal: (-DVec3::from(self.normal)).to_array(),
                offset: -self.offset,
            }
        } else {
            self
        }
    }

    /// Angle in degrees between this plane's normal and `other`'s (unsigned, 0..=180; atan2 of
    /// ‖a × b‖ and a·b, accurate near 0 and 180).
    pub fn angle_degrees(&self, other: &Plane) -> f64 {
        let (a, b) = (DVec3::from(self.normal), DVec3::from(other.normal));
        a.cross(b).length().atan2(a.dot(b)).to_degrees()
    }
}

/// RANSAC knobs.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RansacConfig {
    /// Inlier distance, in scene units.
    pub threshold: f64,
    /// How many random triples to try.
    pub iterations: usize,
    /// Seed of the sampler; the fit is deterministic for a seed.
    pub seed: u64,
}

impl Default for RansacConfig {
    fn default() -> Self {
        RansacConfig {
            threshold: 0.01,
            iterations: 1000,
            seed: 0,
        }
    }
}

/// A fitted plane and its support.
#[derive(Debug, Clone, PartialEq)]
pub struct PlaneFit {
    /// The refined plane.
    pub plane: Plane,
    /// Indices of the points within the threshold of `plane`, ascending.
    pub inliers: Vec<usize>,
    /// RMS distance of the inliers to the refined plane.
    pub rms: f64,
}

/// RANSAC plane fit: sample 3 distinct points (skipping near-collinear triples, ‖cross‖ below
/// 1e-12 × scale², scale being the bounding-box diagonal), count inliers |n·x + d| ≤ threshold and
/// keep the best model (most inliers; a tie goes to the smaller sum of inlier distances). Then
/// refine twice by least squares (centroid and the smallest-eigenvalue eigenvector of the inlier
/// covariance), recomputing the inliers after each. Deterministic for a seed.
///
/// Errors on fewer than 3 points, a non-finite coordinate, a threshold that is not finite and
/// positive, zero iterations, or no non-degenerate triple.
pub fn ransac_plane(points: &[[f64; 3]], config: &RansacConfig) -> Result<PlaneFit, Prior4dError> {
    let error = |problem: String| Prior4dError::input("ground points", problem);
    let no_plane = || {
        error(
            "no plane: every sampled triple is degenerate (all points collinear or coincident)"
                .into(),
        )
    };
    if points.len() < 3 {
        return Err(error(format!(
            "need at least 3 points to fit a plane, got {}",
            points.len()
        )));
    }
    if let Some((i, p)) = points
        .iter()
        .enumerate()
        .find(|(_, p)| !p.iter().all(|c| c.is_finite()))
    {
        return Err(error(format!(
            "point {i} has a non-finite coordinate {p:?}"
        )));
    }
    let threshold = config.threshold;
    if !(threshold.is_finite() && threshold > 0.0) {
        return Err(error(format!(
            "the RANSAC threshold must be finite and > 0, got {threshold}"
        )));
    }
    if config.iterations == 0 {
        return Err(error(
            "the RANSAC iteration count must be at least 1".into(),
        ));
    }

    let pts: Vec<DVec3> = points.iter().map(|&p| DVec3::from(p)).collect();
    let (lo, hi) = pts
        .iter()
        .fold((pts[0], pts[0]), |(lo, hi), &p| (lo.min(p), hi.max(p)));
    let scale = (hi - lo).length();
    let degenerate = 1e-12 * scale * scale;

    struct Model {
        normal: DVec3,
        offset: f64,
        count: usize,
        sum: f64,
    }
    let mut rng = SplitMix64(config.seed);
    let mut best: Option<Model> = None;
    for _ in 0..config.iterations {
        let [i, j, k] = rng.distinct_triple(pts.len());
        let cross = (pts[j] - pts[i]).cross(pts[k] - pts[i]);
        let len = cross.length();
        if len.is_nan() || len <= degenerate {
            continue;
        }
        let normal = cross / len;
        let offset = -normal.dot(pts[i]);
        let (count, sum) = pts
            .iter()
            .map(|p| (normal.dot(*p) + offset).abs())
            .filter(|&r| r <= threshold)
            .fold((0usize, 0.0), |(c, s), r| (c + 1, s + r));
        if best
            .as_ref()
            .is_none_or(|b| count > b.count || (count == b.count && sum < b.sum))
        {
            best = Some(Model {
                normal,
                offset,
                count,
                sum,
            });
        }
    }
    let Some(model) = best else {
        return Err(no_plane());
    };

    let support = |normal: DVec3, offset: f64| -> Vec<usize> {
        pts.iter()
            .enumerate()
            .filter(|(_, p)| (normal.dot(**p) + offset).abs() <= threshold)
            .map(|(i, _)| i)
            .collect()
    };
    let (mut normal, mut offset) = (model.normal, model.offset);
    let mut inliers = support(normal, offset);
    if inliers.len() < 3 {
        return Err(no_plane());
    }
    for _ in 0..2 {
        let (n, d) = least_squares(&pts, &inliers, normal);
        let refined = support(n, d);
        if refined.len() < 3 {
            break;
        }
        (normal, offset, inliers) = (n, d, refined);
    }
    let squares: f64 = inliers
        .iter()
        .map(|&i| (normal.dot(pts[i]) + offset).powi(2))
        .sum();
    let rms = (squares / inliers.len() as f64).sqrt();
    Ok(PlaneFit {
        plane: Plane {
            normal: normal.to_array(),
            offset,
        },
        inliers,
        rms,
    })
}

/// The least-squares plane through `pts[inliers]`: the centroid and the covariance's
/// smallest-eigenvalue eigenvector, signed to agree with `hint`.
fn least_squares(pts: &[DVec3], inliers: &[usize], hint: DVec3) -> (DVec3, f64) {
    let centroid = inliers.iter().map(|&i| pts[i]).sum::<DVec3>() / inliers.len() as f64;
    let covariance = inliers.iter().fold(DMat3::ZERO, |acc, &i| {
        let r = pts[i] - centroid;
        acc + DMat3::from_cols(r * r.x, r * r.y, r * r.z)
    });
    let (_, vectors) = symmetric_eigen(covariance.to_cols_array_2d());
    let mut normal = DVec3::from(vectors[0]);
    if normal.dot(hint) < 0.0 {
        normal = -normal;
    }
    (normal, -normal.dot(centroid))
}

/// Eigen-decomposition of a symmetric 3×3 matrix by cyclic Jacobi rotations (glam has no SVD).
///
/// Returns the eigenvalues ascending and `vectors[k]`, the unit eigenvector of `values[k]`.
/// Sweeps until the off-diagonal part is below ~1e-18 of the matrix norm, at most 50 sweeps.
/// The input is symmetrised first; a non-finite input gives non-finite output, never a panic.
pub fn symmetric_eigen(m: [[f64; 3]; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
    const MAX_SWEEPS: usize = 50;
    // Symmetric, so rows and columns are interchangeable; entry (p, q) is `a.col(q)[p]`.
    let mut a = DMat3::from_cols_array_2d(&m);
    a = (a + a.transpose()) * 0.5;
    let mut v = DMat3::IDENTITY;
    let norm_sq: f64 = a.to_cols_array().iter().map(|x| x * x).sum();
    for _ in 0..MAX_SWEEPS {
        let off_sq = a.col(1)[0].powi(2) + a.col(2)[0].powi(2) + a.col(2)[1].powi(2);
        if off_sq <= 1e-36 * norm_sq {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            let apq = a.col(q)[p];
            if apq == 0.0 {
                continue;
            }
            // Rotation P (P_pp = P_qq = c, P_pq = s, P_qp = −s) zeroing (PᵀAP)_pq.
            let theta = (a.col(q)[q] - a.col(p)[p]) / (2.0 * apq);
            let t = if theta.abs() > 1e100 {
                0.5 / theta
            } else {
                theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt())
            };
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            let mut rot = DMat3::IDENTITY;
            rot.col_mut(p)[p] = c;
            rot.col_mut(q)[q] = c;
            rot.col_mut(q)[p] = s;
            rot.col_mut(p)[q] = -s;
            a = rot.transpose() * a * rot;
            a.col_mut(q)[p] = 0.0;
            a.col_mut(p)[q] = 0.0;
            v *= rot;
        }
    }
    let mut order = [0usize, 1, 2];
    order.sort_by(|&i, &j| a.col(i)[i].total_cmp(&a.col(j)[j]));
    let values = order.map(|k| a.col(k)[k]);
    let vectors = order.map(|k| v.col(k).normalize_or_zero().to_array());
    (values, vectors)
}

/// One frame's input to [`initial_scale`].
#[derive(Debug, Clone, Copy)]
pub struct ScaleFrame<'a> {
    /// The acting camera's camera-to-world rotation R_t (row-major 3×3).
    pub rotation: [[f64; 3]; 3],
    /// The acting camera's centre c_t, in scene units.
    pub centre: [f64; 3],
    /// Camera-space foot vertices of the body (metres, body units).
    pub feet: &'a [[f64; 3]],
}

/// Initial global scale σ₀ (a procedure derived for Prior-4D; the paper gives none).
///
/// A camera-space vertex v lies at σ R v + c, at signed height h(v) = σ n·(R v) + (n·c + d)
/// above π. For σ > 0 the order of vertices by h does not depend on σ, so each frame averages
/// its `contact_count` vertices of smallest n·(R v) to v̄ and puts them on the floor:
/// σ_t = −(n·c + d) / n·(R v̄), used only where n·(R v̄) < 0 and σ_t is finite and > 0.
/// σ₀ is the median of the σ_t (robust to frames with a lifted foot; an even count takes the
/// mean of the two middle values).
///
/// Errors on `contact_count == 0`, a frame with fewer feet than `contact_count` or a non-finite
/// value, or no usable frame.
pub fn initial_scale(
    plane: &Plane,
    frames: &[ScaleFrame<'_>],
    contact_count: usize,
) -> Result<f64, Prior4dError> {
    let error = |problem: String| Prior4dError::input("initial scale", problem);
    if contact_count == 0 {
        return Err(error("contact_count must be at least 1".into()));
    }
    let normal = DVec3::from(plane.normal);
    let mut scales = Vec::with_capacity(frames.len());
    for (t, frame) in frames.iter().enumerate() {
        if frame.feet.len() < contact_count {
            return Err(error(format!(
                "frame {t} has {} foot vertices, fewer than contact_count {contact_count}",
                frame.feet.len()
            )));
        }
        let finite = frame
            .rotation
            .iter()
            .flatten()
            .chain(&frame.centre)
            .chain(frame.feet.iter().flatten())
            .all(|x| x.is_finite());
        if !finite {
            return Err(error(format!(
                "frame {t} has a non-finite rotation, centre or foot vertex"
            )));
        }
        // Built from R's rows as columns, this matrix is Rᵀ, and n·(R v) = (Rᵀ n)·v.
        let up = DMat3::from_cols_array_2d(&frame.rotation) * normal;
        let mut feet: Vec<(f64, DVec3)> = frame
            .feet
            .iter()
            .map(|&v| (up.dot(DVec3::from(v)), DVec3::from(v)))
            .collect();
        feet.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mean = feet[..contact_count].iter().map(|f| f.1).sum::<DVec3>() / contact_count as f64;
        let lowest = up.dot(mean);
        let sigma = -plane.signed_distance(frame.centre) / lowest;
        if lowest < 0.0 && sigma.is_finite() && sigma > 0.0 {
            scales.push(sigma);
        }
    }
    if scales.is_empty() {
        return Err(error(
            "no frame has its feet below the camera relative to the floor".into(),
        ));
    }
    scales.sort_by(f64::total_cmp);
    let mid = scales.len() / 2;
    Ok(if scales.len() % 2 == 1 {
        scales[mid]
    } else {
        scales[mid - 1].midpoint(scales[mid])
    })
}

/// SplitMix64: a tiny deterministic generator for RANSAC's sampling.
struct SplitMix64(u64);

impl SplitMix64 {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `0..n` (n ≥ 1; the modulo bias is negligible for point counts).
    fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }

    /// Three distinct indices in `0..n` (n ≥ 3).
    fn distinct_triple(&mut self, n: usize) -> [usize; 3] {
        let i = self.below(n);
        let mut j = self.below(n - 1);
        if j >= i {
            j += 1;
        }
        let (lo, hi) = (i.min(j), i.max(j));
        let mut k = self.below(n - 2);
        if k >= lo {
            k += 1;
        }
        if k >= hi {
            k += 1;
        }
        [i, j, k]
    }
}
