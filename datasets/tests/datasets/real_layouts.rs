//! The loaders on what the original preprocessing scripts really write, awkward parts included,
//! one test per finding: PeopleSnapshot's extra pose row (InstantAvatar's
//! `preprocess_PeopleSnapshot.py` copies the release's `reconstructed_poses.hdf5` unchanged),
//! drivestudio's empty dynamic masks (`waymo_preprocess.py` writes one per image), GHG's SMPL-X
//! fits beside the split folders and its integer pixel centres (`render_image.py`, its taichi
//! renderer's `geometry.py`), NeuMan's `segmentations/<name>.npy` (`neuman_helper.py`) and
//! ZJU-MoCap `annots.npy` files whose paths are numpy string arrays (neuralbody's
//! `get_annots.py` without `.tolist()`). The fixtures are [`splatzoo_datasets::fixtures`];
//! `inspect-dataset` is run on each to see warnings kept apart from problems.

use crate::fixtures::close;
use splatzoo_datasets::fixtures::{
    drivestudio_fixture, ghg_extrinsic, ghg_fit, ghg_subject, neuman_fixture, snapshot_fixture,
    write_annots_with, write_mask, write_npy_u8, write_npz, write_rgb, zju_fixture,
};
use splatzoo_datasets::formats::check::check;
use splatzoo_datasets::formats::{Format, load};
use splatzoo_models::pickle::{Writer, npy_object_bytes};
use std::path::Path;

/// Runs `inspect-dataset` on `root`: whether it exited 0, and what it printed.
fn inspect(root: &Path) -> (bool, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_inspect-dataset"))
        .arg(root)
        .output()
        .unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
    )
}

/// The release's 7 pose rows for 6 frames load as 6 frames, row i for frame i; the extra row is
/// a warning in the dataset, the check and the inspect output, not a problem.
#[test]
fn people_snapshot_extra_pose_rows_load_as_the_first_n_with_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("male-3-casual");
    snapshot_fixture(&root, false);
    let d = load(&root, None).unwrap();
    assert_eq!((d.frame_count, d.people[0].frames.len()), (6, 6));
    for (f, frame) in d.people[0].frames.iter().enumerate() {
        // transl z = 5 + row: row f for frame f (row 6, z = 11, is the unused extra).
        let frame = frame.as_ref().unwrap();
        assert!(close(frame.transl[2], 5.0 + f as f64), "frame {f}");
    }
    assert_eq!(d.warnings.len(), 1, "{:?}", d.warnings);
    let (file, fact) = &d.warnings[0];
    assert!(file.ends_with("poses.npz"), "{file}");
    assert!(
        fact.contains("`thetas` has 7 rows")
            && fact.contains("for 6 frames")
            && fact.contains("first 6 are used"),
        "{fact}"
    );
    let report = check(&d, None);
    assert!(report.problems.is_empty(), "{report:?}");
    assert_eq!(report.warnings, d.warnings);
    let (ok, text) = inspect(&root);
    assert!(ok, "warnings alone exit 0: {text}");
    for expected in [
        "person male-3-casual: valid in 6 of 6 frames",
        "warning: ",
        "first 6 are used",
        "no problems found (1 warning)",
    ] {
        assert!(text.contains(expected), "{expected:?} in {text}");
    }
    // Fewer rows than frames is still refused, naming the shape it needs.
    let thetas = vec![0.0; 5 * 72];
    let transl = vec![0.0; 5 * 3];
    write_npz(
        &root.join("poses.npz"),
        &[
            ("thetas", &[5, 72], &thetas),
            ("transl", &[5, 3], &transl),
            ("betas", &[10], &[0.0; 10]),
        ],
        true,
    );
    let e = load(&root, None).unwrap_err().to_string();
    assert!(
        e.contains("thetas") && e.contains("[5, 72]") && e.contains("(at least 6, 72)"),
        "{e}"
    );
}

