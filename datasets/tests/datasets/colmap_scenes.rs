//! COLMAP scene folders (text and binary models, `images_N/` downscales, detection beside
//! NeuMan's COLMAP text model) and nerfstudio's `ply_file_path` points, on the library's
//! fixtures ([`splatzoo_datasets::fixtures::colmap_fixture`], `nerfstudio_fixture`): the two
//! model forms read to the same dataset, cameras project as written, and corrupt or truncated
//! files are errors naming the file and what was being read, never panics.

use crate::fixtures::close;
use splatzoo_datasets::fixtures::{
    COLMAP_IMAGES, colmap_fixture, nerfstudio_fixture, neuman_fixture, ring_points, ring_view,
    write_mask, write_point_ply, write_rgb,
};
use splatzoo_datasets::formats::check::check;
use splatzoo_datasets::formats::colmap::read_model;
use splatzoo_datasets::formats::{
    Format, LoadOptions, MaskConvention, ViewRecord, detect, load, load_with,
};
use splatzoo_datasets::point_ply::read_points;
use std::path::Path;

/// Where `view`'s camera sees the world point `p`.
fn pixel(view: &ViewRecord, p: [f64; 3]) -> (f64, f64) {
    let c = view.camera;
    let m = c.world_to_camera;
    let x: Vec<f64> = (0..3)
        .map(|i| (0..3).map(|j| m[i][j] as f64 * p[j]).sum::<f64>() + m[i][3] as f64)
        .collect();
    (
        c.fx as f64 * x[0] / x[2] + c.cx as f64,
        c.fy as f64 * x[1] / x[2] + c.cy as f64,
    )
}

fn load_error(root: &Path) -> String {
    load(root, None).unwrap_err().to_string()
}

#[test]
fn text_and_binary_colmap_models_load_to_the_same_dataset() {
    let text = tempfile::tempdir().unwrap();
    let binary = tempfile::tempdir().unwrap();
    colmap_fixture(text.path(), false);
    colmap_fixture(binary.path(), true);
    let a = read_model(&text.path().join("sparse/0")).unwrap();
    let b = read_model(&binary.path().join("sparse/0")).unwrap();
    assert!(!a.binary && b.binary);
    assert_eq!(a.cameras, b.cameras);
    assert_eq!(a.images, b.images);
    assert_eq!(a.points, b.points);
    for root in [text.path(), binary.path()] {
        assert_eq!(detect(root), Some(Format::Colmap));
    }
    let a = load(text.path(), None).unwrap();
    let b = load(binary.path(), None).unwrap();
    assert_eq!(a.format, Format::Colmap);
    let names: Vec<&str> = a.views.iter().map(|v| v.camera_name.as_str()).collect();
    assert_eq!(
        names, COLMAP_IMAGES,
        "sorted by name, whatever the file order"
    );
    assert_eq!(
        a.views.iter().map(|v| v.frame).collect::<Vec<_>>(),
        [0, 1, 2, 3, 4, 5]
    );
    assert_eq!((a.frame_count, a.image_downscale), (6, 1));
    assert!(a.people.is_empty() && a.splits.is_empty());
    for (va, vb) in a.views.iter().zip(&b.views) {
        assert_eq!(va.camera, vb.camera);
        assert_eq!(va.distortion, vb.distortion);
        assert_eq!((va.frame, &va.camera_name), (vb.frame, &vb.camera_name));
        assert_eq!(
            va.image.strip_prefix(text.path()).unwrap(),
            vb.image.strip_prefix(binary.path()).unwrap()
        );
        assert_eq!(va.mask, None);
    }
    assert_eq!(a.points, b.points);
    assert_eq!(a.points, ring_points());
    assert_eq!(b.views[5].image, binary.path().join("images/extra/05.png"));
    let report = check(&b, None);
    assert_eq!((report.images, report.problems.len()), (6, 0), "{report:?}");
}

