//! Binary-mask image operations for APF-GS's self-supervised decoupling (Eq. 3,
//! `M_acc^h = M_coarse^h \ M_kine^h`, applied per instance; see `specs/apf-gs.md`).
//!
//! The decoupling needs a handful of plain operations on per-pixel masks: the set operations of
//! Eq. 3 ([`Mask::and`], [`Mask::or`], [`Mask::minus`]), the filled 2-D hull of a projected 3-D
//! box that bounds `M_coarse^h` ([`Mask::fill_convex_polygon`]), and the cleanup — dilating the
//! kinematic silhouette ([`Mask::dilate`]), a morphological opening ([`Mask::open`]) and dropping
//! small connected components ([`Mask::drop_small_components`]) — plus areas, boxes and IoU to
//! decide whether an accessory exists, and crops of an image around an instance
//! ([`crop_resize`], [`grow_box`]). These are preprocessing: no gradients, no dependencies, a
//! plain CPU reference.
//!
//! Conventions: a mask is row-major, pixel `(x, y)` at index `y * width + x`, pixel `(x, y)`
//! covering `[x, x + 1) × [y, y + 1)` with its centre at `(x + 0.5, y + 0.5)`. The structuring
//! element of [`Mask::dilate`] and [`Mask::erode`] is the digital disk `dx² + dy² ≤ r²` (radius 1
//! is the 5-pixel cross, radius 2 has 13 pixels). Dilation ignores what lies outside the image;
//! erosion counts the outside as set, so a mask touching the border is not eaten from the border.
//! With these two choices erosion and dilation are adjoint, so [`Mask::open`] and [`Mask::close`]
//! are idempotent.

/// A binary mask of `width × height` pixels, row-major (`data[y * width + x]`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Mask {
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// `width * height` values, row-major; `true` = in the mask.
    pub data: Vec<bool>,
}

impl Mask {
    /// A mask from row-major data.
    ///
    /// # Panics
    /// When `data.len() != width * height`.
    pub fn new(width: usize, height: usize, data: Vec<bool>) -> Self {
        assert_eq!(
            data.len(),
            width * height,
            "mask data has {} values, expected width {width} × height {height} = {}",
            data.len(),
            width * height
        );
        Self {
            width,
            height,
            data,
        }
    }

    /// A mask with no pixel set.
    pub fn empty(width: usize, height: usize) -> Self {
        Self::new(width, height, vec![false; width * height])
    }

    /// The number of set pixels.
    pub fn area(&self) -> usize {
        self.data.iter().filter(|&&v| v).count()
    }

    /// Whether pixel `(x, y)` is set.
    ///
    /// # Panics
    /// When `(x, y)` lies outside the mask.
    pub fn get(&self, x: usize, y: usize) -> bool {
        assert!(
            x < self.width && y < self.height,
            "pixel ({x}, {y}) outside the {}×{} mask",
            self.width,
            self.height
        );
        self.data[y * self.width + x]
    }

    /// Pixels set in both masks.
    ///
    /// # Panics
    /// When the masks differ in size.
    pub fn and(&self, other: &Mask) -> Mask {
        self.zip_with(other, "and", |a, b| a && b)
    }

    /// Pixels set in either mask.
    ///
    /// # Panics
    /// When the masks differ in size.
    pub fn or(&self, other: &Mask) -> Mask {
        self.zip_with(other, "or", |a, b| a || b)
    }

    /// The set difference `self \ other`: pixels set here and not in `other`.
    ///
    /// # Panics
    /// When the masks differ in size.
    pub fn minus(&self, other: &Mask) -> Mask {
        self.zip_with(other, "minus", |a, b| a && !b)
    }

