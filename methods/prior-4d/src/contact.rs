//! The contact loss (Eq. 7 of Prior-4D): the `N_c = 25` foot vertices nearest the floor plane π
//! kept within `Δ_c = 0.02` of it, `Σ max(0, |nᵀV + d| − Δ_c)`, so the avatar neither floats nor
//! sinks in. It is the one term besides occlusion that can see the global scale σ.
//!
//! Two readings the paper leaves open, each a knob (spec, Eq. 7):
//! - which 25: the paper's "closest" by `|distance|` picks the vertices where the sole crosses
//!   the floor once a foot has sunk in, and the loss then reads zero while the foot penetrates;
//!   the default takes the 25 *lowest* by signed distance ([`ContactSelect`]);
//! - the units the term is read in ([`ContactUnits`]): by default metres on the body — `Δ_c`
//!   is 2 cm of the body (`× σ` into the scene) and the residual is divided by σ (detached), so
//!   the term's weight means the same in a scene of any unit; or scene units as written, where
//!   the same foot error weighs σ times more in a scene whose unit is σ times smaller.
//!
//! Foot vertices are those whose dominant skinning weight is on an ankle or foot joint (SMPL
//! joints 7, 8, 10, 11) and whose rest height is at most their ankle's + 2 cm: sole, heel and
//! toes ([`foot_vertices`]). Selection is host-side on detached distances; the loss is Burn ops,
//! so its gradient reaches whatever placed the vertices (σ, the root, the pose, the offsets)
//! while the plane stays constant.

use crate::error::Prior4dError;
use crate::plane::Plane;
use burn::tensor::{Int, Tensor, TensorData};
use serde::{Deserialize, Serialize};
use splatzoo_models::body::BodyModel;

/// SMPL joint indices of the left/right ankle and foot (the same in SMPL-H and SMPL-X).
pub const LEFT_ANKLE: usize = 7;
pub const RIGHT_ANKLE: usize = 8;
pub const LEFT_FOOT: usize = 10;
pub const RIGHT_FOOT: usize = 11;

/// Which foot vertices count as contact candidates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ContactSelect {
    /// The lowest by signed distance (default: a sunken foot keeps a loss).
    Lowest,
    /// The closest by `|distance|`, as the paper writes it.
    Closest,
}

/// The units Eq. 7 is read in: its margin `Δ_c` and its residual.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ContactUnits {
    /// Metres on the body: `Δ_c · σ` in the scene, the residual `÷ σ` (σ detached).
    Metres,
    /// Scene units as they are, margin and residual.
    Scene,
}

/// Eq. 7's knobs.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ContactConfig {
    /// `N_c`.
    pub count: usize,
    /// `Δ_c`.
    pub margin: f64,
    pub units: ContactUnits,
    pub select: ContactSelect,
}

impl Default for ContactConfig {
    fn default() -> Self {
        Self {
            count: 25,
            margin: 0.02,
            units: ContactUnits::Metres,
            select: ContactSelect::Lowest,
        }
    }
}

impl ContactConfig {
    /// `Δ_c` in scene units at global scale `sigma`.
    pub fn margin_in_scene(&self, sigma: f64) -> f64 {
        match self.units {
            ContactUnits::Metres => self.margin * sigma,
            ContactUnits::Scene => self.margin,
        }
    }

    /// What the scene-unit residual is multiplied by at global scale `sigma`: `1 / σ` in
    /// metres, 1 in scene units.
    pub fn residual_factor(&self, sigma: f64) -> f64 {
        match self.units {
            ContactUnits::Metres => 1.0 / sigma,
            ContactUnits::Scene => 1.0,
        }
    }
}

