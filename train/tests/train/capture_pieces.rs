//! The pieces between a capture on disk and training: undistortion against an iterative
//! inversion of the lens model, 3DGS's nearest-neighbour scales against brute force (with
//! duplicates), a LiDAR scan's sparse depth against back-projection, the bounded image cache (evicts within its budget, decodes the same pixels
//! again), and a person track's world placement folded into SMPL's own parameters against
//! posing the body and applying the placement.

use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_datasets::formats::{
    BodyFrame, Distortion, MaskConvention, Similarity, ViewRecord, axis_angle_matrix,
};
use splatzoo_datasets::synth::rng::Rng;
use splatzoo_models::body::builtin_body;
use splatzoo_models::body::lbs::{BodyTensors, PoseInput, pose};
use splatzoo_rasterizer::Camera;
use splatzoo_train::host_f32;
use splatzoo_train::views::image_store::FileImage;
use splatzoo_train::views::init_points::{
    InitPoints, back_project, nearest_neighbour_scales, sparse_depth,
};
use splatzoo_train::views::people::{fold_placement, rest_root};
use splatzoo_train::views::undistort::{distort_normalised, remap_bilinear, source_coordinates};
use splatzoo_train::views::{ImageSource, ImageStore, MaskRole};

fn camera(w: u32, h: u32) -> Camera {
    Camera {
        fx: 0.9 * w as f32,
        fy: 0.9 * w as f32,
        cx: 0.5 * w as f32 + 1.3,
        cy: 0.5 * h as f32 - 0.7,
        width: w,
        height: h,
        near: 0.01,
        far: 100.0,
        world_to_camera: [
            [1.0, 0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, 2.0],
        ],
    }
}

/// Normalised pinhole coordinates the lens sent to `(xd, yd)`, by fixed-point iteration (the
/// way OpenCV's `undistortPoints` inverts the model): an independent path to the same map.
fn undistort_iterative(d: &Distortion, xd: f64, yd: f64) -> (f64, f64) {
    let (mut x, mut y) = (xd, yd);
    for _ in 0..200 {
        let (fx, fy) = distort_normalised(d, x, y);
        x -= fx - xd;
        y -= fy - yd;
    }
    (x, y)
}

/// A smooth scene over normalised pinhole coordinates.
fn pattern(x: f64, y: f64) -> f32 {
    (0.5 + 0.4 * (7.0 * x).sin() * (5.0 * y).cos()) as f32
}

#[test]
fn undistortion_recovers_the_pinhole_image() {
    let (w, h) = (96u32, 72u32);
    let cam = camera(w, h);
    let (fx, fy, cx, cy) = (cam.fx as f64, cam.fy as f64, cam.cx as f64, cam.cy as f64);
    for d in [
        Distortion {
            k1: -0.12,
            k2: 0.03,
            ..Default::default()
        },
        Distortion {
            k1: 0.08,
            k2: -0.01,
            p1: 0.002,
            p2: -0.003,
            k3: 0.001,
        },
    ] {
        // The captured (distorted) image: each pixel shows the scene along its undistorted ray.
        let captured: Vec<f32> = (0..h)
            .flat_map(|py| (0..w).map(move |px| (px, py)))
            .map(|(px, py)| {
                let xd = (px as f64 + 0.5 - cx) / fx;
                let yd = (py as f64 + 0.5 - cy) / fy;
                let (x, y) = undistort_iterative(&d, xd, yd);
                pattern(x, y)
            })
            .collect();
        let coordinates = source_coordinates(&cam, &d);
        let (pinhole, valid) = remap_bilinear(&captured, w as usize, h as usize, 1, &coordinates);
        let (mut worst, mut inside) = (0.0f32, 0);
        for py in 4..h - 4 {
            for px in 4..w - 4 {
                let k = (py * w + px) as usize;
                if !valid[k] {
                    continue;
                }
                inside += 1;
                let x = (px as f64 + 0.5 - cx) / fx;
                let y = (py as f64 + 0.5 - cy) / fy;
                worst = worst.max((pinhole[k] - pattern(x, y)).abs());
            }
        }
        assert!(inside > (w * h / 2) as usize, "{inside}");
        // Bilinear sampling of a smooth pattern: a second-order error (3e-4 measured).
        assert!(worst < 0.003, "{d:?}: worst {worst}");
        // Without undistortion the error is large: the test can fail.
        let plain_worst = (0..(w * h) as usize)
            .map(|k| {
                let (px, py) = (k % w as usize, k / w as usize);
                let x = (px as f64 + 0.5 - cx) / fx;
                let y = (py as f64 + 0.5 - cy) / fy;
                (captured[k] - pattern(x, y)).abs()
            })
            .fold(0.0f32, f32::max);
        assert!(plain_worst > 0.03, "without undistortion: {plain_worst}");
    }
    // No distortion: the identity.
    let d = Distortion::default();
    let values: Vec<f32> = (0..w * h).map(|k| (k % 17) as f32).collect();
    let (same, valid) = remap_bilinear(
        &values,
        w as usize,
        h as usize,
        1,
        &source_coordinates(&cam, &d),
    );
    assert!(valid.iter().all(|&v| v));
    assert!(same.iter().zip(&values).all(|(a, b)| (a - b).abs() < 1e-4));
}

