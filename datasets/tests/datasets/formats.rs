//! Dataset loaders on small fixtures in each format's exact layout (pickles, joblib dumps and
//! numpy object files through `splatzoo_models::pickle::Writer`, which Python's own readers
//! accept), written by [`splatzoo_datasets::fixtures`], each fixture's doc naming the original
//! script whose output it copies: every convention conversion, and bad input named by file,
//! field and expected shape. The awkward parts of the real releases have their own tests in
//! [`crate::real_layouts`], which reuses these fixtures.

use crate::fixtures::close;
use splatzoo_datasets::fixtures::{
    drivestudio_fixture, ghg_fixture, neuman_fixture, rot_y, rot_z, snapshot_fixture, write_annots,
    write_mask, write_npy_f64, write_npz, write_params, write_rgb, zju_fixture,
};
use splatzoo_datasets::formats::check::check;
use splatzoo_datasets::formats::zju::parameter_index;
use splatzoo_datasets::formats::{Format, MaskConvention, detect, load};
use std::path::Path;

#[test]
fn neuman_scenes_load_in_our_conventions() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    neuman_fixture(root, false);
    assert_eq!(detect(root), Some(Format::Neuman));
    let d = load(root, None).unwrap();
    let names: Vec<&str> = d.views.iter().map(|v| v.camera_name.as_str()).collect();
    assert_eq!(
        names,
        ["00000.png", "00001.png", "00002.png"],
        "sorted by name"
    );
    assert_eq!(
        d.views.iter().map(|v| v.frame).collect::<Vec<_>>(),
        [0, 1, 2]
    );
    // COLMAP world-to-camera: R from (w, x, y, z), t as given; intrinsics unchanged.
    let cam = d.views[1].camera;
    let r = rot_y(std::f64::consts::FRAC_PI_2);
    for (row, want) in cam.world_to_camera.iter().zip(&r) {
        assert!(
            (0..3).all(|j| close(row[j] as f64, want[j])),
            "{:?}",
            cam.world_to_camera
        );
    }
    assert_eq!(
        [cam.world_to_camera[0][3], cam.world_to_camera[2][3]],
        [0.5, 3.0]
    );
    assert_eq!(
        (cam.fx, cam.fy, cam.cx, cam.cy, cam.width, cam.height),
        (10.0, 11.0, 4.0, 3.0, 8, 6)
    );
    assert_eq!(d.views[0].mask_convention, MaskConvention::ZeroIsPerson);
    assert_eq!(d.splits["test"], vec![1]);
    assert_eq!(d.points.len(), 2);
    assert!(close(d.points[0].1[2] as f64, 0.2));
    // SMPL by frame number; the alignment as x_world = s R x + t.
    let track = &d.people[0];
    let f1 = track.frames[1].as_ref().unwrap();
    assert!(close(f1.global_orient[0], 0.1) && close(f1.global_orient[2], -0.2));
    assert_eq!(f1.body_pose.len(), 69);
    assert!(close(f1.betas[0], 0.5));
    let m = &f1.world_from_smpl;
    assert!(close(m.scale, 1.5), "{}", m.scale);
    let x = [0.3, -0.7, 1.1];
    let rz = rot_z(std::f64::consts::FRAC_PI_6);
    let want: Vec<f64> = (0..3)
        .map(|i| 1.5 * (0..3).map(|j| rz[i][j] * x[j]).sum::<f64>() + [1.0, 2.0, 3.0][i])
        .collect();
    let got = m.apply(x);
    assert!(
        (0..3).all(|i| close(got[i], want[i])),
        "{got:?} vs {want:?}"
    );
    assert!(track.frames[2].is_none(), "no alignment, not valid");
    // Every image and mask decodes at its camera's size; masks hold person pixels.
    let report = check(&d, None);
    assert_eq!(
        (report.images, report.masks, report.problems.len()),
        (3, 3, 0),
        "{report:?}"
    );
}

