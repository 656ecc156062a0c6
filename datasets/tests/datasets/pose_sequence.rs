//! Pose sequences in the AMASS `.npz` layout: round trip, AMASS dtypes and shapes, mapping
//! SMPL-H/X sequences onto SMPL, and errors that name the file, key and expected shape.

use npyz::WriterBuilder;
use npyz::npz::NpzWriter;
use splatzoo_datasets::pose_sequence::{PoseSequence, load_pose_sequence, write_pose_sequence};
use std::path::Path;

enum Values<'a> {
    F32(&'a [f32]),
    F64(&'a [f64]),
}

/// Writes one array in its own dtype.
fn put<T: npyz::AutoSerialize + Copy, W: std::io::Write + std::io::Seek>(
    npz: &mut NpzWriter<W>,
    name: &str,
    shape: &[u64],
    values: &[T],
) {
    let mut w = npz
        .array::<T>(name, Default::default())
        .unwrap()
        .default_dtype()
        .shape(shape)
        .begin_nd()
        .unwrap();
    w.extend(values.iter().copied()).unwrap();
    w.finish().unwrap();
}

/// Writes arrays with the given dtypes and shapes, as numpy's `savez` would.
fn write_npz(path: &Path, arrays: &[(&str, &[u64], Values)]) {
    let mut npz = NpzWriter::create(path).unwrap();
    for (name, shape, values) in arrays {
        match values {
            Values::F32(v) => put(&mut npz, name, shape, v),
            Values::F64(v) => put(&mut npz, name, shape, v),
        }
    }
    npz.zip_writer().finish().unwrap();
}

fn ramp(n: usize, scale: f32) -> Vec<f32> {
    (0..n)
        .map(|i| ((i * 37 % 101) as f32 / 101.0 - 0.5) * scale)
        .collect()
}

#[test]
fn round_trip_keeps_every_value() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("seq.npz");
    let t = 5;
    let seq = PoseSequence {
        joints: 24,
        poses: (0..t * 72).map(|i| (i as f64 * 0.013).sin()).collect(),
        translations: (0..t * 3).map(|i| i as f64 * 0.1).collect(),
        betas: (0..t * 10).map(|i| (i % 10) as f64 * 0.2 - 1.0).collect(),
        shape_count: 10,
        fps: Some(30.0),
    };
    write_pose_sequence(&path, &seq).unwrap();
    assert_eq!(load_pose_sequence(&path).unwrap(), seq);
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names.len(), 1, "temporary files left behind: {names:?}");
}

#[test]
fn reads_amass_smplh_layout_and_maps_it_to_smpl() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("amass.npz");
    let t = 4;
    let poses = ramp(t * 156, 2.0);
    let trans = ramp(t * 3, 1.0);
    let betas = ramp(16, 3.0);
    write_npz(
        &path,
        &[
            ("poses", &[t as u64, 156], Values::F32(&poses)),
            ("trans", &[t as u64, 3], Values::F32(&trans)),
            (
                "betas",
                &[16],
                Values::F64(&betas.iter().map(|&b| b as f64).collect::<Vec<_>>()),
            ),
            ("mocap_framerate", &[], Values::F64(&[120.0])),
        ],
    );
    let seq = load_pose_sequence(&path).unwrap();
    assert_eq!(
        (seq.joints, seq.frames(), seq.shape_count, seq.fps),
        (52, t, 16, Some(120.0))
    );
    assert_eq!(seq.frame_betas(3)[5], betas[5] as f64);
    let smpl = seq.for_model(24, 10, &path).unwrap();
    assert_eq!(smpl.joints, 24);
    for f in 0..t {
        assert_eq!(&smpl.pose(f)[..66], &seq.pose(f)[..66]);
        assert!(
            smpl.pose(f)[66..].iter().all(|&x| x == 0.0),
            "hand joints at rest"
        );
        assert_eq!(smpl.frame_betas(f).len(), 10);
    }
    // Fewer betas than the model takes are zero-padded.
    let padded = seq.for_model(52, 20, &path).unwrap();
    assert_eq!(padded.frame_betas(0)[16..], [0.0; 4]);
}

fn error_of(arrays: &[(&str, &[u64], Values)]) -> String {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.npz");
    write_npz(&path, arrays);
    let e = load_pose_sequence(&path).unwrap_err().to_string();
    assert!(e.contains("bad.npz"), "error does not name the file: {e}");
    e
}