#[test]
fn nearest_neighbour_scales_match_brute_force() {
    let mut rng = Rng(5);
    let mut points: Vec<[f32; 3]> = (0..600)
        .map(|k| {
            // A dense cluster, a sparse halo and far outliers.
            let spread = if k % 10 == 0 {
                50.0
            } else if k % 3 == 0 {
                3.0
            } else {
                0.2
            };
            std::array::from_fn(|_| (rng.range(-1.0, 1.0) * spread) as f32)
        })
        .collect();
    points.push(points[7]);
    points.push(points[7]);
    let fast = nearest_neighbour_scales(&points, 3);
    for (i, p) in points.iter().enumerate() {
        let mut d: Vec<f32> = points
            .iter()
            .enumerate()
            .filter(|&(j, _)| j != i)
            .map(|(_, q)| (0..3).map(|a| (q[a] - p[a]).powi(2)).sum())
            .collect();
        d.sort_by(f32::total_cmp);
        let slow = (d[..3].iter().sum::<f32>() / 3.0).sqrt();
        assert!(
            (fast[i] - slow).abs() <= 1e-5 * slow.max(1e-3),
            "point {i}: {} vs {slow}",
            fast[i]
        );
        assert!(fast[i].is_finite() && fast[i] > 0.0);
    }
    assert_eq!(nearest_neighbour_scales(&points[..1], 3).len(), 1);
    assert!(nearest_neighbour_scales(&[], 3).is_empty());
}

#[test]
fn sparse_depth_inverts_back_projection() {
    let mut rng = Rng(11);
    let cam = camera(23, 17);
    let (w, h) = (23, 17);
    // A depth map with holes, back-projected through pixel centres, then projected again.
    let depth: Vec<f32> = (0..w * h)
        .map(|_| {
            if rng.range(0.0, 1.0) < 0.3 {
                f32::NAN
            } else {
                rng.range(0.5, 30.0) as f32
            }
        })
        .collect();
    let mut points = InitPoints::default();
    back_project(&cam, &depth, &vec![0.5; 3 * w * h], 1, &mut points);
    let mut world: Vec<[f64; 3]> = points.positions.iter().map(|p| p.map(f64::from)).collect();
    // Points behind the camera, beyond `far` and outside the image mark nothing; a farther
    // point on a marked pixel loses to the nearer one.
    world.push([0.0, 0.0, -3.0]);
    world.push([0.0, 0.0, 200.0]);
    world.push([1e3, 0.0, 5.0]);
    let far_twin = world[0].map(|v| 2.0 * v);
    world.push([far_twin[0], far_twin[1], far_twin[2] + 2.0]);
    let got = sparse_depth(&cam, &world);
    assert_eq!(got.len(), w * h);
    for (p, (&g, &d)) in got.iter().zip(&depth).enumerate() {
        if d.is_nan() {
            assert!(g.is_nan(), "pixel {p}: {g} where no point was");
        } else {
            assert!((g - d).abs() <= 1e-4 * d, "pixel {p}: {g} against {d}");
        }
    }
}

