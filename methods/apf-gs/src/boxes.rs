//! Projected 3-D boxes: a tracked person's world box (the stand-in for a driving dataset's
//! annotated box) projected into a camera and filled, which splits the dataset's merged
//! coarse mask into per-person masks (Eq. 3 is applied per instance).

use splatzoo_datasets::masks::Mask;
use splatzoo_rasterizer::Camera;

/// Camera-space position of a world point.
pub fn to_camera(camera: &Camera, p: [f32; 3]) -> [f32; 3] {
    let m = camera.world_to_camera;
    std::array::from_fn(|r| m[r][0] * p[0] + m[r][1] * p[1] + m[r][2] * p[2] + m[r][3])
}

/// Pixel coordinates (pixel centres at +0.5) of a camera-space point in front of the camera.
pub fn project(camera: &Camera, c: [f32; 3]) -> Option<[f64; 2]> {
    (c[2] > 0.05).then(|| {
        [
            (camera.fx * c[0] / c[2] + camera.cx) as f64,
            (camera.fy * c[1] / c[2] + camera.cy) as f64,
        ]
    })
}

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
    let corners: Vec<[f64; 2]> = (0..8)
        .filter_map(|k| {
            let p = [b[k & 1][0], b[(k >> 1) & 1][1], b[(k >> 2) & 1][2]];
            project(camera, to_camera(camera, p))
        })
        .collect();
    Mask::fill_convex_polygon(w, h, &corners)
}