/// A human dynamic mask that marks no one (no pedestrian moving in that frame) is valid
/// drivestudio data: a warning per mask, no problem, exit 0. The same empty mask in NeuMan,
/// whose helper asserts a person pixel, stays a problem.
#[test]
fn drivestudio_empty_dynamic_masks_warn_and_are_not_problems() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("023");
    drivestudio_fixture(&root, true);
    // Frame 1: nobody moves; waymo_preprocess.py still writes every class's mask, all zero.
    for cam in [0, 3] {
        for class in ["all", "human", "vehicle"] {
            let path = root.join(format!("dynamic_masks/{class}/001_{cam}.png"));
            write_mask(&path, 32, 24, 0, 0);
        }
    }
    let d = load(&root, None).unwrap();
    assert_eq!(d.format, Format::Drivestudio);
    assert!(
        d.views.iter().all(|v| v.mask.is_some()),
        "a mask for every image"
    );
    let report = check(&d, None);
    assert!(report.problems.is_empty(), "{report:?}");
    let mut warned: Vec<&str> = report.warnings.iter().map(|(f, _)| f.as_str()).collect();
    warned.sort_unstable();
    assert_eq!(warned.len(), 2, "{report:?}");
    assert!(
        warned[0].ends_with("dynamic_masks/human/001_0.png")
            && warned[1].ends_with("dynamic_masks/human/001_3.png"),
        "{warned:?}"
    );
    assert!(
        report
            .warnings
            .iter()
            .all(|(_, fact)| fact.contains("marks no person pixel")),
        "{report:?}"
    );
    let (ok, text) = inspect(&root);
    assert!(ok, "{text}");
    assert!(
        text.contains("warning: ") && text.contains("no problems found (2 warnings)"),
        "{text}"
    );

    let neuman = dir.path().join("bike");
    neuman_fixture(&neuman, false);
    write_mask(&neuman.join("segmentations/00001.png"), 8, 6, 255, 255);
    let report = check(&load(&neuman, None).unwrap(), None);
    assert!(
        report
            .problems
            .iter()
            .any(|(f, p)| f.ends_with("segmentations/00001.png") && p.contains("no person")),
        "{report:?}"
    );
    let (ok, text) = inspect(&neuman);
    assert!(!ok && text.contains("first problem"), "{text}");
}

/// GHG keeps the SMPL-X fits at the THuman root (`THuman2.0_smplx/<subject>/`), beside the
/// split folders: found there; a subject without one loads with no valid frame and a warning
/// naming where it was looked for; the split-local `smplx/` and `transform/` still work.
#[test]
fn ghg_reads_fits_beside_the_splits_and_warns_for_a_subject_without_one() {
    let dir = tempfile::tempdir().unwrap();
    let thuman = dir.path().join("THuman");
    let split = thuman.join("val");
    ghg_subject(&split, "0004", &[0, 6, 11], 5);
    ghg_fit(&thuman, "0004");
    ghg_subject(&split, "0005", &[0], 2);
    let d = load(&split, None).unwrap();
    assert_eq!(d.frame_count, 2);
    assert_eq!(d.views.len(), 3 * 5 + 2, "the _hr renders are not views");
    let track = |name: &str| d.people.iter().find(|p| p.person == name).unwrap();
    let fitted = track("0004").frames[0].as_ref().expect("found at the root");
    assert_eq!(fitted.extra["right_hand_pose"].len(), 12);
    assert!(close(fitted.world_from_smpl.scale, 0.9));
    assert!(track("0005").frames.iter().all(Option::is_none));
    assert_eq!(d.warnings.len(), 1, "{:?}", d.warnings);
    let (file, fact) = &d.warnings[0];
    assert!(
        file.ends_with("THuman/THuman2.0_smplx/0005/smplx_param.pkl"),
        "{file}"
    );
    assert!(
        fact.contains("subject 0005 has no SMPL-X fit")
            && fact.contains("val/smplx/0005/smplx_param.pkl"),
        "{fact}"
    );
    let report = check(&d, None);
    assert!(report.problems.is_empty(), "{report:?}");
    let (ok, text) = inspect(&split);
    assert!(ok, "{text}");
    for expected in [
        "person 0004: valid in 1 of 2 frames",
        "person 0005: valid in 0 of 2 frames",
        "no SMPL-X fit",
        "no problems found (1 warning)",
    ] {
        assert!(text.contains(expected), "{expected:?} in {text}");
    }
    // The split-local layout: smplx/<subject>/ and transform/<subject>_transform.npy.
    let local = split.join("smplx/0005/smplx_param.pkl");
    std::fs::create_dir_all(local.parent().unwrap()).unwrap();
    std::fs::copy(thuman.join("THuman2.0_smplx/0004/smplx_param.pkl"), &local).unwrap();
    let d = load(&split, None).unwrap();
    assert!(track_is_none(&d, "0005"), "no transform yet");
    assert!(
        d.warnings[0]
            .0
            .ends_with("val/transform/0005_transform.npy")
            && d.warnings[0]
                .1
                .contains("THuman2.0_Release/0005/0005_transform.npy"),
        "{:?}",
        d.warnings
    );
    std::fs::create_dir_all(split.join("transform")).unwrap();
    std::fs::copy(
        thuman.join("THuman2.0_Release/0004/0004_transform.npy"),
        split.join("transform/0005_transform.npy"),
    )
    .unwrap();
    let d = load(&split, None).unwrap();
    assert!(!track_is_none(&d, "0005") && d.warnings.is_empty());
}

