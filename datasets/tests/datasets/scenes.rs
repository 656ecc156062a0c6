//! Synthetic scenes: determinism from a seed, every preset framing its people, masks consistent
//! with depth, normals agreeing with normals from depth finite differences, accessories rigid on
//! their joints (a swinging one rigid about its grip) and clear of the ground.

use burn::tensor::Device;
use splatzoo_datasets::synth::accessory::AccessoryKind;
use splatzoo_datasets::synth::scene::{STATIC_LABEL, accessory_label, body_label};
use splatzoo_datasets::synth::{Preset, Scene, SceneConfig};

fn small(preset: Preset, seed: u64, size: (u32, u32), frames: usize) -> Scene {
    SceneConfig {
        width: size.0,
        height: size.1,
        frames: Some(frames),
        supersample: 1,
        shadow_resolution: Some(512),
        ..SceneConfig::new(preset, seed)
    }
    .build(&Device::flex())
}

#[test]
fn scenes_are_deterministic_from_the_seed_and_differ_between_seeds() {
    let a = small(Preset::Driving, 3, (96, 54), 2).render_view(1, 0, true);
    let b = small(Preset::Driving, 3, (96, 54), 2).render_view(1, 0, true);
    assert_eq!(a.render.color, b.render.color);
    assert_eq!(a.render.depth, b.render.depth);
    assert_eq!(a.render.label, b.render.label);
    assert_eq!(a.camera, b.camera);
    let c = small(Preset::Driving, 4, (96, 54), 2).render_view(1, 0, true);
    let differing = a
        .render
        .color
        .iter()
        .zip(&c.render.color)
        .filter(|(p, q)| p != q)
        .count();
    assert!(
        differing > 96 * 54 / 10,
        "seeds 3 and 4 differ in only {differing} pixels"
    );
}

#[test]
fn the_driving_scene_shows_every_crossing_pedestrian_and_accessory() {
    let scene = small(Preset::Driving, 0, (192, 108), 12);
    assert_eq!(scene.people.len(), 5);
    assert_eq!(scene.tracks.len(), 3);
    let carried: usize = scene.people.iter().map(|p| p.accessories.len()).sum();
    assert_eq!(carried, 3);
    let mut seen = std::collections::BTreeMap::<u8, usize>::new();
    for frame in [0, 11] {
        for view in scene.render_frame(frame) {
            for &l in &view.render.label {
                *seen.entry(l).or_default() += 1;
            }
        }
    }
    for k in 0..3 {
        assert!(
            seen.get(&body_label(k)).copied().unwrap_or(0) > 20,
            "pedestrian {k} barely visible: {seen:?}"
        );
        assert!(
            seen.get(&accessory_label(k)).copied().unwrap_or(0) > 3,
            "accessory of pedestrian {k} not visible: {seen:?}"
        );
    }
    assert!(seen[&STATIC_LABEL] > 192 * 108, "street missing");
}

/// Pixels showing the surroundings have exactly the depth of the surroundings rendered alone;
/// people and accessories are never behind them; the background has no depth.
#[test]
fn masks_are_consistent_with_depth() {
    let scene = small(Preset::Driving, 1, (192, 108), 20);
    let mut checked = [0usize; 2];
    for track in 0..scene.tracks.len() {
        let full = scene.render_view(19, track, true);
        let alone = scene.render_view(19, track, false);
        let coarse = full.coarse_mask();
        let human = full.human_mask();
        let accessory = full.accessory_mask();
        for i in 0..coarse.len() {
            let (d, d0) = (full.render.depth[i], alone.render.depth[i]);
            assert_eq!(coarse[i], human[i] || accessory[i]);
            assert!(!(human[i] && accessory[i]));
            assert_eq!(d.is_finite(), full.render.label[i] != 0, "pixel {i}");
            if coarse[i] {
                assert!(d <= d0 * (1.0 + 1e-6), "person behind the street at {i}");
                checked[1] += 1;
            } else {
                assert_eq!(full.render.label[i], alone.render.label[i]);
                if d.is_finite() {
                    assert!((d - d0).abs() <= 1e-5 * d0, "pixel {i}: {d} vs {d0}");
                }
                checked[0] += 1;
            }
        }
    }
    assert!(checked[1] > 100, "only {} person pixels", checked[1]);
}

fn angle_degrees(a: [f64; 3], b: [f64; 3]) -> f64 {
    let dot: f64 = (0..3).map(|k| a[k] * b[k]).sum();
    let na = (0..3).map(|k| a[k] * a[k]).sum::<f64>().sqrt();
    let nb = (0..3).map(|k| b[k] * b[k]).sum::<f64>().sqrt();
    (dot / (na * nb)).clamp(-1.0, 1.0).acos().to_degrees()
}

fn percentile(mut v: Vec<f64>, q: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * q) as usize]
}