#[test]
fn bad_neuman_input_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    neuman_fixture(root, true);
    let e = load(root, None).unwrap_err().to_string();
    assert!(
        e.contains("smpl_output_optimized.pkl") && e.contains("1.pose[1]") && e.contains("(72,)"),
        "{e}"
    );
    neuman_fixture(root, false);
    // A truncated image and a mask with the wrong convention are reported by the check.
    let image = root.join("images/00001.png");
    let bytes = std::fs::read(&image).unwrap();
    std::fs::write(&image, &bytes[..bytes.len() / 2]).unwrap();
    write_mask(&root.join("segmentations/00002.png"), 8, 6, 255, 255);
    let report = check(&load(root, None).unwrap(), None);
    assert!(
        report.problems[0].0.ends_with("00001.png") && report.problems[0].1.contains("decode"),
        "{report:?}"
    );
    assert!(
        report
            .problems
            .iter()
            .any(|(f, p)| f.ends_with("segmentations/00002.png") && p.contains("no person")),
        "{report:?}"
    );
    // An unsupported camera model names the line and the model.
    std::fs::write(root.join("sparse/cameras.txt"), "1 FISHEYE 8 6 1 2 3 4\n").unwrap();
    let e = load(root, None).unwrap_err().to_string();
    assert!(
        e.contains("cameras.txt") && e.contains("line 1") && e.contains("FISHEYE"),
        "{e}"
    );
    std::fs::remove_file(root.join("alignments.npy")).unwrap();
    neuman_fixture(root, false);
    std::fs::write(root.join("alignments.npy"), b"not numpy").unwrap();
    let e = load(root, None).unwrap_err().to_string();
    assert!(e.contains("alignments.npy"), "{e}");
}

#[test]
fn zju_mocap_loads_in_our_conventions() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    zju_fixture(root);
    assert_eq!(detect(root), Some(Format::Zju));
    let d = load(root, None).unwrap();
    assert_eq!((d.frame_count, d.views.len()), (2, 4));
    assert_eq!(d.camera_names(), ["Camera_B1", "Camera_B2"]);
    let v = &d.views[3];
    assert_eq!((v.frame, v.camera_name.as_str()), (1, "Camera_B2"));
    let cam = v.camera;
    // T in millimetres → metres; OpenCV integer pixel centres → ours at +0.5; size from the image.
    assert_eq!(
        [
            cam.world_to_camera[0][3],
            cam.world_to_camera[1][3],
            cam.world_to_camera[2][3]
        ],
        [0.1, -0.25, 3.0]
    );
    assert_eq!(
        (cam.fx, cam.fy, cam.cx, cam.cy, cam.width, cam.height),
        (501.0, 503.0, 4.5, 3.5, 10, 8)
    );
    assert!(close(cam.world_to_camera[0][2] as f64, 0.3f64.sin()));
    assert!(
        close(v.distortion.k1, 0.1)
            && close(v.distortion.k3, 0.01)
            && close(v.distortion.p2, 0.002)
    );
    assert_eq!(
        v.mask.as_deref(),
        Some(root.join("mask_cihp/Camera_B2/000001.png").as_path())
    );
    assert_eq!(v.mask_convention, MaskConvention::NonZeroIsPerson);
    // x_world = R(Rh) x + Th: Rh = 90° about y.
    let f1 = d.people[0].frames[1].as_ref().unwrap();
    assert!(close(f1.body_pose[0], 1.2) && close(f1.betas[9], 0.25));
    let got = f1.world_from_smpl.apply([1.0, 0.0, 0.0]);
    assert!(
        close(got[0], 0.1) && close(got[1], 0.2) && close(got[2], 1.3 - 1.0),
        "{got:?}"
    );
    let report = check(&d, None);
    assert_eq!(
        (report.images, report.masks, report.problems.len()),
        (4, 4, 0),
        "{report:?}"
    );
    assert_eq!(report.sizes, vec![(10, 8)]);
    // 313/315 name their frames 1-based in the file name; others by the number itself.
    assert_eq!(
        parameter_index("Camera (1)/CoreView_313_Camera_(1)_0001_2019-08-23_16-08-50.592.jpg"),
        Some(1)
    );
    assert_eq!(parameter_index("Camera_B1/000012.jpg"), Some(12));
}

#[test]
fn refined_zju_mocap_layout_loads() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    write_annots(root, [3, 3], |f, c| format!("images/{c:02}/{f:06}.jpg"));
    for f in 0..2 {
        for c in 0..2 {
            write_rgb(&root.join(format!("images/{c:02}/{f:06}.jpg")), 10, 8);
            write_mask(&root.join(format!("mask/{c:02}/{f:06}.png")), 10, 8, 255, 0);
        }
    }
    write_params(
        &root.join("smpl_params/0.npy"),
        &[0.0; 72],
        [0.0; 3],
        [0.0; 3],
        &[0.0; 10],
    );
    let d = load(root, Some(Format::Zju)).unwrap();
    assert_eq!(d.camera_names(), ["00", "01"]);
    assert_eq!(
        d.views[1].mask.as_deref(),
        Some(root.join("mask/01/000000.png").as_path())
    );
    assert!(
        d.people[0].frames[0].is_some() && d.people[0].frames[1].is_none(),
        "frame 1 has no parameters"
    );
}