#[test]
fn colmap_cameras_project_as_written() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    colmap_fixture(root, true);
    let d = load(root, None).unwrap();
    // View 0: PINHOLE 20, 21, 12, 8; identity rotation, t = (0, 0, 4): (0.4, −0.2, 1) is at
    // (0.4, −0.2, 5) in the camera, so at (20·0.08 + 12, 21·(−0.04) + 8).
    let v0 = &d.views[0];
    let c = v0.camera;
    assert_eq!(
        (c.fx, c.fy, c.cx, c.cy, c.width, c.height),
        (20.0, 21.0, 12.0, 8.0, 24, 16)
    );
    let (u, v) = pixel(v0, [0.4, -0.2, 1.0]);
    assert!(close(u, 13.6) && close(v, 7.16), "{u} {v}");
    // View 1: SIMPLE_RADIAL (one focal length, k1 = 0), turned 20° about y.
    let v1 = &d.views[1];
    assert_eq!((v1.camera.fx, v1.camera.fy), (18.0, 18.0));
    assert_eq!(v1.distortion.k1, 0.0);
    for (k, view) in d.views.iter().enumerate() {
        // The quaternion gives R_y(θ) back; every camera looks at the origin.
        let (_, r, t) = ring_view(k);
        let m = view.camera.world_to_camera;
        for i in 0..3 {
            assert!((0..3).all(|j| close(m[i][j] as f64, r[i][j])), "{m:?}");
            assert!(close(m[i][3] as f64, t[i]));
        }
        let (u, v) = pixel(view, [0.0; 3]);
        assert!(close(u, 12.0) && close(v, 8.0), "view {k}: {u} {v}");
        // Every point is in every image.
        for (p, _) in ring_points() {
            let (u, v) = pixel(view, p);
            assert!(
                (0.0..24.0).contains(&u) && (0.0..16.0).contains(&v),
                "{p:?} in view {k}"
            );
        }
    }
}

#[test]
fn truncated_or_corrupt_binary_models_are_errors_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    colmap_fixture(root, true);
    let sparse = root.join("sparse/0");
    for file in ["cameras.bin", "images.bin", "points3D.bin"] {
        let path = sparse.join(file);
        let bytes = std::fs::read(&path).unwrap();
        let n = bytes.len();
        for cut in [0, 3, 8, 11, 40, n / 3, n / 2, n - 9, n - 1] {
            std::fs::write(&path, &bytes[..cut]).unwrap();
            let e = load_error(root);
            assert!(
                e.contains(file) && e.contains("truncated"),
                "{file} cut at {cut}: {e}"
            );
        }
        let mut longer = bytes.clone();
        longer.push(7);
        std::fs::write(&path, &longer).unwrap();
        let e = load_error(root);
        assert!(e.contains(file) && e.contains("after the last"), "{e}");
        // A corrupt count is refused before anything is allocated for it.
        let mut corrupt = bytes.clone();
        corrupt[..8].copy_from_slice(&u64::MAX.to_le_bytes());
        std::fs::write(&path, &corrupt).unwrap();
        let e = load_error(root);
        assert!(
            e.contains(file) && e.contains("truncated or corrupt"),
            "{e}"
        );
        std::fs::write(&path, &bytes).unwrap();
    }
    // Cut inside the last image's name (images.bin lists image 1, `00.png`, last).
    let path = sparse.join("images.bin");
    let bytes = std::fs::read(&path).unwrap();
    let at = bytes.windows(7).rposition(|w| w == b"00.png\0").unwrap();
    std::fs::write(&path, &bytes[..at + 2]).unwrap();
    let e = load_error(root);
    assert!(
        e.contains("images.bin") && e.contains("truncated in image 5's name"),
        "{e}"
    );
    assert!(load(root, None).is_err());
}

