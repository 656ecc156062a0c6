//! The driving preset as APF-GS measures against it: 60 frames and one untracked passer-by
//! (exported without pose files), a prior corrupted only inside its window, clothing relief on
//! the rendered bodies only, a handbag swinging about its grip beside rigid accessories, a
//! LiDAR stand-in on beam rows, coarse-mask variants, and crossing walkers tall on screen.

use burn::tensor::Device;
use glam::{DQuat, DVec3};
use splatzoo_datasets::posing::PosedFrame;
use splatzoo_datasets::synth::accessory::AccessoryKind;
use splatzoo_datasets::synth::clothing;
use splatzoo_datasets::synth::export::write_scene;
use splatzoo_datasets::synth::prior::PriorCorruption;
use splatzoo_datasets::synth::scene::body_label;
use splatzoo_datasets::synth::sensors::{LIDAR_NOISE, LIDAR_ROWS};
use splatzoo_datasets::synth::{Preset, Scene, SceneConfig, ViewTruth};
use std::sync::OnceLock;

/// The default driving scene (seed 0), without anti-aliasing and shadows to render quickly.
fn driving() -> &'static Scene {
    static SCENE: OnceLock<Scene> = OnceLock::new();
    SCENE.get_or_init(|| {
        SceneConfig {
            supersample: 1,
            shadow_resolution: None,
            ..SceneConfig::new(Preset::Driving, 0)
        }
        .build(&Device::flex())
    })
}

fn distance(p: [f32; 3], q: [f32; 3]) -> f32 {
    (0..3).map(|c| (p[c] - q[c]).powi(2)).sum::<f32>().sqrt()
}

/// Angle (radians) between the local rotations of joint `j` in two poses.
fn joint_angle(a: &[f64], b: &[f64], j: usize) -> f64 {
    let q = |p: &[f64]| DQuat::from_scaled_axis(DVec3::from_slice(&p[3 * j..3 * j + 3]));
    q(a).angle_between(q(b))
}

/// World point `p` in the frame of joint `j`.
fn in_joint_frame(frame: &PosedFrame, j: usize, p: [f32; 3]) -> [f32; 3] {
    let (r, o) = (frame.joint_rotations[j], frame.joints[j]);
    std::array::from_fn(|c| (0..3).map(|row| r[row][c] * (p[row] - o[row])).sum())
}

/// Pixel rows spanned by `label` in a view (0 when absent).
fn rows_spanned(view: &ViewTruth, label: u8) -> usize {
    let w = view.render.width;
    let rows = view
        .render
        .label
        .iter()
        .enumerate()
        .filter(|&(_, &l)| l == label)
        .map(|(i, _)| i / w);
    let (top, bottom) = rows.fold((usize::MAX, 0), |(t, b), y| (t.min(y), b.max(y + 1)));
    bottom.saturating_sub(top)
}

fn area(mask: &[bool]) -> usize {
    mask.iter().filter(|&&m| m).count()
}

#[test]
fn sixty_frames_and_one_untracked_passer_by_without_pose_files() {
    let scene = driving();
    assert_eq!(scene.frame_count, 60);
    assert!(scene.tracks.iter().all(|t| t.cameras.len() == 60));
    let untracked: Vec<usize> = (0..scene.people.len())
        .filter(|&k| !scene.people[k].tracked)
        .collect();
    assert_eq!(untracked, [4]);
    assert!(scene.people[4].accessories.is_empty());
    // The sidewalk walker carrying nothing is tracked.
    assert!(scene.people[3].tracked && scene.people[3].accessories.is_empty());
    assert!(scene.people.iter().all(|p| p.clothed));
    assert_eq!(scene.corruption, Some(PriorCorruption::driving()));
    for preset in [Preset::Multiview, Preset::Monocular, Preset::Static] {
        let config = SceneConfig::new(preset, 0);
        assert!(
            config.corruption.is_none() && !config.clothing_relief,
            "{preset:?}"
        );
    }
    let dir = tempfile::tempdir().unwrap();
    write_scene(scene, dir.path(), &[0], |_| {}).unwrap();
    let people = dir.path().join("people");
    for k in 0..5 {
        for which in ["truth", "prior"] {
            let file = people.join(format!("person_{k:02}_{which}.npz"));
            assert_eq!(file.is_file(), k != 4, "{}", file.display());
        }
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("scene.json")).unwrap())
            .unwrap();
    assert_eq!(json["people"][4]["tracked"], false);
    assert!(json["people"][4]["prior"].is_null());
    assert_eq!(json["prior_corruption"]["last_frame"], 22);
}