#[test]
fn bad_zju_mocap_input_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    zju_fixture(root);
    write_params(
        &root.join("params/1.npy"),
        &[0.0; 72],
        [0.0; 3],
        [0.0, f64::NAN, 0.0],
        &[0.0; 10],
    );
    let e = load(root, None).unwrap_err().to_string();
    assert!(
        e.contains("params/1.npy") && e.contains("`Th`") && e.contains("(1, 3)"),
        "{e}"
    );
    write_params(
        &root.join("params/1.npy"),
        &[0.0; 69],
        [0.0; 3],
        [0.0; 3],
        &[0.0; 10],
    );
    let e = load(root, None).unwrap_err().to_string();
    assert!(
        e.contains("params/1.npy")
            && e.contains("poses")
            && e.contains("[1, 69]")
            && e.contains("(1, 72)"),
        "{e}"
    );
    zju_fixture(root);
    write_annots(root, [2, 3], |f, c| format!("Camera_B{}/{f:06}.jpg", c + 1));
    let e = load(root, None).unwrap_err().to_string();
    assert!(
        e.contains("annots.npy") && e.contains("cams.K[0]") && e.contains("(3, 3)"),
        "{e}"
    );
    zju_fixture(root);
    std::fs::remove_file(root.join("Camera_B2/000000.jpg")).unwrap();
    let e = load(root, None).unwrap_err().to_string();
    assert!(e.contains("Camera_B2/000000.jpg"), "{e}");
}

#[test]
fn the_inspect_command_reports_and_names_the_first_problem() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("scene");
    neuman_fixture(&root, false);
    let run = |root: &Path| {
        std::process::Command::new(env!("CARGO_BIN_EXE_inspect-dataset"))
            .arg(root)
            .output()
            .unwrap()
    };
    let ok = run(&root);
    let text = String::from_utf8_lossy(&ok.stdout).into_owned();
    assert!(ok.status.success(), "{text}");
    for expected in [
        "format: Neuman",
        "frames: 3",
        "cameras: 3",
        "person 1: valid in 2 of 3 frames",
        "resolution 8×6",
        "no problems found",
    ] {
        assert!(text.contains(expected), "{expected:?} in {text}");
    }
    let image = root.join("images/00002.png");
    std::fs::write(&image, b"\x89PNG").unwrap();
    let bad = run(&root);
    let text = String::from_utf8_lossy(&bad.stdout).into_owned();
    assert!(!bad.status.success());
    assert!(
        text.contains("first problem") && text.contains("00002.png"),
        "{text}"
    );
    let nothing = run(dir.path());
    assert!(!nothing.status.success());
    assert!(String::from_utf8_lossy(&nothing.stdout).contains("format not recognised"));
}

