//! The `pose-body` command end to end: a body model written in the SMPL `.npz` layout and a pose
//! sequence in, OBJ meshes and a preview PNG out; and a bad sequence refused with a clear error.

use splatzoo_datasets::pose_sequence::{PoseSequence, write_pose_sequence};
use splatzoo_models::body::{builtin_body, load_npz, save_npz};
use std::process::Command;

#[test]
fn poses_a_model_file_and_writes_meshes_and_a_preview() {
    let dir = tempfile::tempdir().unwrap();
    let model_path = dir.path().join("body.npz");
    let body = builtin_body();
    save_npz(&body.model, &model_path).unwrap();
    let reread = load_npz(&model_path).unwrap();
    assert_eq!(reread.template, body.model.template);
    assert_eq!(reread.faces, body.model.faces);
    assert_eq!(reread.parents, body.model.parents);
    let t = 3;
    let mut poses = vec![0.0; t * 72];
    poses[72 + 18 * 3 + 1] = -1.5; // frame 1: left elbow bent
    poses[2 * 72 + 1] = 1.57; // frame 2: turned
    let seq = PoseSequence {
        joints: 24,
        poses,
        translations: vec![0.0, 0.0, 0.0, 0.1, 0.0, 0.0, 0.2, 0.0, 0.0],
        betas: vec![1.0; t * 4],
        shape_count: 4,
        fps: Some(30.0),
    };
    let seq_path = dir.path().join("seq.npz");
    write_pose_sequence(&seq_path, &seq).unwrap();
    let out = dir.path().join("out");
    let status = Command::new(env!("CARGO_BIN_EXE_pose-body"))
        .args([
            "--model",
            model_path.to_str().unwrap(),
            "--poses",
            seq_path.to_str().unwrap(),
        ])
        .args(["--out", out.to_str().unwrap(), "--cell", "96"])
        .output()
        .unwrap();
    assert!(
        status.status.success(),
        "{}",
        String::from_utf8_lossy(&status.stderr)
    );
    for f in 0..t {
        let obj = std::fs::read_to_string(out.join(format!("frame_{f:05}.obj"))).unwrap();
        let v = obj.lines().filter(|l| l.starts_with("v ")).count();
        let faces = obj.lines().filter(|l| l.starts_with("f ")).count();
        assert_eq!(
            (v, faces),
            (body.model.vertex_count(), body.model.face_count())
        );
    }
    // Frame 2 is the body turned 90° about y and moved 0.2 m along x.
    let read_vertices = |f: usize| -> Vec<[f32; 3]> {
        std::fs::read_to_string(out.join(format!("frame_{f:05}.obj")))
            .unwrap()
            .lines()
            .filter(|l| l.starts_with("v "))
            .map(|l| {
                let x: Vec<f32> = l[2..].split(' ').map(|s| s.parse().unwrap()).collect();
                [x[0], x[1], x[2]]
            })
            .collect()
    };
    let (rest, turned) = (read_vertices(0), read_vertices(2));
    let span = |vs: &[[f32; 3]], k: usize| {
        vs.iter().map(|p| p[k]).fold(f32::MIN, f32::max)
            - vs.iter().map(|p| p[k]).fold(f32::MAX, f32::min)
    };
    assert!(span(&rest, 0) > 1.5 && span(&turned, 2) > 1.5 && span(&turned, 0) < 0.6);
    let preview = image::open(out.join("preview.png")).unwrap();
    assert_eq!((preview.width(), preview.height()), (3 * 96, 2 * 96));
    // Not blank: the body covers part of every cell.
    let rgb = preview.to_rgb8();
    for cell in 0..3 {
        let dark = (0..96 * 96)
            .filter(|i| {
                rgb.get_pixel((cell * 96 + i % 96) as u32, (i / 96) as u32)
                    .0
                    != [255, 255, 255]
            })
            .count();
        assert!(dark > 150, "cell {cell} is nearly empty ({dark} pixels)");
    }
}

#[test]
fn a_sequence_for_another_skeleton_is_refused_with_the_key_and_shape() {
    let dir = tempfile::tempdir().unwrap();
    let seq = PoseSequence {
        joints: 10,
        poses: vec![0.0; 30],
        translations: vec![0.0; 3],
        betas: vec![],
        shape_count: 0,
        fps: None,
    };
    let seq_path = dir.path().join("odd.npz");
    write_pose_sequence(&seq_path, &seq).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_pose-body"))
        .args([
            "--poses",
            seq_path.to_str().unwrap(),
            "--out",
            dir.path().join("o").to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("odd.npz") && err.contains("`poses`") && err.contains("[T, 72]"),
        "{err}"
    );
}