#[test]
fn the_prior_is_corrupted_inside_its_window_only() {
    let build = |corruption: Option<PriorCorruption>| {
        SceneConfig {
            width: 32,
            height: 18,
            frames: Some(30),
            supersample: 1,
            shadow_resolution: None,
            corruption,
            ..SceneConfig::new(Preset::Driving, 2)
        }
        .build(&Device::flex())
    };
    let window = PriorCorruption::driving();
    let (corrupted, clean) = (build(Some(window.clone())), build(None));
    for (a, b) in corrupted.people.iter().zip(&clean.people) {
        assert_eq!(a.motion, b.motion);
        assert_eq!(
            (&a.prior.translations, &a.prior.betas),
            (&b.prior.translations, &b.prior.betas)
        );
        for t in 0..corrupted.frame_count {
            let (p, q) = (a.prior.pose(t), b.prior.pose(t));
            for j in 0..24 {
                if a.tracked && window.contains(t) && window.joints.contains(&j) {
                    let turned = joint_angle(p, q, j);
                    assert!(
                        (turned - window.bias).abs() < 1e-6,
                        "frame {t} joint {j} turned by {turned}"
                    );
                } else {
                    assert_eq!(
                        p[3 * j..3 * j + 3],
                        q[3 * j..3 * j + 3],
                        "frame {t} joint {j}"
                    );
                }
            }
        }
    }
    // Against the truth: the error injected per frame stands out inside the window.
    let scene = driving();
    let mut excess = Vec::new();
    for (k, person) in scene.people.iter().enumerate() {
        let error = scene.prior_joint_error(k);
        assert_eq!(error.len(), scene.frame_count);
        let mean = |inside: bool| {
            let picked: Vec<f64> = (0..scene.frame_count)
                .filter(|&t| window.contains(t) == inside)
                .map(|t| error[t])
                .collect();
            picked.iter().sum::<f64>() / picked.len() as f64
        };
        let (inside, outside) = (mean(true), mean(false));
        eprintln!("person {k}: mean joint error {inside:.3} inside, {outside:.3} outside");
        if person.tracked {
            excess.push(inside - outside);
        } else {
            assert!((inside - outside).abs() < 0.02, "untracked prior corrupted");
        }
        // The corrupted joints alone: about the bias above the noise.
        let chain = |inside: bool| {
            let angles: Vec<f64> = (0..scene.frame_count)
                .filter(|&t| window.contains(t) == inside)
                .flat_map(|t| {
                    let (truth, prior) = (person.motion.pose(t), person.prior.pose(t));
                    window
                        .joints
                        .iter()
                        .map(move |&j| joint_angle(truth, prior, j))
                })
                .collect();
            angles.iter().sum::<f64>() / angles.len() as f64
        };
        if person.tracked {
            let (inside, outside) = (chain(true), chain(false));
            assert!(
                inside > outside + 0.15,
                "person {k}: chain error {inside} inside vs {outside} outside"
            );
        }
    }
    let mean_excess = excess.iter().sum::<f64>() / excess.len() as f64;
    assert!(mean_excess > 0.025, "window adds only {mean_excess} rad");
}

#[test]
fn clothing_relief_moves_the_driving_bodies_by_millimetres_and_nothing_else() {
    let scene = driving();
    for (k, person) in scene.people.iter().enumerate() {
        for f in [0, 59] {
            let plain = &person.frames[f].vertices;
            let dressed = scene.body_vertices(k, f);
            assert_eq!(dressed.len(), plain.len());
            let moved: Vec<f32> = plain
                .iter()
                .zip(&dressed)
                .map(|(&p, &q)| distance(p, q))
                .collect();
            let most = moved.iter().copied().fold(0.0, f32::max);
            let relieved = moved.iter().filter(|&&d| d > 0.003).count();
            assert!(
                most <= 0.02 && most > 0.003,
                "person {k} frame {f}: moved up to {most} m"
            );
            assert!(
                relieved * 50 > moved.len(),
                "person {k} frame {f}: only {relieved} vertices moved over 3 mm"
            );
        }
    }
    let deepest = clothing::relief()
        .iter()
        .fold(0.0f32, |m, d| m.max(d.abs()));
    assert!(
        deepest > 0.005 && deepest <= 0.0151,
        "relief up to {deepest} m"
    );
    let room = SceneConfig {
        width: 32,
        height: 24,
        frames: Some(2),
        supersample: 1,
        shadow_resolution: None,
        ..SceneConfig::new(Preset::Monocular, 0)
    }
    .build(&Device::flex());
    assert!(!room.people[0].clothed);
    assert_eq!(room.body_vertices(0, 1), room.people[0].frames[1].vertices);
}

