//! Surface marks of loaded bodies: the face-region rule against the built-in body's hand-placed
//! face, the SMPL / SMPL-X tables chosen by topology (and refused for any other mesh), and
//! marks files, good and broken, written by these tests.

use splatzoo_models::body::marks::{LANDMARK_NAMES, face_region_by_rule};
use splatzoo_models::body::{BodyKind, BodyModel, SurfaceMarks, builtin_body, save_npz};

/// The built-in body cut or padded to `vertices` vertices (copies of its last vertex, skinned
/// alike; faces kept where all three corners survive) and relabelled `kind`, with the joint
/// layout unchanged: a stand-in for a licensed SMPL-family topology.
fn resized(vertices: usize, kind: BodyKind) -> BodyModel {
    let model = builtin_body().model.clone();
    let (v, j) = (model.vertex_count(), model.joint_count());
    let source = |i: usize| i.min(v - 1);
    BodyModel {
        kind,
        template: (0..vertices)
            .flat_map(|i| model.template[3 * source(i)..3 * source(i) + 3].to_vec())
            .collect(),
        faces: model
            .faces
            .chunks(3)
            .filter(|f| f.iter().all(|&c| (c as usize) < vertices))
            .flatten()
            .copied()
            .collect(),
        skin_weights: (0..vertices)
            .flat_map(|i| model.skin_weights[j * source(i)..j * source(i) + j].to_vec())
            .collect(),
        ..model
    }
}

fn own_landmarks() -> Vec<(String, u32)> {
    SurfaceMarks::builtin().landmarks
}

/// The rule (head-dominant, facing forward, below the brow) on the built-in body finds nearly
/// the face its generator painted by hand: most of it, little else (IoU 0.745 measured), and
/// nothing off the head.
#[test]
fn the_face_rule_finds_the_builtin_bodys_face() {
    let body = builtin_body();
    let rule = face_region_by_rule(&body.model, &own_landmarks(), "built-in").expect("a region");
    let hand = &body.face_region;
    assert_eq!(rule.len(), hand.len());
    let both = rule.iter().zip(hand).filter(|(a, b)| **a && **b).count();
    let either = rule.iter().zip(hand).filter(|(a, b)| **a || **b).count();
    let iou = both as f64 / either as f64;
    assert!(iou > 0.6, "IoU {iou:.3} ({both} of {either})");
    // Every vertex of the rule's face is above the neck joint and no farther from the nose tip
    // than the ears are (the face, not the scalp, the nape or the throat).
    let neck = 12;
    let row = &body.model.joint_regressor[neck * body.model.vertex_count()..];
    let neck_height: f64 = (0..body.model.vertex_count())
        .map(|i| f64::from(row[i]) * f64::from(body.model.template[3 * i + 1]))
        .sum();
    let at =
        |v: usize| -> [f64; 3] { [0, 1, 2].map(|c| f64::from(body.model.template[3 * v + c])) };
    let distance = |a: [f64; 3], b: [f64; 3]| {
        ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
    };
    let nose = at(body.landmark("nose_tip").expect("nose") as usize);
    let ear = distance(nose, at(body.landmark("left_ear").expect("ear") as usize));
    for (i, _) in rule.iter().enumerate().filter(|(_, on)| **on) {
        assert!(at(i)[1] > neck_height, "vertex {i} below the neck");
        let d = distance(at(i), nose);
        assert!(
            d < ear,
            "vertex {i} {d:.3} from the nose tip, the ear {ear:.3}"
        );
    }
}

