//! What a capture calls for: the data rule that decides whether the shadow decoder F_ao
//! (Eq. 8–9) is built. F_ao darkens scene Gaussians the person occludes from the light; a
//! capture whose light casts no shadow of the person on the scene (overcast or diffuse light,
//! [`crate::data::CaptureLight::Diffuse`]) gives it nothing to learn, and every stage-2 step
//! would still pay for its evaluation on the scene Gaussians in the person's box and for the
//! smoothness term (Eq. 12).
//!
//! The rule reads the training frames alone: each synthetic frame carries the same view
//! rendered without the person ([`crate::data::IllumFrame::shadow_ratio`]), so a pixel the person does not cover
//! is *shadowed* where it is darker by at least [`DARKENING`]. Pixels next to the person are
//! left out: anti-aliasing blends the person into them (under diffuse light they alone make
//! 0.2 % of the scene pixels "darker" at 160×120). A frame *shows* the shadow when
//! at least [`MIN_PIXEL_FRACTION`] of its scene pixels are shadowed, and the decoder is built
//! when at least [`MIN_FRAME_FRACTION`] of the training frames show it. `ablation.shadow`
//! forces it either way.

use crate::data::IllumCapture;
use splatzoo_train::harness::ModuleChoice;

/// Relative darkening that counts a scene pixel as in the person's shadow (10 %).
pub const DARKENING: f32 = 0.1;
/// Share of a frame's scene pixels in shadow for the frame to show the person's shadow.
pub const MIN_PIXEL_FRACTION: f64 = 0.005;
/// Share of training frames that must show it for the decoder to be built.
pub const MIN_FRAME_FRACTION: f64 = 0.25;

/// What the training frames show of the person's cast shadow.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CastShadow {
    /// Training frames showing the shadow.
    pub frames_showing: usize,
    pub frames: usize,
    /// Mean share of scene pixels in shadow over the training frames.
    pub mean_pixel_fraction: f64,
}

impl CastShadow {
    /// Measures the training frames of `capture`; `None` where they carry no person-free
    /// view (a capture on disk).
    pub fn measure(capture: &IllumCapture) -> Option<Self> {
        let mut frames = 0;
        let mut frames_showing = 0;
        let mut fraction_sum = 0.0;
        for frame in capture.train_frames() {
            let ratio = frame.shadow_ratio()?;
            let near = beside_person(
                &frame.person,
                frame.camera.width as usize,
                frame.camera.height as usize,
            );
            let ratios: Vec<f32> = ratio
                .into_iter()
                .zip(&near)
                .filter_map(|(ratio, &near)| ratio.filter(|_| !near))
                .collect();
            let scene = ratios.len();
            let shadowed = ratios.iter().filter(|&&r| r < 1.0 - DARKENING).count();
            let fraction = shadowed as f64 / scene.max(1) as f64;
            frames += 1;
            fraction_sum += fraction;
            if fraction >= MIN_PIXEL_FRACTION {
                frames_showing += 1;
            }
        }
        Some(Self {
            frames_showing,
            frames,
            mean_pixel_fraction: fraction_sum / frames.max(1) as f64,
        })
    }

    /// Whether enough training frames show the shadow.
    pub fn needs_decoder(&self) -> bool {
        self.frames > 0 && self.frames_showing as f64 >= MIN_FRAME_FRACTION * self.frames as f64
    }
}

/// Pixels on the person or one of its 8 neighbours (`person` is `[h, w]` row-major). Not
/// `splatzoo_datasets::masks::Mask::dilate`: its radius-1 disk is the 5-pixel cross, which
/// leaves the diagonal neighbours anti-aliasing also blends into.
fn beside_person(person: &[bool], w: usize, h: usize) -> Vec<bool> {
    assert_eq!(person.len(), w * h, "the person mask is [h, w]");
    let mut near = vec![false; w * h];
    for y in 0..h {
        for x in 0..w {
            if person[y * w + x] {
                for ny in y.saturating_sub(1)..(y + 2).min(h) {
                    for nx in x.saturating_sub(1)..(x + 2).min(w) {
                        near[ny * w + nx] = true;
                    }
                }
            }
        }
    }
    near
}

/// The shadow decoder's decision: `forced` (`ablation.shadow`) wins, otherwise the rule; a
/// capture without person-free views cannot be measured, so the decoder is built there (the
/// paper's full model).
pub fn shadow_decoder(forced: Option<bool>, capture: &IllumCapture) -> ModuleChoice {
    let (needed, why) = match CastShadow::measure(capture) {
        Some(shadow) => (
            shadow.needs_decoder(),
            format!(
                "the person's shadow (≥ {:.0} % darker) covers {:.2} % of the scene pixels on \
                 average and shows in {} of {} training frames (built when ≥ {:.0} % of them \
                 show it)",
                100.0 * DARKENING,
                100.0 * shadow.mean_pixel_fraction,
                shadow.frames_showing,
                shadow.frames,
                100.0 * MIN_FRAME_FRACTION,
            ),
        ),
        None => (
            true,
            "the capture has no person-free view of its frames to measure the cast shadow by; \
             built, as the paper's full model"
                .to_owned(),
        ),
    };
    ModuleChoice::decide(
        "shadow decoder F_ao (Eq. 8–9)",
        "ablation.shadow",
        forced,
        needed,
        why,
    )
}