#[test]
fn bad_files_are_named_with_key_and_expected_shape() {
    let p = ramp(2 * 72, 1.0);
    let e = error_of(&[("trans", &[2, 3], Values::F32(&p[..6]))]);
    assert!(e.contains("`poses`") && e.contains("[T, 3J]"), "{e}");
    let e = error_of(&[("poses", &[2, 70], Values::F32(&p[..140]))]);
    assert!(
        e.contains("`poses`") && e.contains("[2, 70]") && e.contains("[T, 3J]"),
        "{e}"
    );
    let e = error_of(&[
        ("poses", &[2, 72], Values::F32(&p)),
        ("trans", &[3, 2], Values::F32(&p[..6])),
    ]);
    assert!(e.contains("`trans`") && e.contains("[2, 3]"), "{e}");
    let e = error_of(&[
        ("poses", &[2, 72], Values::F32(&p)),
        ("betas", &[3, 10], Values::F32(&ramp(30, 1.0))),
    ]);
    assert!(e.contains("`betas`") && e.contains("[S] or [2, S]"), "{e}");
    let mut nan = p.clone();
    nan[72 + 5] = f32::NAN;
    let e = error_of(&[("poses", &[2, 72], Values::F32(&nan))]);
    assert!(
        e.contains("`poses`") && e.contains("frame 1, column 5"),
        "{e}"
    );
    let dir = tempfile::tempdir().unwrap();
    let garbage = dir.path().join("garbage.npz");
    std::fs::write(&garbage, b"not a zip").unwrap();
    let e = load_pose_sequence(&garbage).unwrap_err().to_string();
    assert!(e.contains("garbage.npz") && e.contains(".npz"), "{e}");
}

