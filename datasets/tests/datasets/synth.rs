//! Procedural motion and identities: determinism, feet on the ground while walking, the
//! trajectory following the speed, each motion doing what it names, smooth frame to frame, and
//! identities that differ by seed and paint every texel their charts cover.

use burn::tensor::Device;
use splatzoo_datasets::posing::pose_frames;
use splatzoo_datasets::synth::identity::Identity;
use splatzoo_datasets::synth::motion::{Motion, Start, generate};
use splatzoo_models::body::builtin_body;
use std::path::Path;

fn standing_height() -> f64 {
    let t = &builtin_body().model.template;
    -t.chunks(3).map(|p| p[1] as f64).fold(f64::MAX, f64::min)
}

fn posed(
    motions: &[Motion],
    fps: f64,
) -> (
    Vec<Vec<[f32; 3]>>,
    splatzoo_datasets::pose_sequence::PoseSequence,
) {
    let body = builtin_body();
    let start = Start {
        position: [0.0, 0.0],
        heading: 0.0,
        standing_height: standing_height(),
    };
    let seq = generate(motions, start, fps);
    let fitted = seq
        .for_model(24, body.model.shape_count(), Path::new("generated"))
        .unwrap();
    (pose_frames(&body.model, &fitted, &Device::flex()), seq)
}

#[test]
fn walking_keeps_feet_on_the_ground_and_moves_at_the_speed() {
    let motions = [Motion::Walk {
        seconds: 2.0,
        speed: 1.2,
        turn_rate: 0.0,
    }];
    let (frames, seq) = posed(&motions, 15.0);
    assert_eq!(seq, posed(&motions, 15.0).1, "not deterministic");
    for (f, vs) in frames.iter().enumerate() {
        let lowest = vs.iter().map(|p| p[1]).fold(f32::MAX, f32::min);
        assert!(
            lowest.abs() < 0.05,
            "frame {f}: lowest point at y = {lowest}"
        );
    }
    let travelled = seq.translation(seq.frames() - 1)[2] - seq.translation(0)[2];
    let expected = 1.2 * (seq.frames() - 1) as f64 / 15.0;
    assert!(
        (travelled - expected).abs() < 1e-6,
        "{travelled} vs {expected}"
    );
    // The legs actually alternate: left ankle ahead of the right in some frames, behind in others.
    let ankle_z = |vs: &Vec<[f32; 3]>, side: f32| {
        vs.iter()
            .filter(|p| p[1] < 0.12 && p[0] * side > 0.0)
            .map(|p| p[2])
            .sum::<f32>()
            / vs.iter()
                .filter(|p| p[1] < 0.12 && p[0] * side > 0.0)
                .count()
                .max(1) as f32
    };
    let ahead = frames
        .iter()
        .filter(|vs| ankle_z(vs, 1.0) > ankle_z(vs, -1.0) + 0.1)
        .count();
    let behind = frames
        .iter()
        .filter(|vs| ankle_z(vs, 1.0) < ankle_z(vs, -1.0) - 0.1)
        .count();
    assert!(
        ahead > 3 && behind > 3,
        "{ahead} frames left ahead, {behind} right ahead"
    );
}

#[test]
fn wave_raises_the_right_hand_above_the_head_and_sitting_lowers_the_pelvis() {
    let body = builtin_body();
    let tip = body.landmark("right_fingertip").unwrap() as usize;
    let top = body.landmark("head_top").unwrap() as usize;
    let (frames, seq) = posed(
        &[Motion::Idle { seconds: 0.5 }, Motion::Wave { seconds: 1.0 }],
        20.0,
    );
    let last = frames.last().unwrap();
    assert!(
        last[tip][1] > last[top][1],
        "fingertip {} below head top {}",
        last[tip][1],
        last[top][1]
    );
    assert!(
        frames[0][tip][1] < frames[0][top][1] - 0.5,
        "arms relaxed at first"
    );
    assert_eq!(seq.frames(), 30);

    let (frames, seq) = posed(
        &[Motion::SitStand {
            seconds: 3.0,
            seat_drop: 0.45,
        }],
        10.0,
    );
    let lowest_pelvis = (0..seq.frames())
        .map(|f| seq.translation(f)[1])
        .fold(f64::MAX, f64::min);
    assert!(
        (standing_height() - lowest_pelvis - 0.45).abs() < 0.02,
        "pelvis dropped to {lowest_pelvis}"
    );
    assert!(
        (seq.translation(seq.frames() - 1)[1] - standing_height()).abs() < 0.02,
        "stands up again"
    );
    assert!(
        frames
            .iter()
            .all(|vs| vs.iter().all(|p| p.iter().all(|x| x.is_finite())))
    );
}

#[test]
fn chained_motions_change_smoothly() {
    let motions = [
        Motion::Walk {
            seconds: 1.5,
            speed: 1.0,
            turn_rate: 0.4,
        },
        Motion::Turn {
            seconds: 1.0,
            angle: 1.5,
        },
        Motion::Wave { seconds: 1.0 },
        Motion::SitStand {
            seconds: 2.0,
            seat_drop: 0.4,
        },
        Motion::Idle { seconds: 0.5 },
    ];
    let (frames, seq) = posed(&motions, 30.0);
    assert_eq!(seq.frames(), 180);
    let mut worst = 0.0f32;
    for pair in frames.windows(2) {
        for (a, b) in pair[0].iter().zip(&pair[1]) {
            let d = ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt();
            worst = worst.max(d);
        }
    }
    // A walking foot peaks near 4–5 m/s; nothing should exceed 6 m/s (20 cm a frame at 30 fps),
    // which a jump between segments would.
    assert!(worst < 0.20, "a vertex jumps {worst} m between frames");
}

#[test]
fn identities_differ_by_seed_and_paint_their_charts() {
    let body = builtin_body();
    let a = Identity::sample(1);
    assert_eq!(a, Identity::sample(1));
    let others: Vec<Identity> = (2..12).map(Identity::sample).collect();
    assert!(others.iter().all(|o| *o != a));
    let skins: std::collections::HashSet<String> =
        others.iter().map(|o| format!("{:?}", o.skin)).collect();
    assert!(skins.len() > 3, "skin tones barely vary");
    assert!(others.iter().all(
        |o| o.betas.len() == body.model.shape_count() && o.betas.iter().all(|b| b.abs() < 5.0)
    ));

    let texture = a.bake_texture(body, 256);
    // Every texel a UV triangle covers is painted (none left black), and the identity's skin,
    // hair and top colours all appear.
    let coords = &body.uv.coords;
    let mut checked = 0;
    for f in 0..body.model.face_count() {
        let c = body.uv.faces[3 * f] as usize;
        let (u, v) = (coords[2 * c], coords[2 * c + 1]);
        let (x, y) = ((u * 256.0) as usize, ((1.0 - v) * 256.0) as usize);
        let t = texture.texels[y.min(255) * 256 + x.min(255)];
        assert!(
            t.iter().any(|&c| c > 0.0) || a.hair == [0.02, 0.015, 0.01],
            "black texel at a corner of face {f}"
        );
        checked += 1;
    }
    assert_eq!(checked, body.model.face_count());
    let close = |p: [f32; 3], q: [f32; 3]| (0..3).all(|k| (p[k] - q[k]).abs() < 1e-6);
    assert!(texture.texels.iter().any(|&t| close(t, a.skin)), "no skin");
    assert!(texture.texels.iter().any(|&t| close(t, a.hair)), "no hair");
    assert!(
        texture.texels.iter().any(|&t| close(t, a.top.colour)),
        "no top"
    );
}