fn track_is_none(d: &splatzoo_datasets::formats::Dataset, name: &str) -> bool {
    let track = d.people.iter().find(|p| p.person == name).unwrap();
    track.frames.iter().all(Option::is_none)
}

/// GHG's taichi renderer marks the integer pixel X where X lies in the triangle projected by K
/// (`geometry.py`, `render_triangle`; `transform.py`, `Camera.uncook`). Our convention samples
/// pixel X at its centre X + 0.5, so with K's centre + 0.5 a triangle covers exactly the pixels
/// the renderer drew; with K unchanged it would not.
#[test]
fn ghg_cameras_cover_the_pixels_its_renderer_drew() {
    let dir = tempfile::tempdir().unwrap();
    let split = dir.path().join("THuman/val");
    ghg_subject(&split, "0004", &[0], 1);
    let d = load(&split, None).unwrap();
    let camera = d.views[0].camera;
    assert_eq!(d.views[0].camera_name, "000/0");
    assert!(close(camera.cx as f64, 8.5) && close(camera.cy as f64, 8.9));
    // The renderer's projection, from the fixture's own f64 K and [R | t].
    let (fx, k_cx, k_cy) = (12.8, 8.0, 8.4);
    let e = ghg_extrinsic([0.0, 1.128, 2.0], [0.0, 0.85, 0.0]);
    let ghg = |p: [f64; 3]| {
        let x: Vec<f64> = (0..3)
            .map(|i| (0..3).map(|j| e[4 * i + j] * p[j]).sum::<f64>() + e[4 * i + 3])
            .collect();
        [fx * x[0] / x[2] + k_cx, fx * x[1] / x[2] + k_cy]
    };
    let ours = |p: [f64; 3]| {
        let m = camera.world_to_camera;
        let x: Vec<f64> = (0..3)
            .map(|i| (0..3).map(|j| m[i][j] as f64 * p[j]).sum::<f64>() + m[i][3] as f64)
            .collect();
        [
            camera.fx as f64 * x[0] / x[2] + camera.cx as f64,
            camera.fy as f64 * x[1] / x[2] + camera.cy as f64,
        ]
    };
    let triangle = [[-0.3, 0.6, 0.05], [0.35, 0.7, -0.1], [0.0, 1.2, 0.0]];
    let inside = |t: [[f64; 2]; 3], p: [f64; 2]| {
        let side = |a: [f64; 2], b: [f64; 2]| {
            (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
        };
        let s = [side(t[0], t[1]), side(t[1], t[2]), side(t[2], t[0])];
        s.iter().all(|&v| v >= 0.0) || s.iter().all(|&v| v <= 0.0)
    };
    let drawn = triangle.map(ghg);
    let seen = triangle.map(ours);
    let (mut covered, mut unshifted_differs) = (0, false);
    for x in 0..16 {
        for y in 0..16 {
            let (xf, yf) = (x as f64, y as f64);
            let by_renderer = inside(drawn, [xf, yf]);
            assert_eq!(
                by_renderer,
                inside(seen, [xf + 0.5, yf + 0.5]),
                "pixel ({x}, {y})"
            );
            covered += by_renderer as usize;
            unshifted_differs |= by_renderer != inside(drawn, [xf + 0.5, yf + 0.5]);
        }
    }
    assert!(covered > 3, "{covered} pixels");
    assert!(unshifted_differs, "half a pixel matters for this triangle");
}

/// NeuMan's helper prefers `segmentations/<name>.npy` (e.g. `00001.png.npy`) to the PNG: used
/// where present, read with the same convention (0 = person, 255 = background), and an npy
/// marking no person is a problem, as the helper asserts one.
#[test]
fn neuman_segmentation_npy_is_preferred_and_read_zero_is_person() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    neuman_fixture(root, false);
    // Person (0) in the right half; the PNG's person is the top-left block.
    let values: Vec<u8> = (0..48).map(|i| if i % 8 >= 4 { 0 } else { 255 }).collect();
    let npy = root.join("segmentations/00001.png.npy");
    write_npy_u8(&npy, 6, 8, &values);
    let d = load(root, None).unwrap();
    assert_eq!(d.views[1].mask.as_deref(), Some(npy.as_path()));
    assert_eq!(
        d.views[0].mask.as_deref(),
        Some(root.join("segmentations/00000.png").as_path()),
        "the PNG where no npy exists"
    );
    let (w, h, person) = d.views[1].read_mask().unwrap().unwrap();
    assert_eq!((w, h), (8, 6));
    assert!(
        person.iter().enumerate().all(|(i, &p)| p == (i % 8 >= 4)),
        "{person:?}"
    );
    let report = check(&d, None);
    assert_eq!((report.masks, report.problems.len()), (3, 0), "{report:?}");
    write_npy_u8(&npy, 6, 8, &[255; 48]);
    let report = check(&load(root, None).unwrap(), None);
    assert!(
        report
            .problems
            .iter()
            .any(|(f, p)| f.ends_with("00001.png.npy") && p.contains("no person")),
        "{report:?}"
    );
}

