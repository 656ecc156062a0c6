//! Binary masks for APF-GS's decoupling: set operations' truth tables, dilation and erosion
//! against a brute-force disk (borders included), opening and closing, 8-connected components,
//! boxes and IoU, filled convex hulls of projected points, and bilinear crops.

use splatzoo_datasets::masks::{Mask, crop_resize, grow_box};

/// A mask drawn as text rows, `#` = set.
fn rows(r: &[&str]) -> Mask {
    let w = r[0].len();
    for row in r {
        assert_eq!(row.len(), w, "ragged test mask");
    }
    let data: Vec<bool> = r
        .iter()
        .flat_map(|row| row.bytes().map(|b| b == b'#'))
        .collect();
    Mask::new(w, r.len(), data)
}

fn pixel(w: usize, h: usize, x: usize, y: usize) -> Mask {
    let mut m = Mask::empty(w, h);
    m.data[y * w + x] = true;
    m
}

/// The rectangle `[x0, x1) × [y0, y1)`.
fn rect(w: usize, h: usize, x0: usize, y0: usize, x1: usize, y1: usize) -> Mask {
    let mut m = Mask::empty(w, h);
    for y in y0..y1 {
        for x in x0..x1 {
            m.data[y * w + x] = true;
        }
    }
    m
}

/// A reproducible speckled mask with about `percent` % of pixels set.
fn speckle(w: usize, h: usize, seed: u64, percent: u64) -> Mask {
    let mut s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15).wrapping_add(1);
    let data = (0..w * h)
        .map(|_| {
            s = s
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (s >> 33) % 100 < percent
        })
        .collect();
    Mask::new(w, h, data)
}

/// Whether `a ⊆ b`.
fn subset(a: &Mask, b: &Mask) -> bool {
    a.minus(b).area() == 0
}

/// Set pixels of the disk `dx² + dy² ≤ r²` around `(x, y)` that lie inside the mask: whether
/// any is set (`any = true`) or all are (`any = false`).
fn disk_test(m: &Mask, x: usize, y: usize, r: usize, any: bool) -> bool {
    let (w, h, r) = (m.width as i64, m.height as i64, r as i64);
    let (x, y) = (x as i64, y as i64);
    let mut inside = Vec::new();
    for dy in -r..=r {
        for dx in -r..=r {
            let (sx, sy) = (x + dx, y + dy);
            if dx * dx + dy * dy <= r * r && sx >= 0 && sy >= 0 && sx < w && sy < h {
                inside.push(m.get(sx as usize, sy as usize));
            }
        }
    }
    if any {
        inside.iter().any(|&v| v)
    } else {
        inside.iter().all(|&v| v)
    }
}

fn brute_morphology(m: &Mask, r: usize, dilate: bool) -> Mask {
    let mut out = Mask::empty(m.width, m.height);
    for y in 0..m.height {
        for x in 0..m.width {
            out.data[y * m.width + x] = disk_test(m, x, y, r, dilate);
        }
    }
    out
}

#[test]
#[should_panic(expected = "mask data has 5 values, expected width 2 × height 3 = 6")]
fn new_rejects_data_of_the_wrong_length() {
    Mask::new(2, 3, vec![false; 5]);
}

#[test]
#[should_panic(expected = "outside")]
fn get_rejects_pixels_outside() {
    Mask::empty(4, 3).get(4, 0);
}

#[test]
fn set_operations_follow_their_truth_tables() {
    let a = rows(&["##.."]);
    let b = rows(&["#.#."]);
    assert_eq!(a.and(&b), rows(&["#..."]));
    assert_eq!(a.or(&b), rows(&["###."]));
    assert_eq!(a.minus(&b), rows(&[".#.."]));
    assert_eq!(b.minus(&a), rows(&["..#."]));
    assert_eq!(a.area(), 2);
    assert_eq!(Mask::empty(4, 1).area(), 0);
}

#[test]
#[should_panic(expected = "sizes differ")]
fn set_operations_reject_different_sizes() {
    Mask::empty(3, 2).and(&Mask::empty(2, 3));
}

