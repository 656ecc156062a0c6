//! Dataset loaders on small fixtures written here in each format's exact layout (pickles,
//! joblib dumps and numpy object files through `splatzoo_models::pickle::Writer`, which Python's
//! own readers accept), each fixture's doc naming the original script whose output it copies:
//! every convention conversion, and bad input named by file, field and expected shape. The file
//! writers are in [`crate::fixtures`]; the awkward parts of the real releases have their own
//! tests in [`crate::real_layouts`], which reuses these fixtures.

use crate::fixtures::{
    close, ghg_fixture, write_mask, write_matrix, write_npy_f64, write_npy_u8, write_npz, write_rgb,
};
use splatzoo_datasets::formats::check::check;
use splatzoo_datasets::formats::zju::parameter_index;
use splatzoo_datasets::formats::{Format, MaskConvention, detect, load};
use splatzoo_models::pickle::{Writer, npy_object_bytes};
use std::path::Path;

fn rot_y(angle: f64) -> [[f64; 3]; 3] {
    let (s, c) = angle.sin_cos();
    [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]
}

fn rot_z(angle: f64) -> [[f64; 3]; 3] {
    let (s, c) = angle.sin_cos();
    [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
}

/// A NeuMan scene as its preprocessing leaves it (`preprocess/gen_run.py`): a COLMAP text model
/// (`sparse/`), undistorted `images/`, `segmentations/<name>` plus the `<name>.png` copy that
/// NeuMan's detectron2 `demo/demo.py` also writes (0 = person, 255 = background), a joblib
/// `smpl_output_optimized.pkl` and `alignments.npy` (`export_alignment.py`), read as
/// `data_io/neuman_helper.py` reads them. 3 frames (listed out of order), frame 2 without an
/// alignment.
pub(crate) fn neuman_fixture(root: &Path, nan_pose: bool) {
    let sparse = root.join("sparse");
    std::fs::create_dir_all(&sparse).unwrap();
    std::fs::write(
        sparse.join("cameras.txt"),
        "# Camera list with one line of data per camera:\n#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n# Number of cameras: 1\n1 PINHOLE 8 6 10 11 4 3\n",
    )
    .unwrap();
    // Image 1 turned 90° about y: q = (cos 45°, 0, sin 45°, 0).
    let h = std::f64::consts::FRAC_1_SQRT_2;
    std::fs::write(
        sparse.join("images.txt"),
        format!(
            "# Image list with two lines of data per image:\n#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n#   POINTS2D[] as (X, Y, POINT3D_ID)\n# Number of images: 3, mean observations per image: 0\n\
             2 1 0 0 0 0 0 2 1 00002.png\n\n1 {h} 0 {h} 0 0.5 0 3 1 00001.png\n\n3 1 0 0 0 0 0 1 1 00000.png\n\n"
        ),
    )
    .unwrap();
    std::fs::write(
        sparse.join("points3D.txt"),
        "# 3D point list with one line of data per point:\n1 0.5 1 2 255 0 51 0.1 1 0\n2 0 0 4 0 255 0 0.2\n",
    )
    .unwrap();
    for k in 0..3 {
        write_rgb(&root.join(format!("images/0000{k}.png")), 8, 6);
        for name in [format!("0000{k}.png"), format!("0000{k}.png.png")] {
            write_mask(&root.join("segmentations").join(name), 8, 6, 0, 255);
        }
    }
    let mut w = Writer::new(true);
    w.begin_dict().int(1).begin_dict().str("pose").begin_list();
    for k in 0..3 {
        let mut pose = vec![0.0; 72];
        pose[0] = 0.1 * k as f64;
        pose[2] = -0.2;
        if nan_pose && k == 1 {
            pose[40] = f64::NAN;
        }
        w.array(&[72], &pose, false);
    }
    w.end_list().str("betas").begin_list();
    for k in 0..3 {
        w.array(&[10], &[0.5 * k as f64; 10], false);
    }
    w.end_list().end_dict().end_dict();
    std::fs::write(root.join("smpl_output_optimized.pkl"), w.finish()).unwrap();
    // A = [(s R)ᵀ; t] with s = 1.5, R = 30° about z, t = (1, 2, 3), for frames 0 and 1.
    let (s, r) = (1.5, rot_z(std::f64::consts::FRAC_PI_6));
    // Row i of A's 3×3 block is column i of s R.
    let mut a: Vec<f64> = (0..9).map(|k| s * r[k % 3][k / 3]).collect();
    a.extend([1.0, 2.0, 3.0]);
    let mut w = Writer::new(false);
    w.begin_object_scalar().begin_dict();
    for name in ["00000.png", "00001.png"] {
        w.str(name).array(&[4, 3], &a, true);
    }
    w.end_dict().end_object_scalar();
    std::fs::write(root.join("alignments.npy"), npy_object_bytes(&w.finish())).unwrap();
    std::fs::write(root.join("test_split.txt"), "00001.png\n").unwrap();
}

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

/// One `(1, n)` float64 array per key.
fn write_params(path: &Path, poses: &[f64], rh: [f64; 3], th: [f64; 3], shapes: &[f64]) {
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    let mut w = Writer::new(false);
    w.begin_object_scalar().begin_dict();
    w.str("poses").array(&[1, poses.len()], poses, true);
    w.str("Rh").array(&[1, 3], &rh, true);
    w.str("Th").array(&[1, 3], &th, true);
    w.str("shapes").array(&[1, shapes.len()], shapes, true);
    w.end_dict().end_object_scalar();
    std::fs::write(path, npy_object_bytes(&w.finish())).unwrap();
}

/// `annots.npy` as neuralbody's `tools/custom/get_annots.py` writes it (`cams` lists, `ims`
/// dicts holding the path list) for two cameras and two frames with image paths from
/// `path(frame, camera)`.
fn write_annots(root: &Path, k_shape: [usize; 2], path: impl Fn(usize, usize) -> String) {
    write_annots_with(root, k_shape, path, false);
}

/// [`write_annots`], with each frame's paths as a numpy string array (`<U…`, the script without
/// its `.tolist()`) where `numpy_strings`.
pub(crate) fn write_annots_with(
    root: &Path,
    k_shape: [usize; 2],
    path: impl Fn(usize, usize) -> String,
    numpy_strings: bool,
) {
    let mut w = Writer::new(false);
    w.begin_object_scalar()
        .begin_dict()
        .str("cams")
        .begin_dict();
    w.str("K").begin_list();
    for c in 0..2 {
        let f = 500.0 + c as f64;
        let k = [f, 0.0, 4.0, 0.0, f + 2.0, 3.0, 0.0, 0.0, 1.0];
        let n = k_shape[0] * k_shape[1];
        w.array(
            &k_shape,
            &k[..n.min(9)]
                .iter()
                .chain(std::iter::repeat(&0.0))
                .take(n)
                .copied()
                .collect::<Vec<_>>(),
            true,
        );
    }
    w.end_list().str("D").begin_list();
    for _ in 0..2 {
        w.array(&[5, 1], &[0.1, -0.05, 0.001, 0.002, 0.01], true);
    }
    w.end_list().str("R").begin_list();
    for c in 0..2 {
        let r = rot_y(0.3 * c as f64);
        w.array(&[3, 3], &r.concat(), true);
    }
    w.end_list().str("T").begin_list();
    for c in 0..2 {
        w.array(&[3, 1], &[100.0 * c as f64, -250.0, 3000.0], true);
    }
    w.end_list().end_dict().str("ims").begin_list();
    for f in 0..2 {
        let paths: Vec<String> = (0..2).map(|c| path(f, c)).collect();
        w.begin_dict().str("ims");
        if numpy_strings {
            let paths: Vec<&str> = paths.iter().map(String::as_str).collect();
            w.string_array(&[paths.len()], &paths);
        } else {
            w.begin_list();
            for p in &paths {
                w.str(p);
            }
            w.end_list();
        }
        w.end_dict();
    }
    w.end_list().end_dict().end_object_scalar();
    std::fs::write(root.join("annots.npy"), npy_object_bytes(&w.finish())).unwrap();
}

/// ZJU-MoCap's original layout (`CoreView_*`, as neuralbody's `lib/datasets/light_stage/`
/// readers take it): `annots.npy`, `Camera_B*/` images, `mask_cihp/` masks (non-zero = person),
/// `params/{i}.npy` EasyMocap parameters.
pub(crate) fn zju_fixture(root: &Path) {
    write_annots(root, [3, 3], |f, c| format!("Camera_B{}/{f:06}.jpg", c + 1));
    for f in 0..2 {
        for c in 0..2 {
            write_rgb(&root.join(format!("Camera_B{}/{f:06}.jpg", c + 1)), 10, 8);
            write_mask(
                &root.join(format!("mask_cihp/Camera_B{}/{f:06}.png", c + 1)),
                10,
                8,
                1,
                0,
            );
        }
        let mut poses = vec![0.0; 72];
        poses[3] = 0.2 + f as f64;
        write_params(
            &root.join(format!("params/{f}.npy")),
            &poses,
            [0.0, std::f64::consts::FRAC_PI_2, 0.0],
            [0.1, 0.2, 0.3 + f as f64],
            &[0.25; 10],
        );
    }
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

/// PeopleSnapshot as InstantAvatar's `scripts/peoplesnapshot/preprocess_PeopleSnapshot.py`
/// writes it: `cameras.npz` (float64 K and world-to-camera, int64 0-d height and width),
/// `images/image_%04d.png`, `masks/mask_%04d.npy` (uint8 0/1), `poses.npz` with the release's
/// `reconstructed_poses.hdf5` arrays copied as float32, **one pose row more than frames**, as the
/// release has. 6 frames of 6×8 in a folder named like a subject.
pub(crate) fn snapshot_fixture(root: &Path, nan: bool) {
    let k = [500.0, 0.0, 2.5, 0.0, 510.0, 3.5, 0.0, 0.0, 1.0];
    let e: Vec<f64> = (0..16)
        .map(|i| if i % 5 == 0 { 1.0 } else { 0.0 })
        .collect();
    write_npz(
        &root.join("cameras.npz"),
        &[
            ("intrinsic", &[3, 3], &k),
            ("extrinsic", &[4, 4], &e),
            ("height", &[], &[8.0]),
            ("width", &[], &[6.0]),
        ],
        false,
    );
    let n = 6;
    for f in 0..n {
        write_rgb(&root.join(format!("images/image_{f:04}.png")), 6, 8);
        let mask: Vec<u8> = (0..48).map(|i| (i % 6 < 3) as u8).collect();
        write_npy_u8(&root.join(format!("masks/mask_{f:04}.npy")), 8, 6, &mask);
    }
    let poses = n + 1;
    let mut thetas: Vec<f64> = (0..poses * 72).map(|i| (i % 72) as f64 * 0.001).collect();
    thetas[0] = std::f64::consts::PI;
    if nan {
        thetas[72 * 2 + 10] = f64::NAN;
    }
    let transl: Vec<f64> = (0..poses)
        .flat_map(|f| [0.1, 0.2, 5.0 + f as f64])
        .collect();
    write_npz(
        &root.join("poses.npz"),
        &[
            ("thetas", &[poses as u64, 72], &thetas),
            ("transl", &[poses as u64, 3], &transl),
            ("betas", &[10], &[0.3; 10]),
        ],
        true,
    );
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

fn pose_z(angle: f64, t: [f64; 3]) -> [[f64; 4]; 4] {
    let r = rot_z(angle);
    [
        [r[0][0], r[0][1], r[0][2], t[0]],
        [r[1][0], r[1][1], r[1][2], t[1]],
        [r[2][0], r[2][1], r[2][2], t[2]],
        [0.0, 0.0, 0.0, 1.0],
    ]
}

fn mul(a: [[f64; 4]; 4], b: [[f64; 4]; 4]) -> [[f64; 4]; 4] {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..4).map(|k| a[i][k] * b[k][j]).sum()))
}

