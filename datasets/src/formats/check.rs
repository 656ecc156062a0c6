//! Decodes every image and mask of a [`Dataset`] and checks it against its camera: readable,
//! the camera's size (after the dataset's [`Dataset::image_downscale`], where the files are
//! full resolution), and (for masks) marking some person pixel. Images are decoded in parallel
//! in batches of a few per thread, each dropped after its check, so memory stays bounded by the
//! batch whatever the dataset's size.
//!
//! What it finds is either a problem (the data is unreadable or contradicts itself: a caller
//! should not train on it) or a warning (valid data worth saying). A mask that marks no one is a
//! problem where the format's masks segment a person who is always in view (NeuMan's own reader
//! asserts a non-empty mask), and a warning for drivestudio, whose `dynamic_masks/human/` holds
//! one box mask per image, all zero wherever no pedestrian or cyclist moves (its
//! `waymo_preprocess.py` writes it for every image).

use super::colmap_scene::downscaled_size;
use super::{Dataset, Format, ViewRecord};
use rayon::prelude::*;

/// What checking found.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CheckReport {
    pub images: usize,
    pub masks: usize,
    /// Distinct image sizes seen, (width, height).
    pub sizes: Vec<(u32, u32)>,
    /// Problems in view order: (file, problem).
    pub problems: Vec<(String, String)>,
    /// Facts worth a warning, not problems: the dataset's load-time warnings
    /// ([`Dataset::warnings`]) first, then the checked views' in view order: (file, fact).
    pub warnings: Vec<(String, String)>,
}

/// Whether a format's person masks may validly mark no one.
pub fn empty_masks_are_valid(format: Format) -> bool {
    // drivestudio's human masks are boxes of *moving* pedestrians and cyclists (speed > 1 m/s),
    // written for every image: most are empty.
    matches!(format, Format::Drivestudio)
}

/// One view's outcome: its image size where it decoded, whether it has a mask, its problems
/// and warnings.
struct ViewCheck {
    size: Option<(u32, u32)>,
    has_mask: bool,
    problems: Vec<(String, String)>,
    warnings: Vec<(String, String)>,
}

/// Whether a file of `size` matches a camera of `expected` size once shrunk by `downscale`,
/// and the size as said in a problem: `w×h`, or `w×h (w'×h' at 1/N)`.
fn file_size(size: (u32, u32), downscale: u32, expected: (u32, u32)) -> (bool, String) {
    if downscale <= 1 {
        return (size == expected, format!("{}×{}", size.0, size.1));
    }
    let seen = downscaled_size(size.0, size.1, downscale);
    (
        seen == expected,
        format!(
            "{}×{} ({}×{} at 1/{downscale})",
            size.0, size.1, seen.0, seen.1
        ),
    )
}

fn check_view(view: &ViewRecord, empty_mask_is_valid: bool, downscale: u32) -> ViewCheck {
    let mut problems = Vec::new();
    let mut warnings = Vec::new();
    let expected = (view.camera.width, view.camera.height);
    let name = view.image.display().to_string();
    let size = match image::open(&view.image) {
        Ok(img) => {
            let size = (img.width(), img.height());
            let (matches, seen) = file_size(size, downscale, expected);
            if !matches {
                problems.push((
                    name,
                    format!("is {seen}, its camera says {}×{}", expected.0, expected.1),
                ));
            }
            Some(size)
        }
        Err(e) => {
            problems.push((name, format!("cannot decode ({e})")));
            None
        }
    };
    let Some(mask) = &view.mask else {
        return ViewCheck {
            size,
            has_mask: false,
            problems,
            warnings,
        };
    };
    let name = mask.display().to_string();
    match view.read_mask().expect("the view has a mask") {
        Ok((w, h, person)) => {
            let (matches, seen) = file_size((w, h), downscale, expected);
            if !matches {
                problems.push((
                    name,
                    format!("is {seen}, its camera says {}×{}", expected.0, expected.1),
                ));
            } else if !person.iter().any(|&p| p) {
                if empty_mask_is_valid {
                    warnings.push((
                        name,
                        "marks no person pixel (valid here: no pedestrian or cyclist moves in \
                         view)"
                            .into(),
                    ));
                } else {
                    problems.push((name, "marks no person pixel".into()));
                }
            }
        }
        Err(e) => problems.push((name, e.to_string())),
    }
    ViewCheck {
        size,
        has_mask: true,
        problems,
        warnings,
    }
}

/// Checks at most `limit` views (all when `None`).
pub fn check(dataset: &Dataset, limit: Option<usize>) -> CheckReport {
    let views = &dataset.views[..limit.unwrap_or(usize::MAX).min(dataset.views.len())];
    let batch = 2 * rayon::current_num_threads().max(1);
    let empty_mask_is_valid = empty_masks_are_valid(dataset.format);
    let mut report = CheckReport {
        warnings: dataset.warnings.clone(),
        ..CheckReport::default()
    };
    for chunk in views.chunks(batch) {
        let results: Vec<_> = chunk
            .par_iter()
            .map(|view| check_view(view, empty_mask_is_valid, dataset.image_downscale))
            .collect();
        for ViewCheck {
            size,
            has_mask,
            problems,
            warnings,
        } in results
        {
            if let Some(s) = size {
                report.images += 1;
                if !report.sizes.contains(&s) {
                    report.sizes.push(s);
                }
            }
            report.masks += has_mask as usize;
            report.problems.extend(problems);
            report.warnings.extend(warnings);
        }
    }
    report
}