#[test]
fn dilating_a_pixel_gives_the_digital_disk() {
    assert_eq!(
        pixel(5, 5, 2, 2).dilate(2),
        rows(&["..#..", ".###.", "#####", ".###.", "..#.."])
    );
    let (w, h, c) = (21, 21, 10);
    let p = pixel(w, h, c, c);
    for r in 0..=6usize {
        let d = p.dilate(r);
        for y in 0..h {
            for x in 0..w {
                let (dx, dy) = (x.abs_diff(c), y.abs_diff(c));
                assert_eq!(
                    d.get(x, y),
                    dx * dx + dy * dy <= r * r,
                    "r {r} at ({x}, {y})"
                );
            }
        }
    }
    assert_eq!(p.dilate(0).area(), 1);
    assert_eq!(p.dilate(1).area(), 5);
    assert_eq!(p.dilate(2).area(), 13);
    assert_eq!(p.dilate(3).area(), 29);
}

#[test]
fn dilation_and_erosion_match_a_brute_force_disk() {
    for seed in 0..3 {
        let m = speckle(40, 30, seed, 15 + 30 * seed);
        for r in 0..=5 {
            assert_eq!(
                m.dilate(r),
                brute_morphology(&m, r, true),
                "dilate seed {seed} r {r}"
            );
            assert_eq!(
                m.erode(r),
                brute_morphology(&m, r, false),
                "erode seed {seed} r {r}"
            );
        }
    }
}

#[test]
fn dilation_clips_at_the_border_and_erosion_treats_the_outside_as_set() {
    // A corner pixel grows into a quarter disk.
    assert_eq!(pixel(10, 10, 0, 0).dilate(2).area(), 6);
    // A full mask survives erosion; a mask touching the border is eaten only from its inner edge.
    let full = rect(8, 6, 0, 0, 8, 6);
    assert_eq!(full.erode(3), full);
    assert_eq!(rect(10, 6, 0, 0, 5, 6).erode(2), rect(10, 6, 0, 0, 3, 6));
    // Degenerate sizes do not panic.
    assert_eq!(Mask::empty(0, 5).dilate(2), Mask::empty(0, 5));
    assert_eq!(Mask::empty(0, 0).erode(2), Mask::empty(0, 0));
}

#[test]
fn eroding_a_dilated_pixel_gives_the_pixel_back() {
    let p = pixel(21, 21, 10, 10);
    for r in 1..=4 {
        assert_eq!(p.dilate(r).erode(r), p, "radius {r}");
    }
}

#[test]
fn radius_zero_is_the_identity() {
    let m = speckle(17, 11, 7, 40);
    assert_eq!(m.dilate(0), m);
    assert_eq!(m.erode(0), m);
    assert_eq!(m.open(0), m);
    assert_eq!(m.close(0), m);
}

#[test]
fn morphology_is_ordered_and_opening_and_closing_are_idempotent() {
    for seed in 0..3 {
        let m = speckle(30, 20, seed, 30 + 20 * seed);
        for r in 1..=3 {
            assert!(subset(&m.erode(r), &m));
            assert!(subset(&m, &m.dilate(r)));
            let (open, close) = (m.open(r), m.close(r));
            assert!(subset(&open, &m), "seed {seed} r {r}");
            assert!(subset(&m, &close), "seed {seed} r {r}");
            assert_eq!(open.open(r), open, "seed {seed} r {r}");
            assert_eq!(close.close(r), close, "seed {seed} r {r}");
        }
    }
}

#[test]
fn opening_removes_specks_and_thin_lines_but_keeps_blobs() {
    let blob = pixel(20, 20, 12, 10).dilate(2);
    let speck = pixel(20, 20, 2, 2);
    let line = rect(20, 20, 2, 17, 12, 18);
    let m = blob.or(&speck).or(&line);
    assert_eq!(m.open(1), blob);
    // A square loses exactly its 4 corners to the radius-1 disk (the cross): no cross inside
    // the square covers a corner. Without its corners it is open.
    let square = rect(20, 20, 5, 5, 10, 10);
    let mut cut = square.clone();
    for (x, y) in [(5, 5), (9, 5), (5, 9), (9, 9)] {
        cut.data[y * 20 + x] = false;
    }
    assert_eq!(square.open(1), cut);
    assert_eq!(cut.open(1), cut);
    assert_eq!(cut.area(), 21);
}

#[test]
fn closing_fills_a_one_pixel_hole() {
    let square = rect(15, 15, 5, 5, 10, 10);
    let holed = square.minus(&pixel(15, 15, 7, 7));
    assert_eq!(holed.close(1), square);
}

