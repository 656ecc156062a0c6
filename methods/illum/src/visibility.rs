//! Pose-aware visibility `vis = F_vis(v, θ, φ)` (Eq. 3 of Illum, after RelightableAvatar): the
//! probability that light arriving from direction `φ` reaches canonical point `v` of the body
//! in pose `θ` unblocked by the body itself. It feeds `V(ω_i, x)` of Eq. 4 and Eq. 7, so `φ` is
//! the *incident* direction ω_i (the paper says "view direction"; the spec explains why the
//! integrand needs the light's), expressed in the body's root frame, with θ's global
//! orientation zeroed.
//!
//! The network never sees an image loss: it is supervised by binary cross-entropy against
//! ray-cast labels of the posed mesh ([`sample_labels`], [`raycast_visibility`] on a
//! [`TriangleBvh`]), each ray starting `1e-3 · H` above the surface along the normal. The
//! ray cast itself is the exact oracle ([`VisibilitySource::Raycast`]: slow, the top of the
//! speed/accuracy trade); [`VisibilitySource::Open`] takes `V ≡ 1`.

use burn::module::Module;
use burn::nn::Linear;
use burn::tensor::activation::{relu, sigmoid};
use burn::tensor::{Device, Tensor};
use rand::Rng;
use splatzoo_models::networks::encoding::{encoded_width, frequency_encoding};
use splatzoo_models::networks::mlp::{SkipMlp, head};
use splatzoo_models::raycast::TriangleBvh;

/// Where `V(ω_i, x)` comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum VisibilitySource {
    /// The paper's F_vis.
    Net,
    /// The exact ray cast of the posed mesh (an oracle: no learning, slow).
    Raycast,
    /// No self-occlusion: `V ≡ 1`.
    Open,
}

/// F_vis's shape. RelightableAvatar's: position code of 10 frequencies, direction code of 4,
/// 4 × 256 ReLU layers.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct VisibilityConfig {
    pub position_levels: usize,
    pub direction_levels: usize,
    pub depth: usize,
    pub width: usize,
}

impl Default for VisibilityConfig {
    fn default() -> Self {
        Self {
            position_levels: 10,
            direction_levels: 4,
            depth: 4,
            width: 256,
        }
    }
}

/// F_vis (Eq. 3): `[γ(v) ‖ γ(φ) ‖ θ]` → ReLU MLP → one logit.
#[derive(Module, Debug)]
pub struct VisibilityNet {
    pub trunk: SkipMlp,
    pub head: Linear,
    #[module(skip)]
    config: VisibilityConfig,
    #[module(skip)]
    pose_width: usize,
}

impl VisibilityNet {
    /// A network for poses of `pose_width` values (3 per joint, axis-angle).
    pub fn new(config: VisibilityConfig, pose_width: usize, device: &Device) -> Self {
        let inputs = encoded_width(3, config.position_levels)
            + encoded_width(3, config.direction_levels)
            + pose_width;
        let trunk = SkipMlp::new(inputs, config.depth, config.width, None, device);
        Self {
            head: head(config.width, 1, false, device),
            trunk,
            config,
            pose_width,
        }
    }

    /// Input width: `γ(v)` + `γ(φ)` + θ (162 for SMPL's 72-D pose).
    pub fn input_width(&self) -> usize {
        encoded_width(3, self.config.position_levels)
            + encoded_width(3, self.config.direction_levels)
            + self.pose_width
    }

    /// Logits `[N, S]` of canonical points `[N, 3]` under directions `[N, S, 3]` (root frame)
    /// and one pose `[pose_width]` (global orientation zeroed by the caller).
    ///
    /// The first layer is applied block by block, `W₀x = W_v γ(v) + W_φ γ(φ) + W_θ θ`: the
    /// position block once per point, the pose block once, only the direction block per
    /// sample (27 of 162 inputs for SMPL). Equal to [`Self::logit_rows`] on the concatenated
    /// rows up to rounding (tested).
    pub fn logits(&self, points: Tensor<2>, directions: Tensor<3>, pose: Tensor<1>) -> Tensor<2> {
        let [n, s, three] = directions.dims();
        assert_eq!(three, 3, "F_vis directions must be [N, S, 3]");
        assert_eq!(
            points.dims(),
            [n, 3],
            "F_vis points must be [N, 3] for [{n}, {s}, 3] directions"
        );
        assert_eq!(
            pose.dims(),
            [self.pose_width],
            "F_vis was built for poses of {} values",
            self.pose_width
        );
        let first = &self.trunk.layers[0];
        let weight = first.weight.val();
        let [inputs, width] = weight.dims();
        let p = encoded_width(3, self.config.position_levels);
        let d = encoded_width(3, self.config.direction_levels);
        let block = |range: std::ops::Range<usize>| weight.clone().slice([range, 0..width]);
        let mut shared = frequency_encoding(points, self.config.position_levels)
            .matmul(block(0..p))
            + pose
                .reshape([1, self.pose_width])
                .matmul(block(p + d..inputs));
        if let Some(bias) = &first.bias {
            shared = shared + bias.val().reshape([1, width]);
        }
        let per_sample =
            frequency_encoding(directions.reshape([n * s, 3]), self.config.direction_levels)
                .matmul(block(p..p + d))
                .reshape([n, s, width]);
        let x = relu(per_sample + shared.reshape([n, 1, width])).reshape([n * s, width]);
        let hidden = self.trunk.layers[1..]
            .iter()
            .fold(x, |x, layer| relu(layer.forward(x)));
        self.head.forward(hidden).reshape([n, s])
    }