/// `annots.npy` whose `ims` entries are numpy string arrays loads exactly as the list form, in
/// the original and the refined layouts; a numeric array there is named.
#[test]
fn zju_annots_with_numpy_string_arrays_load_like_lists() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("CoreView_377");
    std::fs::create_dir_all(&root).unwrap();
    zju_fixture(&root);
    let lists = load(&root, None).unwrap();
    write_annots_with(
        &root,
        [3, 3],
        |f, c| format!("Camera_B{}/{f:06}.jpg", c + 1),
        true,
    );
    let arrays = load(&root, None).unwrap();
    assert_eq!(arrays.views, lists.views);
    assert_eq!(arrays.people, lists.people);
    assert_eq!(arrays.views.len(), 4);

    let refined = dir.path().join("my_377");
    std::fs::create_dir_all(&refined).unwrap();
    write_annots_with(
        &refined,
        [3, 3],
        |f, c| format!("images/{c:02}/{f:06}.jpg"),
        true,
    );
    for f in 0..2 {
        for c in 0..2 {
            write_rgb(&refined.join(format!("images/{c:02}/{f:06}.jpg")), 10, 8);
            write_mask(
                &refined.join(format!("mask/{c:02}/{f:06}.png")),
                10,
                8,
                255,
                0,
            );
        }
    }
    let d = load(&refined, Some(Format::Zju)).unwrap();
    assert_eq!(d.camera_names(), ["00", "01"], "refined layout recognised");
    assert_eq!(
        d.views[1].mask.as_deref(),
        Some(refined.join("mask/01/000000.png").as_path())
    );

    // One camera, one frame whose `ims` is a float array.
    let mut w = Writer::new(false);
    w.begin_object_scalar()
        .begin_dict()
        .str("cams")
        .begin_dict();
    for (key, shape, values) in [
        (
            "K",
            [3, 3],
            vec![500.0, 0.0, 4.0, 0.0, 500.0, 3.0, 0.0, 0.0, 1.0],
        ),
        ("D", [5, 1], vec![0.0; 5]),
        (
            "R",
            [3, 3],
            vec![1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        ),
        ("T", [3, 1], vec![0.0; 3]),
    ] {
        w.str(key)
            .begin_list()
            .array(&shape, &values, true)
            .end_list();
    }
    w.end_dict().str("ims").begin_list().begin_dict().str("ims");
    w.array(&[2], &[1.0, 2.0], true).end_dict().end_list();
    w.end_dict().end_object_scalar();
    std::fs::write(root.join("annots.npy"), npy_object_bytes(&w.finish())).unwrap();
    let e = load(&root, None).unwrap_err().to_string();
    assert!(
        e.contains("annots.npy")
            && e.contains("ims[0].ims")
            && e.contains("list or numpy array of image paths"),
        "{e}"
    );
}