#[test]
fn components_are_8_connected_in_raster_order() {
    let m = rows(&[
        "##......", //
        "##...#..", //
        "......#.", //
        "........", //
        "#.......",
    ]);
    assert_eq!(
        m.components(),
        vec![vec![0, 1, 8, 9], vec![13, 22], vec![32]]
    );
    // A U shape: the flood fill goes around it; pixels come back in raster order.
    let u = rows(&["#...#", "#...#", "#####"]);
    assert_eq!(u.components(), vec![vec![0, 4, 5, 9, 10, 11, 12, 13, 14]]);
    assert!(Mask::empty(4, 4).components().is_empty());
    assert!(Mask::empty(0, 0).components().is_empty());
}

#[test]
fn components_of_a_full_frame_need_no_recursion() {
    let (w, h) = (640, 360);
    let components = Mask::new(w, h, vec![true; w * h]).components();
    assert_eq!(components.len(), 1);
    assert_eq!(components[0], (0..w * h).collect::<Vec<_>>());
}

#[test]
fn dropping_small_components_keeps_exactly_the_big_ones() {
    let big = rect(20, 12, 2, 2, 6, 6);
    let small = rect(20, 12, 10, 2, 12, 4);
    let speck = pixel(20, 12, 15, 9);
    let m = big.or(&small).or(&speck);
    assert_eq!(m.drop_small_components(5), big);
    assert_eq!(m.drop_small_components(16), big);
    assert_eq!(m.drop_small_components(4), big.or(&small));
    assert_eq!(m.drop_small_components(17), Mask::empty(20, 12));
    assert_eq!(m.drop_small_components(0), m);
    assert_eq!(m.drop_small_components(1), m);
}

#[test]
fn bounding_boxes_are_tight_and_exclusive() {
    assert_eq!(Mask::empty(10, 8).bounding_box(), None);
    assert_eq!(pixel(10, 8, 3, 2).bounding_box(), Some([3, 2, 4, 3]));
    let m = rect(20, 12, 2, 2, 6, 6)
        .or(&rect(20, 12, 10, 2, 12, 4))
        .or(&pixel(20, 12, 15, 9));
    assert_eq!(m.bounding_box(), Some([2, 2, 16, 10]));
    assert_eq!(rect(5, 4, 0, 0, 5, 4).bounding_box(), Some([0, 0, 5, 4]));
}

#[test]
fn iou_of_known_shapes() {
    let a = rect(4, 2, 0, 0, 2, 2);
    let b = rect(4, 2, 1, 0, 3, 2);
    let c = rect(4, 2, 3, 0, 4, 2);
    assert_eq!(a.iou(&a), Some(1.0));
    assert_eq!(a.iou(&c), Some(0.0));
    assert!((a.iou(&b).unwrap() - 1.0 / 3.0).abs() < 1e-12);
    assert_eq!(a.iou(&b), b.iou(&a));
    let empty = Mask::empty(4, 2);
    assert_eq!(empty.iou(&empty), None);
    assert_eq!(empty.iou(&a), Some(0.0));
}

#[test]
fn a_filled_square_covers_the_pixels_whose_centres_it_contains() {
    let square = [[2.0, 1.0], [6.0, 1.0], [6.0, 5.0], [2.0, 5.0]];
    let m = Mask::fill_convex_polygon(10, 8, &square);
    assert_eq!(m, rect(10, 8, 2, 1, 6, 5));
    assert_eq!(m.area(), 16);
    // Order, repeats and interior points do not matter.
    let shuffled = [
        [6.0, 5.0],
        [2.0, 1.0],
        [4.0, 3.0],
        [2.0, 5.0],
        [6.0, 5.0],
        [6.0, 1.0],
        [2.0, 1.0],
        [3.0, 2.5],
    ];
    assert_eq!(Mask::fill_convex_polygon(10, 8, &shuffled), m);
    let reversed: Vec<[f64; 2]> = square.iter().rev().copied().collect();
    assert_eq!(Mask::fill_convex_polygon(10, 8, &reversed), m);
    // Non-finite points are ignored.
    let with_nan = [square[0], [f64::NAN, 3.0], square[1], square[2], square[3]];
    assert_eq!(Mask::fill_convex_polygon(10, 8, &with_nan), m);
}