#[test]
fn people_snapshot_npz_form_loads_with_its_splits_and_refined_poses() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("male-3-casual");
    snapshot_fixture(&root, false);
    // Refined poses for the test split (frames 456.. do not exist here; train = 0, 4).
    write_npz(
        &root.join("poses/anim_nerf_train.npz"),
        &[
            ("global_orient", &[2, 3], &[1.0, 0.0, 0.0, 2.0, 0.0, 0.0]),
            ("body_pose", &[2, 69], &[0.5; 138]),
            ("transl", &[2, 3], &[0.0, 0.0, 7.0, 0.0, 0.0, 8.0]),
            ("betas", &[1, 10], &[0.9; 10]),
        ],
        true,
    );
    assert_eq!(detect(&root), Some(Format::PeopleSnapshot));
    let d = load(&root, None).unwrap();
    assert_eq!((d.frame_count, d.views.len()), (6, 6));
    let cam = d.views[0].camera;
    assert_eq!(
        (cam.fx, cam.fy, cam.cx, cam.cy, cam.width, cam.height),
        (500.0, 510.0, 3.0, 4.0, 6, 8),
        "OpenCV centres → +0.5"
    );
    assert_eq!(d.splits["train"], vec![0, 4]);
    let frames = &d.people[0].frames;
    let f1 = frames[1].as_ref().unwrap();
    assert!(
        close(f1.global_orient[0], 0.0)
            && close(f1.body_pose[0], 0.003)
            && close(f1.transl[2], 6.0)
    );
    let f4 = frames[4].as_ref().unwrap();
    assert!(
        close(f4.global_orient[0], 2.0) && close(f4.transl[2], 8.0) && close(f4.betas[0], 0.9),
        "the refined train poses replace poses.npz on their frames"
    );
    let report = check(&d, None);
    assert_eq!(
        (report.images, report.masks, report.problems.len()),
        (6, 6, 0),
        "{report:?}"
    );
    // Bad input: NaN in a pose, a missing key.
    snapshot_fixture(&root, true);
    let e = load(&root, None).unwrap_err().to_string();
    assert!(
        e.contains("poses.npz") && e.contains("thetas") && e.contains("(at least 6, 72)"),
        "{e}"
    );
    write_npz(
        &root.join("poses.npz"),
        &[("thetas", &[6, 72], &[0.0; 432])],
        true,
    );
    let e = load(&root, None).unwrap_err().to_string();
    assert!(
        e.contains("poses.npz") && e.contains("transl") && e.contains("missing"),
        "{e}"
    );
}

#[test]
fn ghg_thuman_renders_load_with_the_test_protocol() {
    let dir = tempfile::tempdir().unwrap();
    let split = ghg_fixture(&dir.path().join("THuman"));
    let root = split.as_path();
    assert_eq!(detect(root), Some(Format::Ghg));
    let d = load(root, None).unwrap();
    assert_eq!((d.frame_count, d.views.len()), (1, 6));
    assert_eq!(d.views[2].camera_name, "003/0");
    assert_eq!(
        d.splits["inputs"],
        vec![0, 4],
        "view 0 of ring positions 0 and 6"
    );
    assert_eq!(d.splits["targets"], vec![2]);
    // The look-at target projects to the principal point; a higher point projects higher (v
    // smaller): OpenCV world-to-camera with world y up; K's centre + 0.5 (GHG's renderer puts
    // pixel centres at integers).
    for view in &d.views {
        let c = view.camera;
        let project = |p: [f64; 3]| {
            let x: Vec<f64> = (0..3)
                .map(|i| {
                    (0..3)
                        .map(|j| c.world_to_camera[i][j] as f64 * p[j])
                        .sum::<f64>()
                        + c.world_to_camera[i][3] as f64
                })
                .collect();
            (
                c.fx as f64 * x[0] / x[2] + c.cx as f64,
                c.fy as f64 * x[1] / x[2] + c.cy as f64,
            )
        };
        let (u, v) = project([0.0, 0.85, 0.0]);
        assert!(close(u, 8.5) && close(v, 8.9), "{u} {v}");
        assert!(project([0.0, 1.35, 0.0]).1 < v);
    }
    // SMPL-X placed by scale, translation and GHG's transform: k = 1.8 / 1.8 = 1.
    let body = d.people[0].frames[0].as_ref().unwrap();
    assert_eq!(body.body_pose.len(), 63);
    assert_eq!(body.extra["left_hand_pose"].len(), 12);
    let m = &body.world_from_smpl;
    assert!(close(m.scale, 0.9));
    let t = m.translation;
    assert!(
        close(t[0], 0.05) && close(t[1], 0.3 + 0.5) && close(t[2], 0.1 - 0.01),
        "{t:?}"
    );
    let report = check(&d, None);
    assert_eq!(
        (report.images, report.masks, report.problems.len()),
        (6, 6, 0),
        "{report:?}"
    );
    // A wrongly shaped extrinsic is named.
    write_npy_f64(
        &root.join("parm/0004_003/1_extrinsic.npy"),
        &[4, 4],
        &[0.0; 16],
    );
    let e = load(root, None).unwrap_err().to_string();
    assert!(
        e.contains("1_extrinsic.npy") && e.contains("(3, 4)") && e.contains("[4, 4]"),
        "{e}"
    );
}

