//! Projected 3-D boxes: a tracked person's world box (the stand-in for a driving dataset's
//! annotated box) projected into a camera and filled, which splits the dataset's merged
//! coarse mask into per-person masks (Eq. 3 is applied per instance).

use splatzoo_datasets::masks::Mask;
use splatzoo_rasterizer::Camera;
use splatzoo_train::avatar::project;

/// The axis-aligned world box of `points`, grown by `margin` metres.
pub fn world_box(points: impl Iterator<Item = [f32; 3]>, margin: f32) -> Option<[[f32; 3]; 2]> {
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    let mut any = false;
    for p in points {
        any = true;
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    any.then(|| [lo.map(|v| v - margin), hi.map(|v| v + margin)])
}

/// The filled projection of a world box (its corners in front of the camera).
pub fn box_mask(camera: &Camera, b: &[[f32; 3]; 2]) -> Mask {
    let (w, h) = (camera.width as usize, camera.height as usize);
    let corners: Vec<[f32; 3]> = (0..8)
        .map(|k| [b[k & 1][0], b[(k >> 1) & 1][1], b[(k >> 2) & 1][2]])
        .collect();
    // Corners behind (or at) the camera have no pixel; the rest bound the box's footprint.
    let corners: Vec<[f64; 2]> = project(camera, &corners)
        .into_iter()
        .filter(|&(_, _, z)| z > 0.05)
        .map(|(x, y, _)| [f64::from(x), f64::from(y)])
        .collect();
    Mask::fill_convex_polygon(w, h, &corners)
}