/// SMPL / SMPL-H topologies (6890 vertices) get the SMPL ids, SMPL-X (10475) its own, the
/// built-in body its own marks; the same body saved as a plain SMPL-layout file (7000
/// vertices) has no table and is told to bring a marks file.
#[test]
fn landmark_tables_follow_the_topology() {
    let smpl = resized(6890, BodyKind::Smpl);
    let marks = SurfaceMarks::for_model(&smpl, "smpl.npz").expect("the SMPL table");
    assert_eq!(marks.landmark("nose_tip"), Some(332));
    assert_eq!(marks.landmark("left_eye"), Some(2800));
    assert_eq!(marks.face_region.len(), 6890);
    let smplx = resized(10475, BodyKind::SmplX);
    let marks = SurfaceMarks::for_model(&smplx, "smplx.npz").expect("the SMPL-X table");
    assert_eq!(marks.landmark("nose_tip"), Some(9120));
    assert_eq!(marks.landmark("right_heel"), Some(8635));
    assert_eq!(marks.face_region.len(), 10475);
    for (name, v) in &marks.landmarks {
        assert!(LANDMARK_NAMES.contains(&name.as_str()), "{name}");
        assert!((*v as usize) < 10475, "{name}: {v}");
    }
    // SMPL-X ids on an SMPL topology are refused, not read out of range.
    let wrong = resized(6890, BodyKind::SmplX);
    let message = SurfaceMarks::for_model(&wrong, "odd.npz")
        .expect_err("no table")
        .to_string();
    assert!(
        message.contains("odd.npz") && message.contains("6890"),
        "{message}"
    );
    assert_eq!(
        SurfaceMarks::for_model(&builtin_body().model, "built-in").expect("own marks"),
        SurfaceMarks::builtin()
    );
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("body.npz");
    save_npz(&builtin_body().model, &path).expect("saved");
    let loaded = splatzoo_models::body::load_npz(&path).expect("loaded");
    let message = SurfaceMarks::for_model(&loaded, &path.display().to_string())
        .expect_err("no table for 7000 vertices")
        .to_string();
    assert!(
        message.contains("body.npz") && message.contains("marks file"),
        "{message}"
    );
}

/// A marks file gives the landmarks and, optionally, the face vertices (the rule otherwise);
/// an unknown name, a vertex out of range or broken JSON is named with the file.
#[test]
fn marks_files_are_read_and_bad_ones_named() {
    let model = &builtin_body().model;
    let dir = tempfile::tempdir().expect("temp dir");
    let write = |name: &str, text: &str| {
        let path = dir.path().join(name);
        std::fs::write(&path, text).expect("written");
        path
    };
    let landmarks: Vec<String> = own_landmarks()
        .iter()
        .map(|(n, v)| format!("\"{n}\": {v}"))
        .collect();
    let landmarks = landmarks.join(", ");
    let ruled = write("ruled.json", &format!("{{\"landmarks\": {{{landmarks}}}}}"));
    let marks = SurfaceMarks::from_file(model, &ruled).expect("read");
    assert_eq!(
        marks.face_region,
        face_region_by_rule(model, &own_landmarks(), "x").expect("rule")
    );
    assert_eq!(marks.landmark("mouth"), builtin_body().landmark("mouth"));
    let listed = write(
        "listed.json",
        &format!("{{\"landmarks\": {{{landmarks}}}, \"face_vertices\": [3, 5]}}"),
    );
    let marks = SurfaceMarks::from_file(model, &listed).expect("read");
    let on: Vec<usize> = (0..marks.face_region.len())
        .filter(|&i| marks.face_region[i])
        .collect();
    assert_eq!(on, vec![3, 5]);
    for (file, text, needle) in [
        ("unknown.json", "{\"landmarks\": {\"snout\": 3}}", "snout"),
        (
            "range.json",
            "{\"landmarks\": {\"nose_tip\": 99999}}",
            "7000",
        ),
        (
            "face.json",
            "{\"landmarks\": {}, \"face_vertices\": [7000]}",
            "face_vertices",
        ),
        ("broken.json", "{\"landmarks\": [", "expected JSON"),
        (
            "eyeless.json",
            "{\"landmarks\": {\"nose_tip\": 3}}",
            "left_eye",
        ),
    ] {
        let path = write(file, text);
        let message = SurfaceMarks::from_file(model, &path)
            .expect_err(file)
            .to_string();
        assert!(
            message.contains(file) && message.contains(needle),
            "{file}: {message}"
        );
    }
}
