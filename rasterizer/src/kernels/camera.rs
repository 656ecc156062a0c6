//! The camera and settings packed into one small `f32` buffer every kernel reads.

use crate::camera::RasterSettings;

pub const FX: usize = 0;
pub const FY: usize = 1;
pub const CX: usize = 2;
pub const CY: usize = 3;
pub const WIDTH: usize = 4;
pub const HEIGHT: usize = 5;
pub const NEAR: usize = 6;
pub const FAR: usize = 7;
/// Row-major world-to-camera rotation, 9 values.
pub const ROT: usize = 8;
pub const TRANS: usize = 17;
pub const POS: usize = 20;
pub const LIM_X_NEG: usize = 23;
pub const LIM_X_POS: usize = 24;
pub const LIM_Y_NEG: usize = 25;
pub const LIM_Y_POS: usize = 26;
pub const EPS2D: usize = 27;
pub const CLIP: usize = 28;
pub const LEN: usize = 29;

/// Packs `settings` in the layout above.
pub fn pack(settings: &RasterSettings) -> Vec<f32> {
    let cam = &settings.camera;
    let mut v = vec![0.0f32; LEN];
    v[FX] = cam.fx;
    v[FY] = cam.fy;
    v[CX] = cam.cx;
    v[CY] = cam.cy;
    v[WIDTH] = cam.width as f32;
    v[HEIGHT] = cam.height as f32;
    v[NEAR] = cam.near;
    v[FAR] = cam.far;
    for r in 0..3 {
        for c in 0..3 {
            v[ROT + 3 * r + c] = cam.world_to_camera[r][c];
        }
        v[TRANS + r] = cam.world_to_camera[r][3];
    }
    v[POS..POS + 3].copy_from_slice(&cam.position());
    let (w, h) = (cam.width as f64, cam.height as f64);
    let tan_x = 0.5 * w / cam.fx as f64;
    let tan_y = 0.5 * h / cam.fy as f64;
    v[LIM_X_NEG] = (cam.cx as f64 / cam.fx as f64 + 0.3 * tan_x) as f32;
    v[LIM_X_POS] = ((w - cam.cx as f64) / cam.fx as f64 + 0.3 * tan_x) as f32;
    v[LIM_Y_NEG] = (cam.cy as f64 / cam.fy as f64 + 0.3 * tan_y) as f32;
    v[LIM_Y_POS] = ((h - cam.cy as f64) / cam.fy as f64 + 0.3 * tan_y) as f32;
    v[EPS2D] = settings.eps2d;
    v[CLIP] = settings.clip_sigmas;
    v
}