    /// [`Self::logits`] by concatenating every row's full input `[γ(v) ‖ γ(φ) ‖ θ]` (the plain
    /// reference of the blocked first layer).
    pub fn logits_reference(
        &self,
        points: Tensor<2>,
        directions: Tensor<3>,
        pose: Tensor<1>,
    ) -> Tensor<2> {
        let [n, s, _] = directions.dims();
        let position = frequency_encoding(points, self.config.position_levels); // [N, P]
        let p = position.dims()[1];
        let position = position
            .unsqueeze_dim::<3>(1)
            .expand([n, s, p])
            .reshape([n * s, p]);
        let direction =
            frequency_encoding(directions.reshape([n * s, 3]), self.config.direction_levels);
        let pose = pose.unsqueeze_dim::<2>(0).expand([n * s, self.pose_width]);
        let input = Tensor::cat(vec![position, direction, pose], 1);
        self.logit_rows(input).reshape([n, s])
    }

    /// Logits `[R, 1]` of input rows `[R, input_width]` = `[γ(v) ‖ γ(φ) ‖ θ]`.
    pub fn logit_rows(&self, input: Tensor<2>) -> Tensor<2> {
        self.head.forward(self.trunk.forward(input))
    }

    /// Visibility `[R, 1]` of input rows (the ONNX graph's map).
    pub fn probability_rows(&self, input: Tensor<2>) -> Tensor<2> {
        sigmoid(self.logit_rows(input))
    }

    /// Visibility probabilities `[N, S]` in `(0, 1)`.
    pub fn forward(&self, points: Tensor<2>, directions: Tensor<3>, pose: Tensor<1>) -> Tensor<2> {
        sigmoid(self.logits(points, directions, pose))
    }
}

/// Mean binary cross-entropy of `logits` against `labels` in {0, 1} (same shape), in the
/// stable form `max(x, 0) − x·y + ln(1 + e^{−|x|})`.
pub fn bce_with_logits(logits: Tensor<2>, labels: Tensor<2>) -> Tensor<1> {
    assert_eq!(
        logits.dims(),
        labels.dims(),
        "BCE logits and labels differ in shape"
    );
    let softplus = logits.clone().abs().neg().exp().log1p();
    (logits.clone().clamp_min(0.0) - logits * labels + softplus).mean()
}

/// `1` where the ray from `origin + offset · normal` along `direction` leaves the mesh, `0`
/// where the mesh blocks it; `offset = 1e-3 · H` keeps a ray from hitting its own face.
pub fn raycast_visibility(
    bvh: &TriangleBvh,
    origins: &[[f64; 3]],
    normals: &[[f64; 3]],
    directions: &[[f64; 3]],
    offset: f64,
) -> Vec<f32> {
    assert_eq!(origins.len(), normals.len(), "one normal per origin");
    assert_eq!(origins.len(), directions.len(), "one direction per origin");
    origins
        .iter()
        .zip(normals)
        .zip(directions)
        .map(|((o, n), d)| {
            let start = std::array::from_fn(|k| o[k] + offset * n[k]);
            f32::from(u8::from(!bvh.occluded(start, *d, (0.0, f64::INFINITY))))
        })
        .collect()
}

/// Training pairs for F_vis in one pose: random vertices, directions uniform on each vertex's
/// outer hemisphere, and their ray-cast labels.
#[derive(Debug, Clone, PartialEq)]
pub struct VisibilityLabels {
    /// Canonical positions of the chosen vertices.
    pub points: Vec<[f64; 3]>,
    /// World (posed) incident directions, unit.
    pub directions: Vec<[f64; 3]>,
    /// `1` open, `0` blocked.
    pub open: Vec<f32>,
}

/// `count` labelled (vertex, direction) pairs of a posed mesh: vertex `i` is drawn uniformly,
/// its direction uniformly on the hemisphere about its posed normal, and the label cast on
/// `bvh` (built from the same posed mesh) from `1e-3 · height` above the surface.
pub fn sample_labels(
    bvh: &TriangleBvh,
    canonical: &[[f64; 3]],
    posed: &[[f64; 3]],
    posed_normals: &[[f64; 3]],
    height: f64,
    count: usize,
    rng: &mut impl Rng,
) -> VisibilityLabels {
    assert!(!posed.is_empty(), "sample_labels: a mesh without vertices");
    assert_eq!(
        canonical.len(),
        posed.len(),
        "canonical and posed vertex counts differ"
    );
    assert_eq!(
        posed.len(),
        posed_normals.len(),
        "one normal per posed vertex"
    );
    let mut points = Vec::with_capacity(count);
    let mut origins = Vec::with_capacity(count);
    let mut normals = Vec::with_capacity(count);
    let mut directions = Vec::with_capacity(count);
    for _ in 0..count {
        let i = rng.random_range(0..posed.len());
        let n = posed_normals[i];
        let d = loop {
            let d: [f64; 3] = std::array::from_fn(|_| rng.random_range(-1.0..1.0));
            let len2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            if len2 > 1e-4 && len2 <= 1.0 {
                break d.map(|v| v / len2.sqrt());
            }
        };
        let side = d[0] * n[0] + d[1] * n[1] + d[2] * n[2];
        points.push(canonical[i]);
        origins.push(posed[i]);
        normals.push(n);
        directions.push(if side < 0.0 { d.map(|v| -v) } else { d });
    }
    let open = raycast_visibility(bvh, &origins, &normals, &directions, 1e-3 * height);
    VisibilityLabels {
        points,
        directions,
        open,
    }
}