/// A processed Waymo scene as drivestudio's `datasets/waymo/waymo_preprocess.py` writes it
/// (`ego_pose/`, `extrinsics/`, `intrinsics/` by `np.savetxt`, `images/{t:03}_{cam}.jpg`,
/// `dynamic_masks/{all,human,vehicle}/` for every image, `instances/*.json`) plus the sky masks
/// and `humanpose/smpl.pkl` of its later steps, as `waymo_sourceloader.py` reads them. Two
/// frames, cameras 0 and 3; the ego turned 30° about z at (10, 5, 0), then 2 m ahead.
pub(crate) fn drivestudio_fixture(root: &Path, smpl_shape_ok: bool) {
    let heading = std::f64::consts::FRAC_PI_6;
    let ego = [
        pose_z(heading, [10.0, 5.0, 0.0]),
        pose_z(
            heading,
            [10.0 + 2.0 * heading.cos(), 5.0 + 2.0 * heading.sin(), 0.0],
        ),
    ];
    for (t, e) in ego.iter().enumerate() {
        write_matrix(&root.join(format!("ego_pose/{t:03}.txt")), *e);
    }
    write_matrix(&root.join("extrinsics/0.txt"), pose_z(0.0, [1.5, 0.0, 1.6]));
    write_matrix(
        &root.join("extrinsics/3.txt"),
        pose_z(std::f64::consts::FRAC_PI_2, [1.0, 0.9, 1.6]),
    );
    std::fs::create_dir_all(root.join("intrinsics")).unwrap();
    std::fs::write(
        root.join("intrinsics/0.txt"),
        "100\n101\n16\n12\n0.01\n0\n0\n0\n0\n",
    )
    .unwrap();
    std::fs::write(root.join("intrinsics/3.txt"), "90 90 16 12 0 0 0 0 0\n").unwrap();
    for t in 0..2 {
        for cam in [0, 3] {
            write_rgb(&root.join(format!("images/{t:03}_{cam}.jpg")), 32, 24);
            for class in ["all", "human", "vehicle"] {
                write_mask(
                    &root.join(format!("dynamic_masks/{class}/{t:03}_{cam}.png")),
                    32,
                    24,
                    if class == "vehicle" { 0 } else { 255 },
                    0,
                );
            }
            write_mask(
                &root.join(format!("sky_masks/{t:03}_{cam}.png")),
                32,
                24,
                0,
                255,
            );
        }
    }
    // A pedestrian 8 m ahead of the first ego pose, 0.9 m up (its box centre), in both frames.
    let object = |t: usize| mul(ego[0], pose_z(0.2 * t as f64, [8.0, 0.0, 0.9]));
    let rows = |m: [[f64; 4]; 4]| serde_json::json!(m.to_vec());
    let info = serde_json::json!({
        "0": {"id": "abc", "class_name": "Vehicle", "frame_annotations": {
            "frame_idx": [0], "obj_to_world": [rows(mul(ego[0], pose_z(0.0, [20.0, 3.0, 0.8])))], "box_size": [[4.5, 1.9, 1.6]]}},
        "1": {"id": "def", "class_name": "Pedestrian", "frame_annotations": {
            "frame_idx": [0, 1], "obj_to_world": [rows(object(0)), rows(object(1))], "box_size": [[0.6, 0.6, 1.8], [0.6, 0.7, 1.8]]}},
    });
    std::fs::create_dir_all(root.join("instances")).unwrap();
    std::fs::write(root.join("instances/instances_info.json"), info.to_string()).unwrap();
    std::fs::write(
        root.join("instances/frame_instances.json"),
        r#"{"0": [0, 1], "1": [1]}"#,
    )
    .unwrap();
    // SMPL: identity orientation in camera 0's frame; joint 1 turned 0.5 rad about x; frame 1
    // not valid.
    let identity = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
    let (s, c) = 0.5f64.sin_cos();
    let turned = [1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c];
    let mut body = Vec::new();
    for _ in 0..2 {
        body.extend(turned);
        for _ in 1..23 {
            body.extend(identity);
        }
    }
    let mut w = Writer::new(true);
    w.begin_dict().int(1).begin_dict().str("smpl").begin_dict();
    let orient_shape: &[usize] = if smpl_shape_ok {
        &[2, 1, 3, 3]
    } else {
        &[2, 9]
    };
    w.str("global_orient").torch_tensor(
        orient_shape,
        &[identity, identity].concat(),
        "FloatStorage",
    );
    w.str("body_pose")
        .torch_tensor(&[2, 23, 3, 3], &body, "FloatStorage");
    w.str("betas")
        .torch_tensor(&[2, 10], &[0.4; 20], "FloatStorage");
    w.end_dict();
    w.str("selected_cam_idx")
        .torch_tensor(&[2], &[0.0, -1.0], "LongStorage");
    w.str("valid_mask")
        .torch_tensor(&[2], &[1.0, 0.0], "BoolStorage");
    w.end_dict().end_dict();
    std::fs::create_dir_all(root.join("humanpose")).unwrap();
    std::fs::write(root.join("humanpose/smpl.pkl"), w.finish()).unwrap();
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
