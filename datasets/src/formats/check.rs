//! Decodes every image and mask of a [`Dataset`] and checks it against its camera: readable,
//! the camera's size, and (for masks) holding both person and background. Images are decoded
//! in parallel in batches of a few per thread, each dropped after its check, so memory stays
//! bounded by the batch whatever the dataset's size.

use super::{Dataset, ViewRecord};
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
}

/// One view's outcome: its image size where it decoded, whether it has a mask, its problems.
struct ViewCheck {
    size: Option<(u32, u32)>,
    has_mask: bool,
    problems: Vec<(String, String)>,
}

fn check_view(view: &ViewRecord) -> ViewCheck {
    let mut problems = Vec::new();
    let expected = (view.camera.width, view.camera.height);
    let name = view.image.display().to_string();
    let size = match image::open(&view.image) {
        Ok(img) => {
            let size = (img.width(), img.height());
            if size != expected {
                problems.push((
                    name,
                    format!(
                        "is {}×{}, its camera says {}×{}",
                        size.0, size.1, expected.0, expected.1
                    ),
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
        };
    };
    let name = mask.display().to_string();
    match view.read_mask().expect("the view has a mask") {
        Ok((w, h, person)) => {
            if (w, h) != expected {
                problems.push((
                    name,
                    format!("is {w}×{h}, its camera says {}×{}", expected.0, expected.1),
                ));
            } else if !person.iter().any(|&p| p) {
                problems.push((name, "marks no person pixel".into()));
            }
        }
        Err(e) => problems.push((name, e.to_string())),
    }
    ViewCheck {
        size,
        has_mask: true,
        problems,
    }
}

/// Checks at most `limit` views (all when `None`).
pub fn check(dataset: &Dataset, limit: Option<usize>) -> CheckReport {
    let views = &dataset.views[..limit.unwrap_or(usize::MAX).min(dataset.views.len())];
    let batch = 2 * rayon::current_num_threads().max(1);
    let mut report = CheckReport::default();
    for chunk in views.chunks(batch) {
        let results: Vec<_> = chunk.par_iter().map(check_view).collect();
        for ViewCheck {
            size,
            has_mask,
            problems,
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
        }
    }
    report
}