#[test]
fn nerfstudio_folders_load_as_datasets() {
    let dir = tempfile::tempdir().unwrap();
    let scene = splatzoo_datasets::synth::SceneConfig {
        width: 16,
        height: 16,
        ..splatzoo_datasets::synth::SceneConfig::new(splatzoo_datasets::synth::Preset::Static, 1)
    }
    .build(&burn::tensor::Device::flex());
    splatzoo_datasets::synth::export::write_scene(&scene, dir.path(), &[0], |_| {}).unwrap();
    assert_eq!(detect(dir.path()), Some(Format::Synthetic));
    let d = load(dir.path(), Some(Format::Nerfstudio)).unwrap();
    assert_eq!(d.views.len(), 48);
    let report = check(&d, None);
    assert_eq!(
        (report.images, report.problems.len()),
        (48, 0),
        "{report:?}"
    );
}

#[test]
fn drivestudio_waymo_scenes_load_in_our_conventions() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    drivestudio_fixture(root, true);
    assert_eq!(detect(root), Some(Format::Drivestudio));
    let d = load(root, None).unwrap();
    assert_eq!((d.frame_count, d.views.len()), (2, 4));
    assert_eq!(d.frame_times, vec![0.0, 1.0]);
    assert!(d.views.iter().all(|v| v.other_masks.contains_key("sky")));
    let front = d
        .views
        .iter()
        .find(|v| v.camera_name == "0" && v.frame == 0)
        .unwrap()
        .camera;
    // Re-centred on the first ego pose; OpenCV z (forward) = world +x, x = −y, y = −z.
    let want = [[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]];
    for (row, w) in front.world_to_camera.iter().zip(want) {
        assert!(
            (0..3).all(|j| close(row[j] as f64, w[j])),
            "{:?}",
            front.world_to_camera
        );
    }
    let p = front.position();
    assert!(
        close(p[0] as f64, 1.5) && close(p[1] as f64, 0.0) && close(p[2] as f64, 1.6),
        "{p:?}"
    );
    assert_eq!(
        (
            front.fx,
            front.fy,
            front.cx,
            front.cy,
            front.width,
            front.height
        ),
        (100.0, 101.0, 16.0, 12.0, 32, 24)
    );
    let later = d
        .views
        .iter()
        .find(|v| v.camera_name == "0" && v.frame == 1)
        .unwrap()
        .camera
        .position();
    assert!(
        close(later[0] as f64, 3.5) && close(later[1] as f64, 0.0),
        "2 m ahead: {later:?}"
    );
    let side = d.views.iter().find(|v| v.camera_name == "3").unwrap();
    assert_eq!(side.camera.fx, 90.0, "intrinsics on one line");
    let d0 = d.views.iter().find(|v| v.camera_name == "0").unwrap();
    assert!(close(d0.distortion.k1, 0.01));
    // Boxes re-centred.
    let walker = d
        .boxes
        .iter()
        .find(|b| b.class == "Pedestrian" && b.frame == 0)
        .unwrap();
    let c = [
        walker.object_to_world[0][3],
        walker.object_to_world[1][3],
        walker.object_to_world[2][3],
    ];
    assert!(
        close(c[0], 8.0) && close(c[1], 0.0) && close(c[2], 0.9),
        "{c:?}"
    );
    assert_eq!(d.boxes.len(), 3);
    // SMPL from torch tensors: camera-frame orientation → world by camera 0's rotation, root at
    // the box centre, rotation matrices → axis-angle, frame 1 not valid.
    let person = &d.people[0];
    assert_eq!(person.person, "1");
    let f0 = person.frames[0].as_ref().unwrap();
    assert!(
        close(f0.body_pose[0], 0.5) && close(f0.body_pose[1], 0.0) && close(f0.body_pose[3], 0.0)
    );
    assert!(f0.global_orient.iter().all(|v| close(*v, 0.0)));
    let r = f0.world_from_smpl.rotation;
    assert!(
        (0..3).all(|i| (0..3).all(|j| close(r[i][j], want[j][i]))),
        "camera-to-world rotation: {r:?}"
    );
    assert_eq!(
        f0.root_position.map(|p| p.map(|v| (v * 1e6).round() / 1e6)),
        Some([8.0, 0.0, 0.9])
    );
    assert!(close(f0.betas[3], 0.4));
    assert!(person.frames[1].is_none());
    // For a model whose root rests at j0, SMPL's transl puts the root on the box centre.
    let j0 = [0.0, -0.22, 0.03];
    let transl = f0.smpl_transl(j0);
    let root_world = f0
        .world_from_smpl
        .apply(std::array::from_fn(|i| j0[i] + transl[i]));
    assert!(
        (0..3).all(|i| close(root_world[i], [8.0, 0.0, 0.9][i])),
        "{root_world:?}"
    );
    let report = check(&d, None);
    assert_eq!(
        (report.images, report.masks, report.problems.len()),
        (4, 4, 0),
        "{report:?}"
    );
}