#[test]
fn the_handbag_swings_about_its_grip_and_the_others_stay_rigid() {
    let scene = driving();
    // A quarter of the 1.2 s period apart: the swing at rest, then at its widest.
    let (f0, f1) = (0, 3);
    let mut kinds = Vec::new();
    for (k, person) in scene.people.iter().enumerate() {
        for (a, accessory) in person.accessories.iter().enumerate() {
            kinds.push(accessory.kind);
            let local = |f: usize| -> Vec<[f32; 3]> {
                scene
                    .accessory_vertices(k, a, f)
                    .into_iter()
                    .map(|p| in_joint_frame(&person.frames[f], accessory.joint, p))
                    .collect()
            };
            let moved = local(f0)
                .into_iter()
                .zip(local(f1))
                .map(|(p, q)| distance(p, q))
                .fold(0.0, f32::max);
            if accessory.kind == AccessoryKind::Handbag {
                let swing = accessory.swing.expect("the handbag swings");
                assert!((swing.amplitude.to_degrees() - 15.0).abs() < 1e-9);
                let widest = accessory.swing_angle(scene.time(f1));
                assert!((widest - swing.amplitude).abs() < 1e-9, "{widest}");
                assert!(moved > 0.03, "handbag moved {moved} m in its joint's frame");
                // About the grip: every vertex keeps its distance from it.
                let from_grip = |f: usize| -> Vec<f32> {
                    let grip = scene.accessory_grip(k, a, f);
                    scene
                        .accessory_vertices(k, a, f)
                        .into_iter()
                        .map(|p| distance(p, grip))
                        .collect()
                };
                let first = from_grip(f0);
                for f in [f1, 7, 40] {
                    for (d0, d) in first.iter().zip(from_grip(f)) {
                        assert!((d0 - d).abs() < 1e-4, "frame {f}: {d0} vs {d}");
                    }
                }
            } else {
                assert!(accessory.swing.is_none(), "{:?} swings", accessory.kind);
                assert!(moved < 1e-4, "{:?} moved {moved} m", accessory.kind);
            }
        }
    }
    assert_eq!(
        kinds,
        [
            AccessoryKind::Backpack,
            AccessoryKind::Suitcase,
            AccessoryKind::Handbag
        ]
    );
}

#[test]
fn lidar_depth_is_noisy_depth_on_beam_rows_and_nan_elsewhere() {
    let view = driving().render_view(10, 0, true);
    let (w, h) = (view.render.width, view.render.height);
    let rows = view.beam_rows(LIDAR_ROWS);
    assert_eq!(rows.len(), LIDAR_ROWS);
    assert!(rows.windows(2).all(|r| r[0] < r[1]) && rows[LIDAR_ROWS - 1] < h);
    let lidar = view.lidar_depth(LIDAR_ROWS, LIDAR_NOISE, 3);
    assert_eq!(lidar.len(), w * h);
    let (mut hits, mut squares) = (0usize, 0.0f64);
    for (i, (&l, &d)) in lidar.iter().zip(&view.render.depth).enumerate() {
        if rows.contains(&(i / w)) && d.is_finite() {
            assert!((l - d).abs() < 0.1, "pixel {i}: {l} vs {d}");
            hits += 1;
            squares += f64::from(l - d).powi(2);
        } else {
            assert!(l.is_nan(), "pixel {i} off the beams: {l}");
        }
    }
    assert!(hits > w * LIDAR_ROWS / 3, "{hits} returns");
    let rms = (squares / hits as f64).sqrt();
    assert!((rms - LIDAR_NOISE).abs() < 0.004, "noise {rms} m");
    let again = view.lidar_depth(LIDAR_ROWS, LIDAR_NOISE, 3);
    assert!(
        lidar
            .iter()
            .zip(&again)
            .all(|(a, b)| a.to_bits() == b.to_bits())
    );
}

#[test]
fn coarse_mask_variants_hold_the_exact_mask() {
    let view = driving().render_view(30, 0, true);
    let w = view.render.width;
    let exact = view.coarse_mask();
    let dilated = view.coarse_mask_dilated(3);
    let boxes = view.coarse_mask_boxes();
    assert!(area(&exact) > 200, "{} person pixels", area(&exact));
    for ((&e, &d), &b) in exact.iter().zip(&dilated).zip(&boxes) {
        assert!(!e || (d && b));
    }
    assert!(area(&dilated) > area(&exact) && area(&boxes) > area(&exact));
    let person_boxes = view.person_boxes();
    assert_eq!(person_boxes.len(), 5);
    for (i, who) in view.person().into_iter().enumerate() {
        if let Some(k) = who {
            let [x0, y0, x1, y1] = person_boxes[k].expect("a box around a visible person");
            let (x, y) = (i % w, i / w);
            assert!((x0..x1).contains(&x) && (y0..y1).contains(&y), "pixel {i}");
        }
    }
}