/// `cameras.bin` with one 24×16 camera of `model`, followed by `params` parameters.
fn cameras_bin(model: i32, params: usize) -> Vec<u8> {
    let mut b = 1u64.to_le_bytes().to_vec();
    b.extend(1i32.to_le_bytes());
    b.extend(model.to_le_bytes());
    b.extend(24u64.to_le_bytes());
    b.extend(16u64.to_le_bytes());
    for _ in 0..params {
        b.extend(10f64.to_le_bytes());
    }
    b
}

#[test]
fn camera_models_not_read_are_refused_by_name_or_id() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    colmap_fixture(root, true);
    let cameras = root.join("sparse/0/cameras.bin");
    std::fs::write(&cameras, cameras_bin(5, 8)).unwrap();
    let e = load_error(root);
    assert!(
        e.contains("cameras.bin") && e.contains("id 5") && e.contains("OPENCV_FISHEYE"),
        "{e}"
    );
    std::fs::write(&cameras, cameras_bin(42, 4)).unwrap();
    let e = load_error(root);
    assert!(e.contains("cameras.bin") && e.contains("id 42"), "{e}");
    // A model read, with the right parameter count, loads (the images' camera 2 is missing now).
    std::fs::write(&cameras, cameras_bin(1, 4)).unwrap();
    let e = load_error(root);
    assert!(e.contains("images.bin") && e.contains("CAMERA_ID 2"), "{e}");

    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    colmap_fixture(root, false);
    let cameras = root.join("sparse/0/cameras.txt");
    std::fs::write(&cameras, "1 FULL_OPENCV 24 16 1 2 3 4 5 6 7 8 9 10 11 12\n").unwrap();
    let e = load_error(root);
    assert!(
        e.contains("cameras.txt") && e.contains("FULL_OPENCV"),
        "{e}"
    );
    // Too few parameters are named, not indexed past.
    std::fs::write(&cameras, "1 PINHOLE 24 16 20 21 12\n").unwrap();
    let e = load_error(root);
    assert!(
        e.contains("cameras.txt") && e.contains("PINHOLE takes 4 parameters, found 3"),
        "{e}"
    );
}

#[test]
fn downscale_reads_images_n_or_leaves_it_to_the_consumer() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    colmap_fixture(root, true);
    let half = LoadOptions { downscale: 2 };
    // No images_2/: cameras scaled, full-resolution files to be shrunk by the consumer.
    let d = load_with(root, None, &half).unwrap();
    assert_eq!(d.image_downscale, 2);
    let v0 = &d.views[0];
    let c = v0.camera;
    assert_eq!(
        (c.fx, c.fy, c.cx, c.cy, c.width, c.height),
        (10.0, 10.5, 6.0, 4.0, 12, 8)
    );
    assert_eq!(v0.image, root.join("images/00.png"));
    let (u, v) = pixel(v0, [0.4, -0.2, 1.0]);
    assert!(close(u, 6.8) && close(v, 3.58), "{u} {v}");
    let report = check(&d, None);
    assert_eq!((report.images, report.problems.len()), (6, 0), "{report:?}");
    // With images_2/: read from there, at the cameras' size.
    for name in COLMAP_IMAGES {
        write_rgb(&root.join("images_2").join(name), 12, 8);
    }
    let d = load_with(root, None, &half).unwrap();
    assert_eq!(d.image_downscale, 1);
    assert_eq!(d.views[0].image, root.join("images_2/00.png"));
    assert_eq!((d.views[3].camera.width, d.views[3].camera.height), (12, 8));
    let report = check(&d, None);
    assert_eq!((report.images, report.problems.len()), (6, 0), "{report:?}");
    // A file of the wrong size is named.
    write_rgb(&root.join("images_2/01.png"), 13, 8);
    let report = check(&load_with(root, None, &half).unwrap(), None);
    assert!(
        report.problems.len() == 1 && report.problems[0].0.ends_with("01.png"),
        "{report:?}"
    );
    // 24×16 at 1/3 rounds to 8×5.
    let d = load_with(root, None, &LoadOptions { downscale: 3 }).unwrap();
    assert_eq!((d.views[0].camera.width, d.views[0].camera.height), (8, 5));
    assert_eq!(check(&d, None).problems.len(), 0);
    // Other formats, and a factor of 0, are refused.
    assert!(load_with(root, None, &LoadOptions { downscale: 0 }).is_err());
    let neuman = tempfile::tempdir().unwrap();
    neuman_fixture(neuman.path(), false);
    let e = load_with(neuman.path(), None, &half)
        .unwrap_err()
        .to_string();
    assert!(e.contains("COLMAP scenes only"), "{e}");
}

