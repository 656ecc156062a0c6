//! Where each point's name goes on a sweep figure: beside its marker, in the first of a few
//! candidate spots that overlaps neither a name already placed nor another marker, so points
//! that land close together (knobs that change little) stay readable. Pixel coordinates, y
//! down, as the drawing backend has them.

/// A label's box in pixels: top-left corner and size.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LabelBox {
    pub x: i32,
    pub y: i32,
    pub width: i32,
    pub height: i32,
}

impl LabelBox {
    fn overlaps(&self, other: &LabelBox) -> bool {
        self.x < other.x + other.width
            && other.x < self.x + self.width
            && self.y < other.y + other.height
            && other.y < self.y + self.height
    }

    fn inside(&self, area: &LabelBox) -> bool {
        self.x >= area.x
            && self.y >= area.y
            && self.x + self.width <= area.x + area.width
            && self.y + self.height <= area.y + area.height
    }
}

/// The gap between a marker's centre and its label, and a marker's half-size, in pixels.
const GAP: i32 = 8;

/// Each label's offset `(dx, dy)` from its marker to the label's top-left corner.
/// `markers[i]` is point `i`'s pixel position, `sizes[i]` its label's `(width, height)`;
/// labels are placed in `order` (the most important first) within `area`. A label goes to the
/// first candidate spot (right above, right below, left above, left below, then further up or
/// down) that stays in `area` and clears every label placed before it and every marker; where
/// none does, to the spot with the least overlap.
pub fn place_labels(
    markers: &[(i32, i32)],
    sizes: &[(i32, i32)],
    order: &[usize],
    area: LabelBox,
) -> Vec<(i32, i32)> {
    assert_eq!(markers.len(), sizes.len(), "one label size per marker");
    let marker_boxes: Vec<LabelBox> = markers
        .iter()
        .map(|&(x, y)| LabelBox {
            x: x - GAP,
            y: y - GAP,
            width: 2 * GAP,
            height: 2 * GAP,
        })
        .collect();
    let mut offsets = vec![(GAP, -GAP - 10); markers.len()];
    let mut placed: Vec<LabelBox> = Vec::with_capacity(markers.len());
    for &i in order {
        let (w, h) = sizes[i];
        let candidates = [
            (GAP, -GAP - h),
            (GAP, GAP),
            (-GAP - w, -GAP - h),
            (-GAP - w, GAP),
            (GAP, -GAP - 2 * h),
            (GAP, GAP + h),
            (-GAP - w, -GAP - 2 * h),
            (-GAP - w, GAP + h),
            (GAP, -GAP - 3 * h),
            (GAP, GAP + 2 * h),
        ];
        let at = |(dx, dy): (i32, i32)| LabelBox {
            x: markers[i].0 + dx,
            y: markers[i].1 + dy,
            width: w,
            height: h,
        };
        let overlap = |offset: (i32, i32)| -> i64 {
            let label = at(offset);
            let area_penalty = if label.inside(&area) { 0 } else { 1_000_000 };
            let clashes = placed
                .iter()
                .chain(
                    marker_boxes
                        .iter()
                        .enumerate()
                        .filter(|&(j, _)| j != i)
                        .map(|(_, b)| b),
                )
                .filter(|b| b.overlaps(&label))
                .count() as i64;
            area_penalty + clashes
        };
        let offset = candidates
            .into_iter()
            .min_by_key(|&offset| overlap(offset))
            .expect("candidates");
        offsets[i] = offset;
        placed.push(at(offset));
    }
    offsets
}