    /// Dilation by the digital disk `dx² + dy² ≤ radius²`: a pixel is set when any set pixel lies
    /// within the disk around it. Radius 0 is the identity; the outside of the image is empty.
    ///
    /// Each disk row `dy` is a run `|dx| ≤ ⌊√(r² − dy²)⌋`, tested in O(1) with per-row prefix
    /// counts, so the cost is O(width · height · radius).
    pub fn dilate(&self, radius: usize) -> Mask {
        if radius == 0 {
            return self.clone();
        }
        let (w, h) = (self.width, self.height);
        // prefix[y * (w + 1) + x] = number of set pixels in row y left of column x.
        let mut prefix = vec![0usize; h * (w + 1)];
        for y in 0..h {
            let row = &self.data[y * w..(y + 1) * w];
            let p = &mut prefix[y * (w + 1)..(y + 1) * (w + 1)];
            let mut count = 0;
            for (x, &v) in row.iter().enumerate() {
                count += usize::from(v);
                p[x + 1] = count;
            }
        }
        // half[|dy|] = the disk's half-width in row dy.
        let half: Vec<usize> = (0..=radius)
            .map(|dy| (radius * radius - dy * dy).isqrt())
            .collect();
        let mut data = vec![false; w * h];
        for y in 0..h {
            let y_lo = y.saturating_sub(radius);
            let y_hi = (y + radius).min(h - 1);
            for x in 0..w {
                data[y * w + x] = (y_lo..=y_hi).any(|sy| {
                    let k = half[sy.abs_diff(y)];
                    let lo = x.saturating_sub(k);
                    let hi = (x + k + 1).min(w);
                    let p = &prefix[sy * (w + 1)..(sy + 1) * (w + 1)];
                    p[hi] > p[lo]
                });
            }
        }
        Mask::new(w, h, data)
    }

    /// Erosion by the digital disk `dx² + dy² ≤ radius²`, the dual of [`Mask::dilate`]: a pixel
    /// stays set when every pixel of the disk around it that lies inside the image is set.
    /// The outside of the image counts as set, so a mask touching the border is not eaten from
    /// the border. Radius 0 is the identity.
    pub fn erode(&self, radius: usize) -> Mask {
        self.complement().dilate(radius).complement()
    }

    /// Morphological opening, erode then dilate with the same disk: removes specks and parts
    /// thinner than the disk. Note that a square loses its corners to a disk (radius 1: the
    /// cross), since no disk placed inside the square covers them.
    pub fn open(&self, radius: usize) -> Mask {
        self.erode(radius).dilate(radius)
    }

    /// Morphological closing, dilate then erode with the same disk: fills holes and gaps
    /// narrower than the disk.
    pub fn close(&self, radius: usize) -> Mask {
        self.dilate(radius).erode(radius)
    }

    /// The 8-connected components of the set pixels, each as its pixel indices
    /// (`y * width + x`) in ascending (raster) order; components are ordered by their first
    /// pixel in raster order. Iterative flood fill (no recursion).
    pub fn components(&self) -> Vec<Vec<usize>> {
        let (w, h) = (self.width, self.height);
        let mut seen = vec![false; w * h];
        let mut components = Vec::new();
        let mut stack = Vec::new();
        for (start, &set) in self.data.iter().enumerate() {
            if !set || seen[start] {
                continue;
            }
            seen[start] = true;
            stack.push(start);
            let mut component = Vec::new();
            while let Some(i) = stack.pop() {
                component.push(i);
                let (x, y) = (i % w, i / w);
                for ny in y.saturating_sub(1)..=(y + 1).min(h - 1) {
                    for nx in x.saturating_sub(1)..=(x + 1).min(w - 1) {
                        let j = ny * w + nx;
                        if self.data[j] && !seen[j] {
                            seen[j] = true;
                            stack.push(j);
                        }
                    }
                }
            }
            component.sort_unstable();
            components.push(component);
        }
        components
    }

    /// The mask with every 8-connected component of fewer than `min_area` pixels removed.
    pub fn drop_small_components(&self, min_area: usize) -> Mask {
        let mut data = vec![false; self.width * self.height];
        for component in self.components() {
            if component.len() >= min_area {
                for i in component {
                    data[i] = true;
                }
            }
        }
        Mask::new(self.width, self.height, data)
    }