#[test]
fn colmap_scenes_are_detected_beside_neuman_with_their_masks() {
    let dir = tempfile::tempdir().unwrap();
    let neuman = dir.path().join("neuman");
    neuman_fixture(&neuman, false);
    assert_eq!(
        detect(&neuman),
        Some(Format::Neuman),
        "NeuMan has a COLMAP model too"
    );
    // A model directly in sparse/.
    let root = dir.path().join("scene");
    colmap_fixture(&root, false);
    let full = load(&root, None).unwrap();
    for file in ["cameras.txt", "images.txt", "points3D.txt"] {
        std::fs::rename(
            root.join("sparse/0").join(file),
            root.join("sparse").join(file),
        )
        .unwrap();
    }
    std::fs::remove_dir(root.join("sparse/0")).unwrap();
    assert_eq!(detect(&root), Some(Format::Colmap));
    let flat = load(&root, None).unwrap();
    assert_eq!(flat.views, full.views);
    // Without images/ it is not a scene.
    std::fs::rename(root.join("images"), root.join("pictures")).unwrap();
    assert_eq!(detect(&root), None);
    std::fs::rename(root.join("pictures"), root.join("images")).unwrap();
    // masks/<name>.png, non-zero = person.
    write_mask(&root.join("masks/00.png"), 24, 16, 255, 0);
    write_mask(&root.join("masks/extra/05.png"), 24, 16, 255, 0);
    let d = load(&root, None).unwrap();
    assert_eq!(d.views[0].mask, Some(root.join("masks/00.png")));
    assert_eq!(d.views[0].mask_convention, MaskConvention::NonZeroIsPerson);
    assert_eq!(d.views[1].mask, None);
    assert_eq!(d.views[5].mask, Some(root.join("masks/extra/05.png")));
    let report = check(&d, None);
    assert_eq!((report.masks, report.problems.len()), (2, 0), "{report:?}");
}

#[test]
fn nerfstudio_ply_file_path_gives_the_points() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    nerfstudio_fixture(root, true);
    assert_eq!(detect(root), Some(Format::Nerfstudio));
    let d = load(root, None).unwrap();
    assert_eq!(d.views.len(), 6);
    assert_eq!(d.points, ring_points(), "binary little-endian");
    let (u, v) = pixel(&d.views[0], [0.4, -0.2, 1.0]);
    assert!(
        (u - 13.6).abs() < 1e-4 && (v - 7.16).abs() < 1e-4,
        "{u} {v}"
    );
    let report = check(&d, None);
    assert_eq!((report.images, report.problems.len()), (6, 0), "{report:?}");
    write_point_ply(&root.join("sparse_pc.ply"), &ring_points(), true);
    assert_eq!(load(root, None).unwrap().points, ring_points(), "ASCII");
    let plain = tempfile::tempdir().unwrap();
    nerfstudio_fixture(plain.path(), false);
    assert!(load(plain.path(), None).unwrap().points.is_empty());
}