#[test]
fn crossing_walkers_stand_tall_and_the_passer_by_is_in_view() {
    let scene = driving();
    let frames = [30, 59];
    let views = frames.map(|f| scene.render_tracks(f, &[0, 1, 2], true));
    let tallest = |views: &Vec<ViewTruth>, k: usize| {
        views
            .iter()
            .map(|v| rows_spanned(v, body_label(k)))
            .max()
            .unwrap_or(0)
    };
    let heights: Vec<[usize; 3]> = views
        .iter()
        .map(|v| -> [usize; 3] { std::array::from_fn(|k| tallest(v, k)) })
        .collect();
    eprintln!("crossing walkers' tallest at frames {frames:?}: {heights:?} px");
    assert!(
        heights.iter().any(|h| h.iter().all(|&px| px >= 40)),
        "{heights:?}"
    );
    let passer_by = views
        .iter()
        .flatten()
        .map(|v| {
            v.render
                .label
                .iter()
                .filter(|&&l| l == body_label(4))
                .count()
        })
        .max()
        .unwrap_or(0);
    assert!(
        passer_by > 100,
        "passer-by shows {passer_by} pixels at most"
    );
}

/// The pose-dependent clothing: nothing in the rest pose; a bent knee bunches the trousers
/// around that knee only (15 mm at 90°, half at 45°); a stride flares the jacket hem; and a
/// dressed scene's bodies move by it on top of the static relief where the person wears it.
#[test]
fn pose_dependent_clothing_follows_the_knees_and_the_stride() {
    let body = splatzoo_models::body::builtin_body();
    let rest = vec![0.0; 72];
    assert!(clothing::pose_relief(&rest).iter().all(|&d| d == 0.0));
    let knee = |angle: f64| {
        let mut pose = rest.clone();
        pose[3 * 4] = angle; // the left knee bends about x
        clothing::pose_relief(&pose)
    };
    let (half, full, over) = (
        knee(0.25 * std::f64::consts::PI),
        knee(0.5 * std::f64::consts::PI),
        knee(2.0),
    );
    let most = |r: &[f32]| r.iter().fold(0.0f32, |m, &d| m.max(d));
    assert!((most(&full) - 0.015).abs() < 1e-3, "{}", most(&full));
    assert!((most(&half) - 0.5 * most(&full)).abs() < 1e-4);
    assert_eq!(most(&over), most(&full), "capped at full bend");
    for (v, &d) in full.iter().enumerate() {
        if d > 1e-4 {
            let part = body.part_of_vertex[v];
            let y = body.model.template[3 * v + 1];
            assert!([1, 4].contains(&part), "vertex {v} of bone {part} moved");
            assert!((y + 0.678).abs() < 0.15, "vertex {v} at height {y}");
        }
    }
    let mut stride = rest.clone();
    stride[3] = 0.4; // left hip forward
    stride[6] = -0.4; // right hip back
    let flare = clothing::pose_relief(&stride);
    let flared: Vec<usize> = (0..flare.len()).filter(|&v| flare[v] > 1e-3).collect();
    assert!(!flared.is_empty());
    assert!(
        flared
            .iter()
            .all(|&v| (body.model.template[3 * v + 1] + 0.15).abs() < 0.05)
    );
    assert!(most(&flare) > 0.01 && most(&flare) <= 0.0151);

    let mut scene = driving().clone();
    let k = 0;
    let frame = (0..scene.people[k].frames.len())
        .max_by(|&a, &b| {
            let bend = |f: usize| most(&clothing::pose_relief(scene.people[k].motion.pose(f)));
            bend(a).total_cmp(&bend(b))
        })
        .unwrap();
    let static_only = scene.body_vertices(k, frame);
    scene.people[k].pose_clothing = true;
    let moving = scene.body_vertices(k, frame);
    let extra = static_only
        .iter()
        .zip(&moving)
        .map(|(&p, &q)| distance(p, q))
        .fold(0.0f32, f32::max);
    let expected = most(&clothing::pose_relief(scene.people[k].motion.pose(frame)));
    assert!(
        expected > 0.005,
        "the walk bends a knee by only {expected} m of bunching"
    );
    assert!(
        (extra - expected).abs() < 1e-3,
        "moved {extra} m, expected {expected}"
    );
}