#[test]
fn a_triangle_includes_centres_on_its_edges() {
    let m = Mask::fill_convex_polygon(6, 6, &[[0.0, 0.0], [4.0, 0.0], [0.0, 4.0]]);
    assert_eq!(
        m,
        rows(&["####..", "###...", "##....", "#.....", "......", "......"])
    );
}

#[test]
fn a_projected_box_fills_the_hull_of_its_corners() {
    // Seen head-on: the back face lies inside the front face, so the hull is the front face.
    let mut corners = vec![[1.0, 1.0], [7.0, 1.0], [7.0, 7.0], [1.0, 7.0]];
    corners.extend([[2.5, 2.5], [5.5, 2.5], [5.5, 5.5], [2.5, 5.5]]);
    assert_eq!(
        Mask::fill_convex_polygon(10, 10, &corners),
        rect(10, 10, 1, 1, 7, 7)
    );
    // Seen obliquely: the hull covers both faces and stays within their joint box.
    let front = [[1.0, 1.0], [5.0, 1.0], [5.0, 5.0], [1.0, 5.0]];
    let back = [[3.0, 2.0], [7.0, 2.0], [7.0, 6.0], [3.0, 6.0]];
    let all: Vec<[f64; 2]> = front.iter().chain(&back).copied().collect();
    let hull = Mask::fill_convex_polygon(10, 10, &all);
    assert!(subset(&Mask::fill_convex_polygon(10, 10, &front), &hull));
    assert!(subset(&Mask::fill_convex_polygon(10, 10, &back), &hull));
    assert_eq!(hull.bounding_box(), Some([1, 1, 7, 6]));
    // (6, 1) has its centre above the hull's edge from (5, 1) to (7, 2); (1, 5) is left of the
    // edge from (3, 6) to (1, 5).
    assert!(!hull.get(6, 1));
    assert!(!hull.get(1, 5));
    assert!(hull.get(5, 1));
}

#[test]
fn degenerate_polygons_fill_nothing() {
    let empty = Mask::empty(10, 10);
    assert_eq!(Mask::fill_convex_polygon(10, 10, &[]), empty);
    assert_eq!(
        Mask::fill_convex_polygon(10, 10, &[[1.0, 1.0], [5.0, 5.0]]),
        empty
    );
    let collinear = [[0.0, 0.0], [2.0, 2.0], [5.0, 5.0], [3.0, 3.0]];
    assert_eq!(Mask::fill_convex_polygon(10, 10, &collinear), empty);
    assert_eq!(Mask::fill_convex_polygon(10, 10, &[[3.0, 3.0]; 5]), empty);
    let square = [[2.0, 1.0], [6.0, 1.0], [6.0, 5.0], [2.0, 5.0]];
    assert_eq!(Mask::fill_convex_polygon(0, 0, &square), Mask::empty(0, 0));
}

#[test]
fn polygons_past_the_image_are_clipped() {
    let partly = [[-5.0, -5.0], [3.0, -5.0], [3.0, 3.0], [-5.0, 3.0]];
    assert_eq!(
        Mask::fill_convex_polygon(10, 10, &partly),
        rect(10, 10, 0, 0, 3, 3)
    );
    let outside = [[20.0, 20.0], [30.0, 20.0], [30.0, 30.0], [20.0, 30.0]];
    assert_eq!(
        Mask::fill_convex_polygon(10, 10, &outside),
        Mask::empty(10, 10)
    );
    let huge = [[-1e12, -1e12], [1e12, -1e12], [1e12, 1e12], [-1e12, 1e12]];
    assert_eq!(Mask::fill_convex_polygon(10, 10, &huge).area(), 100);
}

#[test]
fn decoupling_cleanup_removes_the_misaligned_prior_sliver() {
    // Eq. 3 on a toy instance: a body with a bag on its right; the prior is off by one pixel.
    let (w, h) = (40, 40);
    let body = rect(w, h, 10, 5, 20, 35);
    let bag = rect(w, h, 20, 15, 26, 22);
    let coarse = body.or(&bag);
    let kine = rect(w, h, 11, 5, 21, 35);
    let literal = coarse.minus(&kine);
    assert_eq!(
        literal.minus(&bag).area(),
        30,
        "the literal Eq. 3 keeps a sliver"
    );
    let kine = kine.and(&coarse);
    let cleaned = coarse
        .minus(&kine.dilate(2))
        .open(1)
        .drop_small_components(5);
    assert!(cleaned.area() > 0);
    assert!(subset(&cleaned, &bag));
    assert_eq!(cleaned.components().len(), 1);
}