#[test]
fn ply_headers_and_encodings_are_read() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("points.ply");
    // Big-endian, an element before the vertices (skipped), float colours, faces after.
    let mut bytes = b"ply\r\nformat binary_big_endian 1.0\r\ncomment x\r\nelement material 1\r\n\
        property uchar id\r\nproperty list uchar int ids\r\nelement vertex 1\r\n\
        property float32 x\r\nproperty float y\r\nproperty double z\r\nproperty float red\r\n\
        property float green\r\nproperty float blue\r\nelement face 1\r\n\
        property list uchar int vertex_indices\r\nend_header\r\n"
        .to_vec();
    bytes.extend([9u8, 2]);
    bytes.extend(1i32.to_be_bytes());
    bytes.extend(2i32.to_be_bytes());
    bytes.extend(1.5f32.to_be_bytes());
    bytes.extend((-2f32).to_be_bytes());
    bytes.extend(3f64.to_be_bytes());
    for c in [0.25f32, 0.5, 1.0] {
        bytes.extend(c.to_be_bytes());
    }
    bytes.extend([3u8, 0, 0, 0, 0]);
    std::fs::write(&path, &bytes).unwrap();
    assert_eq!(
        read_points(&path).unwrap(),
        vec![([1.5, -2.0, 3.0], [0.25f32, 0.5, 1.0])]
    );
    // No colours: mid grey.
    std::fs::write(
        &path,
        "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n\
         property float z\nend_header\n1 2 3\n4 5 6\n",
    )
    .unwrap();
    let points = read_points(&path).unwrap();
    assert_eq!(points.len(), 2);
    assert_eq!(points[1], ([4.0, 5.0, 6.0], [0.5f32; 3]));
}

#[test]
fn bad_ply_files_are_errors_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    nerfstudio_fixture(root, true);
    let ply = root.join("sparse_pc.ply");
    let binary = std::fs::read(&ply).unwrap();
    let write = |text: String| std::fs::write(&ply, text).unwrap();
    let header = "ply\nformat ascii 1.0\nelement vertex 2\n";
    write(format!(
        "{header}property float y\nproperty float z\nend_header\n1 2\n3 4\n"
    ));
    let e = load_error(root);
    assert!(e.contains("sparse_pc.ply") && e.contains("vertex.x"), "{e}");
    write(format!(
        "{header}property float x\nproperty float y\nproperty float z\nend_header\n1 2 3\n4 5"
    ));
    let e = load_error(root);
    assert!(
        e.contains("sparse_pc.ply") && e.contains("truncated") && e.contains("row 1"),
        "{e}"
    );
    write(format!(
        "{header}property float x\nproperty float y\nproperty list uchar float z\nend_header\n"
    ));
    let e = load_error(root);
    assert!(
        e.contains("sparse_pc.ply") && e.contains("list property"),
        "{e}"
    );
    write("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n".into());
    let e = load_error(root);
    assert!(
        e.contains("sparse_pc.ply") && e.contains("end_header"),
        "{e}"
    );
    write(
        "ply\nformat ascii 1.0\nelement vertex 1000000000000\nproperty float x\n\
         property float y\nproperty float z\nend_header\n1 2 3\n"
            .into(),
    );
    let e = load_error(root);
    assert!(
        e.contains("sparse_pc.ply") && e.contains("truncated"),
        "{e}"
    );
    std::fs::write(&ply, &binary[..binary.len() - 10]).unwrap();
    let e = load_error(root);
    assert!(
        e.contains("sparse_pc.ply") && e.contains("truncated"),
        "{e}"
    );
    let text = String::from_utf8_lossy(&binary).into_owned();
    let at = text.find("element vertex 50").unwrap() + "element vertex ".len();
    let huge = [&binary[..at], &b"99999999999999"[..], &binary[at + 2..]].concat();
    std::fs::write(&ply, &huge).unwrap();
    let e = load_error(root);
    assert!(
        e.contains("sparse_pc.ply") && e.contains("truncated"),
        "{e}"
    );
    std::fs::remove_file(&ply).unwrap();
    let e = load_error(root);
    assert!(
        e.contains("sparse_pc.ply") && e.contains("cannot read"),
        "{e}"
    );
}