    /// The tight box `[x0, y0, x1, y1]` around the set pixels (`x1`, `y1` exclusive), or `None`
    /// for an empty mask.
    pub fn bounding_box(&self) -> Option<[usize; 4]> {
        let w = self.width;
        let mut bb: Option<[usize; 4]> = None;
        for (i, _) in self.data.iter().enumerate().filter(|(_, v)| **v) {
            let (x, y) = (i % w, i / w);
            bb = Some(match bb {
                None => [x, y, x + 1, y + 1],
                Some([x0, y0, x1, y1]) => [x0.min(x), y0.min(y), x1.max(x + 1), y1.max(y + 1)],
            });
        }
        bb
    }

    /// Intersection over union, or `None` when both masks are empty.
    ///
    /// # Panics
    /// When the masks differ in size.
    pub fn iou(&self, other: &Mask) -> Option<f64> {
        self.assert_same_size(other, "iou");
        let (mut intersection, mut union) = (0usize, 0usize);
        for (&a, &b) in self.data.iter().zip(&other.data) {
            intersection += usize::from(a && b);
            union += usize::from(a || b);
        }
        if union == 0 {
            None
        } else {
            Some(intersection as f64 / union as f64)
        }
    }

    /// The filled convex hull of pixel-space points (e.g. a projected 3-D box's 8 corners) on a
    /// `width × height` mask: the hull is computed first (Andrew's monotone chain), then every
    /// pixel whose centre `(x + 0.5, y + 0.5)` lies inside the hull or on its boundary is set.
    /// Points may lie outside the image (the hull is clipped); non-finite points are ignored;
    /// fewer than 3 distinct non-collinear points give an empty mask.
    pub fn fill_convex_polygon(width: usize, height: usize, points: &[[f64; 2]]) -> Mask {
        let mut mask = Mask::empty(width, height);
        let hull = convex_hull(points);
        if hull.len() < 3 {
            return mask;
        }
        let (mut min_x, mut min_y) = (f64::INFINITY, f64::INFINITY);
        let (mut max_x, mut max_y) = (f64::NEG_INFINITY, f64::NEG_INFINITY);
        for p in &hull {
            min_x = min_x.min(p[0]);
            min_y = min_y.min(p[1]);
            max_x = max_x.max(p[0]);
            max_y = max_y.max(p[1]);
        }
        // Pixels whose centre lies within the hull's box, clipped to the image.
        let x_start = (min_x - 0.5).ceil().clamp(0.0, width as f64) as usize;
        let x_end = ((max_x - 0.5).floor() + 1.0).clamp(0.0, width as f64) as usize;
        let y_start = (min_y - 0.5).ceil().clamp(0.0, height as f64) as usize;
        let y_end = ((max_y - 0.5).floor() + 1.0).clamp(0.0, height as f64) as usize;
        let n = hull.len();
        for y in y_start..y_end {
            for x in x_start..x_end {
                let c = [x as f64 + 0.5, y as f64 + 0.5];
                // The hull is counter-clockwise (in x-right, y-up terms): inside = left of or on
                // every edge.
                if (0..n).all(|k| cross(hull[k], hull[(k + 1) % n], c) >= 0.0) {
                    mask.data[y * width + x] = true;
                }
            }
        }
        mask
    }

    /// Every pixel flipped.
    fn complement(&self) -> Mask {
        Mask::new(
            self.width,
            self.height,
            self.data.iter().map(|&v| !v).collect(),
        )
    }

    fn assert_same_size(&self, other: &Mask, op: &str) {
        assert!(
            self.width == other.width && self.height == other.height,
            "mask {op}: sizes differ, {}×{} vs {}×{}",
            self.width,
            self.height,
            other.width,
            other.height
        );
    }

    fn zip_with(&self, other: &Mask, op: &str, f: impl Fn(bool, bool) -> bool) -> Mask {
        self.assert_same_size(other, op);
        let data = self
            .data
            .iter()
            .zip(&other.data)
            .map(|(&a, &b)| f(a, b))
            .collect();
        Mask::new(self.width, self.height, data)
    }
}

/// `(a − o) × (b − o)`: positive when `o → a → b` turns counter-clockwise (x right, y up).
fn cross(o: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
}

