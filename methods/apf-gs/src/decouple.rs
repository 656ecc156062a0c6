//! Self-supervised decoupling (§II-B, Eq. 3): `M_acc = M_coarse \ M_kine`, where `M_kine` is
//! the silhouette of the *initial* body prior `(θ₀, β)` rendered by the CPU mesh renderer
//! (independent of the splat rasterizer; masks are preprocessing, no gradient flows).
//!
//! Applied per tracked person `h` (a global difference would call every untracked pedestrian
//! an accessory): `M_coarse^h` is the dataset's coarse mask inside the filled projection of
//! `h`'s 3-D box, and the prior meshes of all tracked people are rendered together, so `h`
//! owns a pixel of `M_kine` only where its mesh is in front. Untracked people get no
//! `M_kine` and, lying in no tracked box, no `M_acc`.
//!
//! The cleanup (on by default; off is the literal equation, bit for bit):
//! (i) `M_kine^h ← M_kine^h ∩ M_coarse^h`; (ii) subtract `M_kine^h` dilated by
//! `d = max(2 px, 0.015 · box height)`, so slivers left by a misaligned prior are not
//! accessory, and every other tracked person's dilated `M_kine`; (iii) an opening of radius 1
//! and dropping components smaller than 0.5 % of the box. An accessory node is created only
//! when `M_acc^h` covers ≥ 3 % of `M_coarse^h` in ≥ 30 % of the views where `h` is visible.

use serde::{Deserialize, Serialize};
use splatzoo_datasets::masks::Mask;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DecoupleConfig {
    /// Off: Table II's "w/o decoupling" (humans supervised by `M_coarse`, no accessory nodes).
    pub enabled: bool,
    /// The cleanup; off is the literal Eq. 3.
    pub cleanup: bool,
    /// Dilation of `M_kine` before subtracting: at least `min_dilation` pixels, else this
    /// fraction of the box height.
    pub min_dilation: usize,
    pub dilation_fraction: f64,
    /// Opening radius, pixels.
    pub opening: usize,
    /// Components smaller than this fraction of the box area are dropped.
    pub min_component: f64,
    /// An accessory node needs `M_acc` ≥ `accessory_area` of `M_coarse^h` in at least
    /// `accessory_views` of the views showing the person.
    pub accessory_area: f64,
    pub accessory_views: f64,
    /// Forces every tracked person's accessory node on or off; absent, the rule above decides.
    pub accessories: Option<bool>,
    /// Re-render `M_kine` from the refined poses every this many steps (0: never, the paper's
    /// θ₀ silhouette throughout; [`crate::refresh`]).
    pub refresh_every: usize,
}

impl Default for DecoupleConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            cleanup: true,
            min_dilation: 2,
            dilation_fraction: 0.015,
            opening: 1,
            min_component: 0.005,
            accessory_area: 0.03,
            accessory_views: 0.3,
            accessories: None,
            refresh_every: 0,
        }
    }
}

/// One tracked person in one view.
#[derive(Debug, Clone)]
pub struct PersonMasks {
    /// `M_coarse^h`: the coarse mask inside the person's projected box.
    pub coarse: Mask,
    /// `M_kine^h` (after cleanup step (i) when the cleanup is on).
    pub kine: Mask,
    /// `M_acc^h`.
    pub accessory: Mask,
    /// The projected box's bounding rectangle `[x0, y0, x1, y1)`, if any of it is on screen.
    pub rectangle: Option<[usize; 4]>,
}

impl PersonMasks {
    /// Whether the person shows in this view.
    pub fn visible(&self) -> bool {
        self.coarse.area() > 0
    }
}

/// Eq. 3 for every tracked person of one view: `coarse` is the dataset's merged mask, `boxes`
/// the filled projection of each tracked person's box, `kine_owner` the prior render's
/// per-pixel owner (`Some(h)` where person `h`'s prior mesh is nearest).
pub fn decouple_view(
    config: &DecoupleConfig,
    coarse: &Mask,
    boxes: &[Mask],
    kine_owner: &[Option<usize>],
) -> Vec<PersonMasks> {
    let (w, h) = (coarse.width, coarse.height);
    assert_eq!(kine_owner.len(), w * h, "one owner per pixel");
    let kine_of = |p: usize| Mask::new(w, h, kine_owner.iter().map(|&o| o == Some(p)).collect());
    let kines: Vec<Mask> = (0..boxes.len()).map(kine_of).collect();
    boxes
        .iter()
        .enumerate()
        .map(|(p, b)| {
            let person_coarse = coarse.and(b);
            let rectangle = b.bounding_box();
            if !config.cleanup {
                let kine = kines[p].clone();
                return PersonMasks {
                    accessory: person_coarse.minus(&kine),
                    coarse: person_coarse,
                    kine,
                    rectangle,
                };
            }
            let kine = kines[p].and(&person_coarse);
            let box_height = rectangle.map_or(0, |r| r[3] - r[1]);
            let box_area = rectangle.map_or(0, |r| (r[2] - r[0]) * (r[3] - r[1]));
            let d = config
                .min_dilation
                .max((config.dilation_fraction * box_height as f64).round() as usize);
            let mut accessory = person_coarse.minus(&kines[p].dilate(d));
            for (q, other) in kines.iter().enumerate() {
                if q != p && other.area() > 0 {
                    accessory = accessory.minus(&other.dilate(d));
                }
            }
            let accessory = accessory
                .open(config.opening)
                .drop_small_components((config.min_component * box_area as f64).ceil() as usize);
            PersonMasks {
                coarse: person_coarse,
                kine,
                accessory,
                rectangle,
            }
        })
        .collect()
}

/// Whether a person gets an accessory node, from their masks in every view, with the reason.
pub fn wants_accessory(config: &DecoupleConfig, views: &[&PersonMasks]) -> (bool, String) {
    let visible: Vec<&&PersonMasks> = views.iter().filter(|m| m.visible()).collect();
    if visible.is_empty() {
        return (false, "never visible".into());
    }
    let carrying = visible
        .iter()
        .filter(|m| {
            m.accessory.area() as f64 >= config.accessory_area * m.coarse.area() as f64
                && m.accessory.area() > 0
        })
        .count();
    let share = carrying as f64 / visible.len() as f64;
    let yes = share >= config.accessory_views;
    (
        yes,
        format!(
            "M_acc ≥ {:.0} % of M_coarse in {carrying} of {} views ({:.0} %, threshold {:.0} %)",
            100.0 * config.accessory_area,
            visible.len(),
            100.0 * share,
            100.0 * config.accessory_views
        ),
    )
}
