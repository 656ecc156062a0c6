//! The synthetic lighting capture at a tiny size: the split, the person in view, a cast shadow
//! the person-free view proves (GT ratio < 0.95 off the person), albedo within [0, 1] and
//! unlit by shading, light that varies across the room, relit frames that change the person,
//! novel poses that differ from the training ones, and bad sizes named.

use crate::values;
use burn::tensor::Device;
use splatzoo_illum::data::{IllumDataConfig, Room};

fn tiny() -> IllumDataConfig {
    IllumDataConfig {
        width: 48,
        height: 36,
        frames: 10,
        test_every: 5,
        novel_pose_frames: 3,
        supersample: 1,
        shadow_resolution: 128,
        scene_points: 2000,
        ..IllumDataConfig::default()
    }
}

#[test]
fn the_capture_holds_the_ground_truth_the_claims_need() {
    let device = Device::flex();
    let capture = tiny().build(&device).unwrap();
    assert_eq!(capture.frames.len(), 10);
    let held: Vec<usize> = capture.test_frames().map(|f| f.frame).collect();
    assert_eq!(held, vec![4, 9]);
    assert_eq!(capture.train_frames().count(), 8);
    let seen = capture
        .frames
        .iter()
        .filter(|f| f.person.iter().filter(|&&p| p).count() > 20)
        .count();
    assert!(seen >= 8, "the person is in view in {seen} of 10 frames");
    // The person casts a shadow somewhere: the empty room is brighter there.
    let shadowed: usize = capture
        .frames
        .iter()
        .map(|f| {
            f.shadow_ratio()
                .expect("the synthetic capture's truth")
                .iter()
                .filter(|r| r.is_some_and(|r| r < 0.95))
                .count()
        })
        .sum();
    assert!(shadowed > 5, "only {shadowed} shadowed pixels");
    // The albedo buffer is reflectance, not shaded colour.
    for f in &capture.frames {
        let truth = f.truth.as_ref().expect("the synthetic capture's truth");
        assert!(
            truth
                .albedo
                .iter()
                .flatten()
                .all(|&a| (0.0..=1.0).contains(&a))
        );
        let image = values(f.image.clone());
        assert!(
            image
                .iter()
                .all(|v| v.is_finite() && (0.0..=1.0).contains(v))
        );
    }
    let truth = capture
        .truth
        .as_ref()
        .expect("the synthetic capture's truth");
    // The light varies across the room: the probe radiance near the lamp is brighter.
    let near = truth.probe_truth([2.0, 1.2, 0.5])[0][0];
    let far = truth.probe_truth([-2.0, 1.2, -1.0])[0][0];
    assert!(near > 2.0 * far, "near {near} vs far {far}");
    // Two other lights on each held-out frame, changing the person's pixels.
    assert_eq!(truth.relit.len(), 4);
    for relit in &truth.relit {
        let original = capture
            .frames
            .iter()
            .find(|f| f.frame == relit.frame.frame)
            .unwrap();
        let (a, b) = (
            values(original.image.clone()),
            values(relit.frame.image.clone()),
        );
        let changed = original
            .person
            .iter()
            .enumerate()
            .filter(|(i, p)| **p && (0..3).any(|c| (a[i * 3 + c] - b[i * 3 + c]).abs() > 0.02))
            .count();
        assert!(
            changed > 10,
            "{}: {changed} person pixels changed",
            relit.light
        );
    }
    assert_eq!(truth.novel_pose.len(), 3);
    assert!(truth.novel_pose.iter().all(|f| f.person.iter().any(|&p| p)));
    assert!(capture.scene_points.len() > 100);
}

#[test]
fn bad_sizes_are_named() {
    let err = IllumDataConfig {
        frames: 1,
        ..tiny()
    }
    .build(&Device::flex())
    .unwrap_err()
    .to_string();
    assert!(err.contains("data.frames"), "{err}");
    let err = IllumDataConfig { width: 2, ..tiny() }
        .build(&Device::flex())
        .unwrap_err()
        .to_string();
    assert!(err.contains("data.width"), "{err}");
}

/// Room B: the same person (shape and motion) in another room under another light.
#[test]
fn room_b_films_the_same_person_elsewhere() {
    let device = Device::flex();
    let config = IllumDataConfig {
        frames: 5,
        novel_pose_frames: 1,
        ..tiny()
    };
    let a = config.build(&device).unwrap();
    let b = IllumDataConfig {
        room: Room::B,
        ..config
    }
    .build(&device)
    .unwrap();
    let (ta, tb) = (a.truth.as_ref().unwrap(), b.truth.as_ref().unwrap());
    let (pa, pb) = (&ta.scene.people[0], &tb.scene.people[0]);
    assert_eq!(pa.identity.betas, pb.identity.betas);
    assert_eq!(pa.motion.poses, pb.motion.poses);
    assert_ne!(ta.scene.lighting, tb.scene.lighting);
    // The room differs where the person is not: the empty views disagree.
    let empty = |c: &splatzoo_illum::data::IllumCapture| c.frames[0].truth.clone().unwrap().empty;
    let (ea, eb) = (empty(&a), empty(&b));
    let differs = ea
        .iter()
        .zip(&eb)
        .filter(|(x, y)| (0..3).any(|c| (x[c] - y[c]).abs() > 0.05))
        .count();
    assert!(differs > ea.len() / 4, "{differs} pixels differ");
}