/// Back-projects the depth map (one sample per pixel, at the pixel centre), takes normals from
/// central differences, and compares them with the rendered world normals rotated into the
/// camera, on pixels whose 4 neighbours lie on the same object and surface.
#[test]
fn normals_agree_with_normals_from_depth_finite_differences() {
    let scene = small(Preset::Static, 2, (160, 160), 1);
    let mut errors = [Vec::new(), Vec::new()];
    for track in [0, 20, 40] {
        let view = scene.render_view(0, track, true);
        let (w, h) = (view.render.width, view.render.height);
        let cam = view.camera;
        let r = cam.world_to_camera.map(|row| row.map(f64::from));
        let point = |x: usize, y: usize| {
            let d = view.render.depth[y * w + x] as f64;
            [
                d * (x as f64 + 0.5 - cam.cx as f64) / cam.fx as f64,
                d * (y as f64 + 0.5 - cam.cy as f64) / cam.fy as f64,
                d,
            ]
        };
        for y in 1..h - 1 {
            for x in 1..w - 1 {
                let i = y * w + x;
                let label = view.render.label[i];
                let around = [i - 1, i + 1, i - w, i + w];
                if label == 0 || around.iter().any(|&j| view.render.label[j] != label) {
                    continue;
                }
                let (px, qx) = (point(x - 1, y), point(x + 1, y));
                let (py, qy) = (point(x, y - 1), point(x, y + 1));
                let du: [f64; 3] = std::array::from_fn(|k| qx[k] - px[k]);
                let dv: [f64; 3] = std::array::from_fn(|k| qy[k] - py[k]);
                // Skip depth discontinuities (occlusion edges within one object).
                let d = view.render.depth[i] as f64;
                let step = 2.0 * d / cam.fx as f64;
                if du[2].abs() > 20.0 * step || dv[2].abs() > 20.0 * step {
                    continue;
                }
                let estimated = [
                    du[1] * dv[2] - du[2] * dv[1],
                    du[2] * dv[0] - du[0] * dv[2],
                    du[0] * dv[1] - du[1] * dv[0],
                ];
                let n = view.render.normal[i].map(f64::from);
                let rendered: [f64; 3] =
                    std::array::from_fn(|k| (0..3).map(|c| r[k][c] * n[c]).sum());
                // The rendered normal faces the camera; the estimate's sign follows pixel order.
                let a = angle_degrees(estimated, rendered);
                let class = usize::from(label != STATIC_LABEL);
                errors[class].push(a.min(180.0 - a));
                // Facing the camera: the normal points back along the viewing ray.
                let ray = point(x, y);
                assert!(
                    (0..3).map(|k| ray[k] * rendered[k]).sum::<f64>() <= 1e-6,
                    "normal facing away at {i}"
                );
            }
        }
    }
    let [flat, body] = errors;
    assert!(
        flat.len() > 5000 && body.len() > 300,
        "{} {}",
        flat.len(),
        body.len()
    );
    let (flat_median, flat_p90) = (percentile(flat.clone(), 0.5), percentile(flat, 0.9));
    // The body's interpolated vertex normals depart from its facets, most at fingers and folds.
    let (body_median, body_p75) = (percentile(body.clone(), 0.5), percentile(body, 0.75));
    eprintln!(
        "flat: median {flat_median:.3}°, p90 {flat_p90:.3}°; body: median {body_median:.3}°, p75 {body_p75:.3}°"
    );
    assert!(
        flat_median < 0.05 && flat_p90 < 0.5,
        "flat {flat_median} {flat_p90}"
    );
    assert!(
        body_median < 4.0 && body_p75 < 10.0,
        "body {body_median} {body_p75}"
    );
}

#[test]
fn accessories_stay_rigid_on_their_joint_and_clear_of_the_ground() {
    let scene = small(Preset::Driving, 5, (32, 18), 40);
    for (k, person) in scene.people.iter().enumerate() {
        for (a, accessory) in person.accessories.iter().enumerate() {
            // A swinging accessory keeps its shape about its grip, a rigid one about its joint.
            let distances = |f: usize| -> Vec<f32> {
                let joint = match accessory.swing {
                    Some(_) => scene.accessory_grip(k, a, f),
                    None => person.frames[f].joints[accessory.joint],
                };
                scene
                    .accessory_vertices(k, a, f)
                    .iter()
                    .map(|p| {
                        (0..3)
                            .map(|c| (p[c] - joint[c]).powi(2))
                            .sum::<f32>()
                            .sqrt()
                    })
                    .collect()
            };
            let first = distances(0);
            let lowest_hand = (0..scene.frame_count)
                .map(|f| person.frames[f].joints[accessory.joint][1])
                .fold(f32::INFINITY, f32::min);
            for f in 1..scene.frame_count {
                for (d0, d) in first.iter().zip(distances(f)) {
                    assert!((d0 - d).abs() < 1e-4, "{:?} not rigid", accessory.kind);
                }
                let lowest = scene
                    .accessory_vertices(k, a, f)
                    .iter()
                    .map(|p| p[1])
                    .fold(f32::INFINITY, f32::min);
                assert!(
                    lowest > 0.02,
                    "{:?} at y = {lowest} (hand down to {lowest_hand})",
                    accessory.kind
                );
            }
            // Within reach of its joint; a backpack behind the chest, a bag below the hand.
            let far = first.iter().copied().fold(0.0, f32::max);
            assert!(
                far < 0.75,
                "{:?} reaches {far} m from its joint",
                accessory.kind
            );
            for f in 0..scene.frame_count {
                let frame = &person.frames[f];
                let placed = scene.accessory_vertices(k, a, f);
                let centroid: [f32; 3] = std::array::from_fn(|c| {
                    placed.iter().map(|p| p[c]).sum::<f32>() / placed.len() as f32
                });
                let joint = frame.joints[accessory.joint];
                let offset: [f32; 3] = std::array::from_fn(|c| centroid[c] - joint[c]);
                if accessory.kind == AccessoryKind::Backpack {
                    // The chest's forward axis is the third column of its orientation.
                    let r = frame.joint_rotations[accessory.joint];
                    let ahead: f32 = (0..3).map(|c| offset[c] * r[c][2]).sum();
                    assert!(ahead < -0.1, "backpack {ahead} m in front of the chest");
                } else {
                    assert!(offset[1] < -0.1, "bag {} m below the wrist", -offset[1]);
                }
            }
        }
    }
}