#[test]
fn a_sequence_that_cannot_drive_the_model_says_so() {
    let seq = PoseSequence {
        joints: 24,
        poses: vec![0.0; 72],
        translations: vec![0.0; 3],
        betas: vec![],
        shape_count: 0,
        fps: None,
    };
    let e = seq
        .for_model(40, 10, Path::new("walk.npz"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("walk.npz") && e.contains("`poses`") && e.contains("[T, 120]"),
        "{e}"
    );
}

/// An SMPL sequence drives SMPL-H and SMPL-X by its 22 body joints; hands, jaw and eyes rest.
#[test]
fn an_smpl_sequence_drives_the_bigger_skeletons() {
    let poses = ramp(2 * 72, 0.01);
    let seq = PoseSequence {
        joints: 24,
        poses: poses.iter().map(|&p| f64::from(p)).collect(),
        translations: vec![0.0; 6],
        betas: vec![],
        shape_count: 0,
        fps: None,
    };
    for joints in [52, 55] {
        let big = seq.for_model(joints, 10, Path::new("walk.npz")).unwrap();
        assert_eq!((big.joints, big.frames()), (joints, 2));
        for f in 0..2 {
            assert_eq!(&big.pose(f)[..66], &seq.pose(f)[..66]);
            assert!(big.pose(f)[66..].iter().all(|&x| x == 0.0), "{joints}");
        }
    }
}

#[test]
fn a_z_up_sequence_turns_into_the_bodies_y_up_world() {
    use splatzoo_datasets::pose_sequence::Z_UP_TO_Y_UP;
    use splatzoo_models::rotation_scalar::axis_angle_matrix;
    // Frame 0 at rest, 1 m up (z); frame 1 turned 90° about z (a heading change in z-up).
    let mut poses = vec![0.0; 2 * 72];
    poses[72 + 2] = std::f64::consts::FRAC_PI_2;
    poses[72 + 3] = 0.4; // another joint: untouched
    let seq = PoseSequence {
        joints: 24,
        poses,
        translations: vec![0.0, 0.0, 1.0, 0.5, -0.25, 0.9],
        betas: vec![0.0; 2 * 10],
        shape_count: 10,
        fps: Some(30.0),
    };
    let turned = seq.rotated_world(Z_UP_TO_Y_UP);
    assert_eq!(turned.translation(0), [0.0, 1.0, 0.0], "z up → y up");
    let t1 = turned.translation(1);
    for (got, want) in t1.iter().zip([0.5, 0.9, 0.25]) {
        assert!((got - want).abs() < 1e-12, "{t1:?}");
    }
    // The root now stands up in y: the rest pose's up axis (z in the file) maps to +y.
    let root0 = axis_angle_matrix(turned.pose(0)[..3].try_into().unwrap());
    let up = [root0[0][2], root0[1][2], root0[2][2]];
    assert!((up[1] - 1.0).abs() < 1e-12, "{up:?}");
    // A heading about the file's up axis becomes a heading about y.
    let root1 = axis_angle_matrix(turned.pose(1)[..3].try_into().unwrap());
    let r0t: Vec<f64> = (0..3)
        .flat_map(|i| (0..3).map(move |j| (i, j)))
        .map(|(i, j)| (0..3).map(|k| root1[i][k] * root0[j][k]).sum())
        .collect();
    // root1 · root0ᵀ is a turn about y by 90°.
    assert!((r0t[4] - 1.0).abs() < 1e-9, "{r0t:?}");
    assert!(
        r0t[0].abs() < 1e-9 && (r0t[2].abs() - 1.0).abs() < 1e-9,
        "{r0t:?}"
    );
    assert_eq!(turned.pose(1)[3], 0.4);
    assert_eq!(turned.frames(), 2);
}

/// A driving file is fitted to the body and, for z-up files, turned to the bodies' y-up world.
#[test]
fn driving_sequences_are_fitted_and_turned_upright() {
    use splatzoo_datasets::pose_sequence::{UpAxis, Z_UP_TO_Y_UP, load_driving_sequence};
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("walk.npz");
    let frames = 3;
    let seq = PoseSequence {
        joints: 52,
        poses: ramp(frames * 156, 0.01).iter().map(|&v| v as f64).collect(),
        translations: ramp(frames * 3, 0.3).iter().map(|&v| v as f64).collect(),
        betas: vec![0.5; frames * 16],
        shape_count: 16,
        fps: Some(30.0),
    };
    write_pose_sequence(&path, &seq).unwrap();
    let upright = load_driving_sequence(&path, 24, 10, UpAxis::Y).unwrap();
    assert_eq!(upright, seq.for_model(24, 10, &path).unwrap());
    assert_eq!((upright.joints, upright.shape_count), (24, 10));
    let turned = load_driving_sequence(&path, 24, 10, UpAxis::Z).unwrap();
    assert_eq!(turned, upright.rotated_world(Z_UP_TO_Y_UP));
    // (x, y, z) → (x, z, −y).
    let (t, u) = (turned.translation(1), upright.translation(1));
    assert!(
        (t[0] - u[0]).abs() < 1e-12 && (t[1] - u[2]).abs() < 1e-12 && (t[2] + u[1]).abs() < 1e-12
    );
}

/// Placing a walk: its first root lands at the floor point asked, its height kept; its
/// displacement from the start and its heading turn by the yaw; other joints are untouched.
/// Looping repeats frames modulo T with the driven body's shape.
#[test]
fn a_placed_sequence_starts_where_asked_and_walks_turned_by_the_yaw() {
    use splatzoo_models::rotation_scalar::axis_angle_matrix;
    let mut poses = vec![0.0; 3 * 72];
    for t in 0..3 {
        poses[72 * t] = 0.1 * t as f64; // a root that turns a little
        poses[72 * t + 5] = 0.3; // another joint
    }
    let seq = PoseSequence {
        joints: 24,
        poses,
        translations: vec![2.0, 0.9, -1.0, 2.5, 0.92, -1.0, 3.0, 0.9, -0.8],
        betas: vec![0.2; 3 * 10],
        shape_count: 10,
        fps: Some(30.0),
    };
    let placed = seq.placed([-0.4, 1.5], 90.0);
    let t0 = placed.translation(0);
    assert!(
        (t0[0] + 0.4).abs() < 1e-12 && (t0[1] - 0.9).abs() < 1e-12 && (t0[2] - 1.5).abs() < 1e-12,
        "{t0:?}"
    );
    // The first step was +0.5 m along x; turned 90° about y, it is −0.5 m along z.
    let t1 = placed.translation(1);
    let step = [t1[0] - t0[0], t1[1] - t0[1], t1[2] - t0[2]];
    assert!(
        step[0].abs() < 1e-12 && (step[1] - 0.02).abs() < 1e-12 && (step[2] + 0.5).abs() < 1e-12,
        "{step:?}"
    );
    // Each root turned by the yaw: R_y(90°) · R_root.
    for t in 0..3 {
        let before = axis_angle_matrix(seq.pose(t)[..3].try_into().unwrap());
        let after = axis_angle_matrix(placed.pose(t)[..3].try_into().unwrap());
        for j in 0..3 {
            // Row 0 of R_y(90°)·R is R's row 2; row 2 is −R's row 0.
            assert!((after[0][j] - before[2][j]).abs() < 1e-9);
            assert!((after[2][j] + before[0][j]).abs() < 1e-9);
            assert!((after[1][j] - before[1][j]).abs() < 1e-9);
        }
        assert_eq!(placed.pose(t)[3..], seq.pose(t)[3..]);
    }
    // No yaw: only the shift.
    let moved = seq.placed([0.0, 0.0], 0.0);
    assert_eq!(moved.pose(2), seq.pose(2));
    assert!(
        (moved.translation(2)[0] - 1.0).abs() < 1e-12
            && (moved.translation(2)[2] - 0.2).abs() < 1e-12
    );

    let betas = [0.7; 10];
    let looped = seq.looped(7, &betas).unwrap();
    assert_eq!(looped.frames(), 7);
    assert_eq!(looped.pose(5), seq.pose(2));
    assert_eq!(looped.translation(6), seq.translation(0));
    assert_eq!(looped.frame_betas(4), &betas);
    let empty = PoseSequence {
        joints: 24,
        poses: vec![],
        translations: vec![],
        betas: vec![],
        shape_count: 10,
        fps: None,
    };
    assert!(empty.looped(3, &betas).is_none());
    assert_eq!(empty.placed([1.0, 1.0], 30.0).frames(), 0);
}