/// A row-major RGB test image with distinct values.
fn ramp(w: usize, h: usize) -> Vec<f32> {
    (0..w * h * 3).map(|i| i as f32 * 0.25 - 3.0).collect()
}

#[test]
fn an_identity_crop_reproduces_the_image() {
    let (w, h) = (7, 5);
    let image = ramp(w, h);
    let out = crop_resize(&image, w, h, [0.0, 0.0, w as f64, h as f64], w, h);
    assert_eq!(out, image);
}

#[test]
fn a_crop_of_a_constant_image_is_constant() {
    let (w, h) = (8, 6);
    let colour = [0.2f32, 0.5, 0.9];
    let image: Vec<f32> = (0..w * h).flat_map(|_| colour).collect();
    for (crop, ow, oh) in [
        ([1.0, 1.0, 5.0, 4.0], 7, 5),
        ([0.5, 0.5, 7.5, 5.5], 3, 2),
        ([2.25, 1.75, 3.5, 2.5], 16, 9),
    ] {
        let out = crop_resize(&image, w, h, crop, ow, oh);
        assert_eq!(out.len(), ow * oh * 3);
        for (i, v) in out.iter().enumerate() {
            assert!((v - colour[i % 3]).abs() < 1e-6, "{crop:?}: {i} = {v}");
        }
    }
}

#[test]
fn halving_a_crop_averages_two_by_two_blocks() {
    let (w, h) = (4, 4);
    let image = ramp(w, h);
    let out = crop_resize(&image, w, h, [0.0, 0.0, 4.0, 4.0], 2, 2);
    let at = |x: usize, y: usize, c: usize| image[(y * w + x) * 3 + c];
    for j in 0..2 {
        for i in 0..2 {
            for c in 0..3 {
                let (x, y) = (2 * i, 2 * j);
                let mean =
                    (at(x, y, c) + at(x + 1, y, c) + at(x, y + 1, c) + at(x + 1, y + 1, c)) / 4.0;
                assert!((out[(j * 2 + i) * 3 + c] - mean).abs() < 1e-6);
            }
        }
    }
}

#[test]
fn crop_pixels_outside_the_image_read_as_zero() {
    let (w, h) = (8, 5);
    let image = vec![1.0f32; w * h * 3];
    // Shifted left by half the image: samples land exactly on pixel centres x = i - 4.
    let out = crop_resize(&image, w, h, [-4.0, 0.0, 4.0, 5.0], 8, 5);
    for j in 0..5 {
        for i in 0..8 {
            let want: f32 = if i < 4 { 0.0 } else { 1.0 };
            assert_eq!(&out[(j * 8 + i) * 3..(j * 8 + i + 1) * 3], &[want; 3]);
        }
    }
    let far = crop_resize(&image, w, h, [100.0, 100.0, 110.0, 110.0], 3, 3);
    assert_eq!(far, vec![0.0f32; 27]);
}

#[test]
fn zero_area_crops_are_zeros() {
    let (w, h) = (6, 4);
    let image = ramp(w, h);
    for crop in [
        [2.0, 2.0, 2.0, 5.0],
        [1.0, 3.0, 4.0, 3.0],
        [5.0, 1.0, 2.0, 4.0],
        [f64::NAN, 0.0, 3.0, 3.0],
        [0.0, 0.0, f64::INFINITY, 3.0],
    ] {
        let out = crop_resize(&image, w, h, crop, 4, 3);
        assert_eq!(out, vec![0.0f32; 36], "{crop:?}");
    }
    assert!(crop_resize(&image, w, h, [0.0, 0.0, 6.0, 4.0], 0, 3).is_empty());
}

#[test]
fn grown_boxes_add_the_margin_on_each_side() {
    assert_eq!(grow_box([10, 20, 30, 60], 0.0), [10.0, 20.0, 30.0, 60.0]);
    let grown = grow_box([10, 20, 30, 60], 0.1);
    for (g, want) in grown.iter().zip([8.0, 16.0, 32.0, 64.0]) {
        assert!((g - want).abs() < 1e-12, "{grown:?}");
    }
}