#[test]
fn the_image_cache_stays_within_its_budget_and_decodes_the_same_pixels_again() {
    let dir = tempfile::tempdir().unwrap();
    let device = Device::flex();
    let (w, h) = (128u32, 128u32);
    // 1 MiB holds 4 frames of 128² × 3 floats (192 KiB) with their masks (64 KiB).
    let mut store = ImageStore::new(1, &device);
    let mut keys = Vec::new();
    for k in 0..12u32 {
        let path = dir.path().join(format!("{k:02}.png"));
        image::RgbImage::from_fn(w, h, |x, y| {
            image::Rgb([(x + k) as u8, y as u8, (7 * k) as u8])
        })
        .save(&path)
        .unwrap();
        let mask = dir.path().join(format!("{k:02}_mask.png"));
        image::GrayImage::from_fn(w, h, |x, _| image::Luma([if x < 10 + k { 255 } else { 0 }]))
            .save(&mask)
            .unwrap();
        let record = ViewRecord {
            frame: k as usize,
            camera_name: "cam".into(),
            camera: camera(w, h),
            distortion: Distortion::default(),
            image: path.clone(),
            mask: Some(mask.clone()),
            mask_convention: MaskConvention::NonZeroIsPerson,
            other_masks: Default::default(),
            depth: None,
        };
        keys.push(store.push(ImageSource::File(Box::new(FileImage {
            image: path,
            mask: Some(mask),
            mask_role: MaskRole::Person,
            record,
            full_camera: camera(w, h),
            distortion: Distortion::default(),
            downscale: if k == 0 { 2 } else { 1 },
            background: [0.0; 3],
        }))));
    }
    let first = host_f32(&store.frame(keys[3]).unwrap().image);
    for round in 0..2 {
        for &key in &keys {
            let frame = store.frame(key).unwrap();
            let side = if key == keys[0] { 64 } else { 128 };
            assert_eq!(
                frame.image.dims(),
                [side, side, 3],
                "view 0 downscaled by 2"
            );
            let person = host_f32(frame.person.as_ref().unwrap());
            // Mask columns x < 10 + k: the first column is the person, the last is not.
            assert!(person[0] > 0.99 && person[side - 1] < 0.01, "round {round}");
            let (count, bytes) = store.cached();
            assert!(bytes <= 1 << 20, "{bytes} bytes cached");
            assert!(count <= 16);
        }
    }
    let (count, _) = store.cached();
    assert!(
        (2..12).contains(&count),
        "{count} frames cached: some, not all"
    );
    assert_eq!(host_f32(&store.frame(keys[3]).unwrap().image), first);
    // A mask of the wrong size is named.
    let bad_mask = dir.path().join("bad_mask.png");
    image::GrayImage::new(w / 2, h).save(&bad_mask).unwrap();
    let image_path = dir.path().join("00.png");
    let record = ViewRecord {
        frame: 0,
        camera_name: "cam".into(),
        camera: camera(w, h),
        distortion: Distortion::default(),
        image: image_path.clone(),
        mask: Some(bad_mask.clone()),
        mask_convention: MaskConvention::NonZeroIsPerson,
        other_masks: Default::default(),
        depth: None,
    };
    let key = store.push(ImageSource::File(Box::new(FileImage {
        image: image_path,
        mask: Some(bad_mask),
        mask_role: MaskRole::Person,
        record,
        full_camera: camera(w, h),
        distortion: Distortion::default(),
        downscale: 1,
        background: [0.0; 3],
    })));
    let error = store
        .frame(key)
        .err()
        .expect("a mis-sized mask is refused")
        .to_string();
    assert!(
        error.contains("bad_mask.png") && error.contains("64×128"),
        "{error}"
    );
}

#[test]
fn a_track_placement_folds_into_smpl_parameters() {
    let device = Device::flex();
    let model = &builtin_body().model;
    let body = BodyTensors::new(model, &device);
    let mut rng = Rng(3);
    let j = model.joint_count();
    let s = model.shape_count();
    let pose_values: Vec<f64> = (0..3 * j).map(|_| rng.range(-0.6, 0.6)).collect();
    let betas: Vec<f64> = (0..s).map(|_| rng.range(-1.0, 1.0)).collect();
    let transl = [0.3, -0.2, 1.1];
    let placement = Similarity {
        scale: 1.7,
        rotation: axis_angle_matrix([0.4, -1.2, 0.7]),
        translation: [2.0, -0.5, 3.0],
    };
    let posed = |orient: [f64; 3], transl: [f64; 3]| -> Vec<f32> {
        let mut values = pose_values.clone();
        values[..3].copy_from_slice(&orient);
        let f32s = |v: &[f64]| v.iter().map(|&x| x as f32).collect::<Vec<f32>>();
        let input = PoseInput::from_axis_angle(
            Tensor::from_data(TensorData::new(f32s(&betas), [1, s]), &device),
            Tensor::from_data(TensorData::new(f32s(&values), [1, 3 * j]), &device),
            Tensor::from_data(TensorData::new(f32s(&transl), [1, 3]), &device),
        );
        host_f32(&pose(&body, &input).vertices)
    };
    let orient = [pose_values[0], pose_values[1], pose_values[2]];
    // Reference: pose in SMPL's frame, then place by x_w = s R x + t, then scale the world by 1/s.
    let smpl = posed(orient, transl);
    let frame = BodyFrame {
        global_orient: orient,
        body_pose: pose_values[3..].to_vec(),
        betas: betas.clone(),
        transl,
        world_from_smpl: placement,
        root_position: None,
        extra: Default::default(),
    };
    let j0 = rest_root(model, &betas);
    let (folded_orient, folded_transl) = fold_placement(&frame, j0, 1.0 / placement.scale);
    let folded = posed(folded_orient, folded_transl);
    let mut worst = 0.0f64;
    for (x, y) in smpl.chunks(3).zip(folded.chunks(3)) {
        let x = [x[0] as f64, x[1] as f64, x[2] as f64];
        let world = placement.apply(x).map(|v| v / placement.scale);
        for a in 0..3 {
            worst = worst.max((world[a] - y[a] as f64).abs());
        }
    }
    assert!(worst < 1e-4, "{worst} m");
    // The root given instead of a translation (drivestudio) lands the root there.
    let root_world = placement.apply(std::array::from_fn(|a| j0[a] + transl[a]));
    let by_root = BodyFrame {
        transl: [0.0; 3],
        root_position: Some(root_world),
        ..frame
    };
    let (o2, t2) = fold_placement(&by_root, j0, 1.0 / placement.scale);
    assert!((0..3).all(|a| (o2[a] - folded_orient[a]).abs() < 1e-9));
    assert!((0..3).all(|a| (t2[a] - folded_transl[a]).abs() < 1e-9));
}
