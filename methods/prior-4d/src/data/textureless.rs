//! The textureless wall of spec §7: plainly painted panels over the part of the room's walls
//! the fixed evaluation camera looks at, behind the person. Photometric reconstruction has
//! nothing to lock onto there (the paper's floaters in its scene (c)); the scene prior's depth
//! and normal terms are what hold it flat.

use glam::DVec3;
use splatzoo_datasets::synth::environment::{Environment, Prop, plain_panel};
use splatzoo_rasterizer::Camera;

/// How far the panels reach along each wall from where the evaluation camera's optical axis
/// meets it (metres, each way), their height and the height of their lower edge, and how far
/// they stand in front of the wall.
pub const PANEL_REACH: f64 = 3.0;
pub const PANEL_HEIGHT: f64 = 1.9;
pub const PANEL_BOTTOM: f64 = 0.4;
pub const PANEL_GAP: f64 = 0.01;

/// Their paint: a warm off-white, lighter than most wallpapers.
const PAINT: [f32; 3] = [0.72, 0.68, 0.6];

/// Plain panels on the wall `camera`'s optical axis meets (seen from above) — on both walls
/// when it meets them within [`PANEL_REACH`] of a corner — each reaching [`PANEL_REACH`] either
/// way from there along its wall and clipped to it; empty when the room has no walls prop or
/// the camera looks straight up or down. Each faces the room as its wall does (the walls'
/// corner walk of [`splatzoo_datasets::synth::environment::room`]).
pub fn textureless_panels(environment: &Environment, camera: &Camera) -> Vec<Prop> {
    let Some(walls) = environment.props.iter().find(|p| p.name == "walls") else {
        return Vec::new();
    };
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for p in &walls.mesh.positions {
        let p = DVec3::from(p.map(f64::from));
        lo = lo.min(p);
        hi = hi.max(p);
    }
    let centre = DVec3::from(camera.position().map(f64::from));
    // The optical axis in the world: the third row of the world-to-camera rotation.
    let m = camera.world_to_camera;
    let axis = DVec3::new(f64::from(m[2][0]), f64::from(m[2][1]), f64::from(m[2][2]));
    let flat = DVec3::new(axis.x, 0.0, axis.z);
    if flat.length() < 1e-6 {
        return Vec::new();
    }
    let d = flat.normalize();
    // Where the axis leaves the room's floor plan: the nearest wall plane ahead.
    let exit = [
        (lo.x, d.x, centre.x),
        (hi.x, d.x, centre.x),
        (lo.z, d.z, centre.z),
        (hi.z, d.z, centre.z),
    ]
    .into_iter()
    .filter(|&(_, dk, _)| dk.abs() > 1e-9)
    .map(|(plane, dk, c)| (plane - c) / dk)
    .filter(|&t| t > 0.0)
    .fold(f64::INFINITY, f64::min);
    if !exit.is_finite() {
        return Vec::new();
    }
    let hit = centre + d * exit;
    let up = DVec3::Y * PANEL_HEIGHT.min(hi.y - PANEL_BOTTOM);
    let span = |c: f64, a: f64, b: f64| ((c - PANEL_REACH).max(a), (c + PANEL_REACH).min(b));
    let mut panels = Vec::new();
    // Walls z = lo.z (walked along +x), x = hi.x (+z), z = hi.z (−x), x = lo.x (−z).
    if (hit.z - lo.z).abs() < PANEL_REACH {
        let (a, b) = span(hit.x, lo.x, hi.x);
        panels.push((
            DVec3::new(a, PANEL_BOTTOM, lo.z + PANEL_GAP),
            DVec3::X * (b - a),
        ));
    }
    if (hit.x - hi.x).abs() < PANEL_REACH {
        let (a, b) = span(hit.z, lo.z, hi.z);
        panels.push((
            DVec3::new(hi.x - PANEL_GAP, PANEL_BOTTOM, a),
            DVec3::Z * (b - a),
        ));
    }
    if (hit.z - hi.z).abs() < PANEL_REACH {
        let (a, b) = span(hit.x, lo.x, hi.x);
        panels.push((
            DVec3::new(b, PANEL_BOTTOM, hi.z - PANEL_GAP),
            DVec3::X * (a - b),
        ));
    }
    if (hit.x - lo.x).abs() < PANEL_REACH {
        let (a, b) = span(hit.z, lo.z, hi.z);
        panels.push((
            DVec3::new(lo.x + PANEL_GAP, PANEL_BOTTOM, b),
            DVec3::Z * (a - b),
        ));
    }
    panels
        .into_iter()
        .map(|(origin, u)| plain_panel(origin, u, up, PAINT))
        .collect()
}