/// The foot vertices of `model` at rest (indices into its vertices), as the module doc defines
/// them; the body's up axis is +y.
pub fn foot_vertices(model: &BodyModel) -> Vec<usize> {
    let v = model.vertex_count();
    let j = model.joint_count();
    let height = |k: usize| f64::from(model.template[3 * k + 1]);
    let joint_height = |joint: usize| -> f64 {
        (0..v)
            .map(|k| f64::from(model.joint_regressor[joint * v + k]) * height(k))
            .sum()
    };
    let ankles = [joint_height(LEFT_ANKLE), joint_height(RIGHT_ANKLE)];
    (0..v)
        .filter(|&k| {
            let row = &model.skin_weights[k * j..(k + 1) * j];
            let dominant = (0..j)
                .max_by(|&a, &b| row[a].total_cmp(&row[b]))
                .unwrap_or(0);
            let ankle = match dominant {
                LEFT_ANKLE | LEFT_FOOT => ankles[0],
                RIGHT_ANKLE | RIGHT_FOOT => ankles[1],
                _ => return false,
            };
            height(k) <= ankle + 0.02
        })
        .collect()
}

/// One evaluation of Eq. 7.
pub struct ContactTerm {
    /// `[1]` the loss, in [`ContactConfig::units`].
    pub loss: Tensor<1>,
    /// Rows of the input that were selected, in selection order.
    pub selected: Vec<usize>,
    /// Signed distances of every input row to the plane (scene units, detached).
    pub distances: Vec<f64>,
}

/// Eq. 7 on foot vertices `[F, 3]` in the world (scene units) against the constant `plane`, at
/// global scale `sigma` (a detached value: it converts units, [`ContactConfig::units`]).
pub fn contact_loss(
    feet: Tensor<2>,
    plane: &Plane,
    config: &ContactConfig,
    sigma: f64,
) -> Result<ContactTerm, Prior4dError> {
    let [f, d] = feet.dims();
    if d != 3 || f == 0 {
        return Err(Prior4dError::input(
            "contact loss",
            format!("foot vertices must be [F ≥ 1, 3], got [{f}, {d}]"),
        ));
    }
    let margin = config.margin_in_scene(sigma);
    let factor = config.residual_factor(sigma);
    if config.count == 0
        || !(margin.is_finite() && margin >= 0.0)
        || !(sigma.is_finite() && sigma > 0.0 && factor.is_finite())
    {
        return Err(Prior4dError::input(
            "contact loss",
            format!(
                "needs count ≥ 1, a finite margin ≥ 0 and a finite σ > 0, got count {}, margin \
                 {} and σ {sigma}",
                config.count, config.margin
            ),
        ));
    }
    let device = feet.device();
    let normal = Tensor::<2>::from_data(
        TensorData::new(plane.normal.map(|v| v as f32).to_vec(), [3, 1]),
        &device,
    );
    let signed = feet.matmul(normal).reshape([f]).add_scalar(plane.offset); // [F]
    let distances: Vec<f64> = signed
        .clone()
        .into_data()
        .convert::<f32>()
        .try_into_vec::<f32>()
        .map_err(|e| Prior4dError::input("contact loss", format!("{e:?}")))?
        .into_iter()
        .map(f64::from)
        .collect();
    if let Some(k) = distances.iter().position(|v| !v.is_finite()) {
        return Err(Prior4dError::input(
            "contact loss",
            format!(
                "foot vertex {k} is not finite (its distance to the floor is {})",
                distances[k]
            ),
        ));
    }
    let mut order: Vec<usize> = (0..f).collect();
    match config.select {
        ContactSelect::Lowest => order.sort_by(|&a, &b| distances[a].total_cmp(&distances[b])),
        ContactSelect::Closest => {
            order.sort_by(|&a, &b| distances[a].abs().total_cmp(&distances[b].abs()))
        }
    }
    order.truncate(config.count.min(f));
    let idx: Vec<i64> = order.iter().map(|&k| k as i64).collect();
    let idx = Tensor::<1, Int>::from_data(TensorData::new(idx, [order.len()]), &device);
    let loss = (signed.select(0, idx).abs() - margin)
        .clamp_min(0.0)
        .sum()
        .mul_scalar(factor);
    Ok(ContactTerm {
        loss,
        selected: order,
        distances,
    })
}