/// Andrew's monotone chain: the convex hull's vertices, counter-clockwise, without collinear or
/// repeated points. Fewer than 3 vertices means the points span no area.
fn convex_hull(points: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let mut pts: Vec<[f64; 2]> = points
        .iter()
        .filter(|p| p[0].is_finite() && p[1].is_finite())
        // `+ 0.0` turns -0.0 into 0.0, so equal points sort together and dedup.
        .map(|p| [p[0] + 0.0, p[1] + 0.0])
        .collect();
    pts.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    pts.dedup();
    if pts.len() < 3 {
        return pts;
    }
    let mut hull: Vec<[f64; 2]> = Vec::with_capacity(2 * pts.len());
    // Lower hull, left to right.
    for &p in &pts {
        while hull.len() >= 2 && cross(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0 {
            hull.pop();
        }
        hull.push(p);
    }
    // Upper hull, right to left, never popping into the lower hull.
    let lower_len = hull.len() + 1;
    for &p in pts.iter().rev().skip(1) {
        while hull.len() >= lower_len && cross(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0
        {
            hull.pop();
        }
        hull.push(p);
    }
    // The last point repeats the first.
    hull.pop();
    hull
}

/// Crops the box `[x0, y0, x1, y1)` (f64 pixel coordinates; it may extend past the image, and
/// pixels outside read as 0) of a row-major RGB image `[height * width * 3]` and resizes it
/// bilinearly to `out_w × out_h`, returning `[out_h * out_w * 3]`.
///
/// Output pixel `(i, j)` samples the source at `x = x0 + (i + 0.5) · (x1 − x0) / out_w − 0.5`
/// (and likewise `y`), in the convention that pixel centres sit at integer coordinates, so the
/// crop `[0, 0, width, height]` at the same size reproduces the image exactly. A crop of zero
/// (or negative, or non-finite) area returns all zeros.
///
/// # Panics
/// When `image.len() != width * height * 3`.
pub fn crop_resize(
    image: &[f32],
    width: usize,
    height: usize,
    crop: [f64; 4],
    out_w: usize,
    out_h: usize,
) -> Vec<f32> {
    assert_eq!(
        image.len(),
        width * height * 3,
        "crop_resize: image has {} values, expected width {width} × height {height} × 3",
        image.len()
    );
    let mut out = vec![0.0f32; out_w * out_h * 3];
    let [x0, y0, x1, y1] = crop;
    if !crop.iter().all(|v| v.is_finite()) || x1 <= x0 || y1 <= y0 {
        return out;
    }
    let texel = |x: i64, y: i64, c: usize| -> f32 {
        if x < 0 || y < 0 || x >= width as i64 || y >= height as i64 {
            0.0
        } else {
            image[(y as usize * width + x as usize) * 3 + c]
        }
    };
    for j in 0..out_h {
        let sy = y0 + (j as f64 + 0.5) * (y1 - y0) / out_h as f64 - 0.5;
        let fy = sy.floor();
        let ty = (sy - fy) as f32;
        let yi = fy as i64;
        for i in 0..out_w {
            let sx = x0 + (i as f64 + 0.5) * (x1 - x0) / out_w as f64 - 0.5;
            let fx = sx.floor();
            let tx = (sx - fx) as f32;
            let xi = fx as i64;
            for c in 0..3 {
                let v = (1.0 - tx) * (1.0 - ty) * texel(xi, yi, c)
                    + tx * (1.0 - ty) * texel(xi.saturating_add(1), yi, c)
                    + (1.0 - tx) * ty * texel(xi, yi.saturating_add(1), c)
                    + tx * ty * texel(xi.saturating_add(1), yi.saturating_add(1), c);
                out[(j * out_w + i) * 3 + c] = v;
            }
        }
    }
    out
}

/// The box `[x0, y0, x1, y1]` (as from [`Mask::bounding_box`]) grown by `margin` times its width
/// (left and right) and height (top and bottom) on each side, as f64 pixel coordinates (for
/// [`crop_resize`]).
pub fn grow_box(b: [usize; 4], margin: f64) -> [f64; 4] {
    let [x0, y0, x1, y1] = b.map(|v| v as f64);
    let (dx, dy) = (margin * (x1 - x0), margin * (y1 - y0));
    [x0 - dx, y0 - dy, x1 + dx, y1 + dy]
}