#[test]
fn bad_drivestudio_input_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    drivestudio_fixture(root, false);
    let e = load(root, None).unwrap_err().to_string();
    assert!(
        e.contains("smpl.pkl") && e.contains("1.smpl.global_orient") && e.contains("[F, 1, 3, 3]"),
        "{e}"
    );
    drivestudio_fixture(root, true);
    std::fs::write(
        root.join("ego_pose/001.txt"),
        "1 0 0 0\n0 2 0 0\n0 0 1 0\n0 0 0 1\n",
    )
    .unwrap();
    let e = load(root, None).unwrap_err().to_string();
    assert!(e.contains("ego_pose/001.txt") && e.contains("rigid"), "{e}");
    drivestudio_fixture(root, true);
    std::fs::write(root.join("intrinsics/3.txt"), "90 90 16\n").unwrap();
    let e = load(root, None).unwrap_err().to_string();
    assert!(
        e.contains("intrinsics/3.txt") && e.contains("fx fy cx cy k1 k2 p1 p2 k3"),
        "{e}"
    );
    drivestudio_fixture(root, true);
    std::fs::write(root.join("instances/frame_instances.json"), r#"{"0": [7]}"#).unwrap();
    let e = load(root, None).unwrap_err().to_string();
    assert!(
        e.contains("frame_instances.json") && e.contains("instance 7"),
        "{e}"
    );
}

#[test]
fn rotation_matrices_convert_to_axis_angle_everywhere() {
    use splatzoo_datasets::formats::axis_angle_matrix;
    use splatzoo_datasets::formats::drivestudio::matrix_axis_angle;
    let mut rng = splatzoo_datasets::synth::rng::Rng(4);
    for k in 0..200 {
        let angle = match k {
            0 => 0.0,
            1 => std::f64::consts::PI,
            2 => std::f64::consts::PI - 1e-6,
            _ => rng.range(0.0, std::f64::consts::PI),
        };
        let axis = [rng.normal(), rng.normal(), rng.normal()];
        let n = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
        let v = axis.map(|a| a / n * angle);
        let m = axis_angle_matrix(v);
        let back = axis_angle_matrix(matrix_axis_angle(&m));
        for i in 0..3 {
            for j in 0..3 {
                assert!(
                    (m[i][j] - back[i][j]).abs() < 1e-6,
                    "angle {angle}: {m:?} vs {back:?}"
                );
            }
        }
    }
}

/// The generator's export arrives in the same types, with its people's true poses.
#[test]
fn synthetic_exports_load_as_datasets_with_pose_tracks() {
    let dir = tempfile::tempdir().unwrap();
    let config = splatzoo_datasets::synth::SceneConfig {
        width: 24,
        height: 24,
        frames: Some(3),
        ..splatzoo_datasets::synth::SceneConfig::new(splatzoo_datasets::synth::Preset::Monocular, 5)
    };
    let scene = config.build(&burn::tensor::Device::flex());
    splatzoo_datasets::synth::export::write_scene(&scene, dir.path(), &[0, 1, 2], |_| {}).unwrap();
    let d = load(dir.path(), None).unwrap();
    assert_eq!(d.format, Format::Synthetic);
    assert_eq!(d.frame_count, 3);
    assert_eq!(d.frame_times, vec![0.0, 0.5, 1.0]);
    assert!(d.views.iter().all(|v| v.other_masks.contains_key("coarse")));
    assert_eq!(d.people.len(), 2, "truth and prior of one person");
    let truth = d.people.iter().find(|p| p.person == "person_00").unwrap();
    let f2 = truth.frames[2].as_ref().unwrap();
    let pose = scene.people[0].motion.pose(2);
    assert!(close(f2.global_orient[1], pose[1]) && close(f2.body_pose[5], pose[8]));
    assert!(close(
        f2.transl[0],
        scene.people[0].motion.translation(2)[0]
    ));
    let report = check(&d, None);
    assert_eq!(report.problems.len(), 0, "{report:?}");
    assert!(report.masks > 0);
}
