//! A real capture's scans (`data.scene_scan`, `data.human_scan`): the synthetic capture's scene
//! scan written as a nerfstudio folder (with its points, ground masks and monocular depth
//! beside the images) and its human scan as a NeuMan-layout folder, beside its acting video
//! written as NeuMan, read back as they were and trained on in place of the acting video.

use crate::data::tiny_capture;
use crate::trainer::into_stage_d;
use crate::{assert_same_camera, max_abs_difference, values};
use burn::tensor::Device;
use splatzoo_datasets::fixtures::write_point_ply;
use splatzoo_datasets::formats::Similarity;
use splatzoo_datasets::formats::neuman_writer::{NeumanFrame, frame_name, write_neuman_scene};
use splatzoo_datasets::nerfstudio::{NerfstudioFrame, write_transforms_with_points};
use splatzoo_datasets::synth::export::write_npy_f32;
use splatzoo_models::body::builtin_body;
use splatzoo_prior_4d::Prior4d;
use splatzoo_prior_4d::data::neuman::{NEUMAN_BETAS, write_acting_as_neuman};
use splatzoo_prior_4d::data::{Prior4dCapture, Prior4dDataConfig};
use splatzoo_train::avatar::track_joints;
use splatzoo_train::harness::Method;
use splatzoo_train::host_f32;
use std::path::Path;

fn png(path: &Path, image: image::DynamicImage) {
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    image.save(path).unwrap();
}

fn bytes(t: &burn::tensor::Tensor<3>) -> Vec<u8> {
    host_f32(t)
        .iter()
        .map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8)
        .collect()
}

/// The scene scan as nerfstudio: `images/`, `transforms.json` naming `sparse_pc.ply`, and
/// `ground/`, `mono_depth/` by the images' stems.
fn write_scene_scan(capture: &Prior4dCapture, root: &Path) {
    let mut frames = Vec::new();
    for (k, view) in capture.scene_scan.iter().enumerate() {
        let (w, h) = (view.camera.width, view.camera.height);
        let name = frame_name(k);
        let rgb = image::RgbImage::from_raw(w, h, bytes(&view.image)).unwrap();
        png(&root.join("images").join(&name), rgb.into());
        let g: Vec<u8> = view
            .ground
            .data
            .iter()
            .map(|&v| u8::from(v) * 255)
            .collect();
        let g = image::GrayImage::from_raw(w, h, g).unwrap();
        png(&root.join("ground").join(&name), g.into());
        let stem = name.trim_end_matches(".png");
        let mono = root.join("mono_depth").join(format!("{stem}.npy"));
        std::fs::create_dir_all(mono.parent().unwrap()).unwrap();
        let values = host_f32(&view.mono_inverse_depth);
        write_npy_f32(&mono, &[u64::from(h), u64::from(w)], &values).unwrap();
        frames.push(NerfstudioFrame {
            file_path: format!("images/{name}"),
            mask_path: None,
            depth_file_path: None,
            camera: view.camera,
            time: None,
        });
    }
    let points = capture.scene_points.to_sparse();
    write_point_ply(&root.join("sparse_pc.ply"), &points, false);
    write_transforms_with_points(
        &root.join("transforms.json"),
        &frames,
        Some("sparse_pc.ply"),
    )
    .unwrap();
}

/// The human scan as a NeuMan-layout folder: its world is metres, so the alignment is the
/// fit's translation alone.
fn write_human_scan(capture: &Prior4dCapture, root: &Path) {
    let prior = &capture.scan_prior;
    let frames: Vec<NeumanFrame> = capture
        .human_scan
        .iter()
        .enumerate()
        .map(|(k, view)| NeumanFrame {
            camera: view.camera,
            rgb: bytes(&view.image),
            person: host_f32(&view.mask).iter().map(|&m| m > 0.5).collect(),
            pose: prior.pose(k).to_vec(),
            betas: prior.frame_betas(k)[..NEUMAN_BETAS].to_vec(),
            alignment: Similarity {
                scale: 1.0,
                rotation: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
                translation: prior.translation(k),
            },
            depth: None,
        })
        .collect();
    write_neuman_scene(root, &frames, &[([0.0; 3], [0.5; 3])], &[]).unwrap();
}

#[test]
fn given_scans_read_back_and_replace_the_acting_video_as_the_priors_source() {
    let mut synthetic = tiny_capture();
    // NeuMan's fits carry 10 shape coefficients: the rest read back as zero.
    for prior in [&mut synthetic.scan_prior, &mut synthetic.acting_prior] {
        let s = prior.shape_count;
        for (k, beta) in prior.betas.iter_mut().enumerate() {
            if k % s >= NEUMAN_BETAS {
                *beta = 0.0;
            }
        }
    }
    let dir = tempfile::tempdir().unwrap();
    let (acting, scene, human) = (
        dir.path().join("acting"),
        dir.path().join("scene"),
        dir.path().join("human"),
    );
    write_acting_as_neuman(&synthetic, &acting, &[2, 5], false).unwrap();
    write_scene_scan(&synthetic, &scene);
    write_human_scan(&synthetic, &human);
    let data = Prior4dDataConfig {
        capture: Some(acting),
        scene_scan: Some(scene),
        human_scan: Some(human),
        width: 80,
        capture_betas: true,
        ..Prior4dDataConfig::default()
    };
    let real = data.build(&Device::flex()).expect("the three folders read");

    assert_eq!(real.scene_scan.len(), synthetic.scene_scan.len());
    assert_eq!(real.scene_points.len(), synthetic.scene_points.len());
    for (t, (a, b)) in real
        .scene_scan
        .iter()
        .zip(&synthetic.scene_scan)
        .enumerate()
    {
        assert_eq!(a.ground, b.ground, "scan view {t}: ground");
        let (ma, mb) = (
            values(a.mono_inverse_depth.clone()),
            values(b.mono_inverse_depth.clone()),
        );
        assert_eq!(ma, mb, "scan view {t}: monocular depth");
        assert_same_camera(&a.camera, &b.camera, 1e-4, &format!("scan view {t}"));
        let finite = a.depth.iter().filter(|d| d.is_finite()).count();
        assert!(
            finite > 50,
            "scan view {t}: {finite} pixels of sparse depth"
        );
    }
    assert_eq!(real.human_scan.len(), synthetic.human_scan.len());
    for (t, (a, b)) in real
        .human_scan
        .iter()
        .zip(&synthetic.human_scan)
        .enumerate()
    {
        assert_eq!(
            values(a.mask.clone()),
            values(b.mask.clone()),
            "human view {t}"
        );
        assert_same_camera(&a.camera, &b.camera, 1e-4, &format!("human view {t}"));
    }
    let model = &builtin_body().model;
    let device = Device::flex();
    let joints = |c: &Prior4dCapture| host_f32(&track_joints(model, &c.scan_prior, &device));
    let worst = max_abs_difference(&joints(&real), &joints(&synthetic));
    assert!(worst < 1e-3, "the scan's body off by {worst} m");

    let mut config = into_stage_d(8);
    config.data = data;
    let mut method = Prior4d::new(config.clone(), &device).expect("a run on the folders");
    let decisions = method.decisions().join("\n");
    assert!(
        decisions.contains("scene scan")
            && decisions.contains("human scan")
            && !decisions.contains("no scene scan")
            && !decisions.contains("no human scan"),
        "{decisions}"
    );
    assert_eq!(
        method.scene.train.len() + method.scene.test.len(),
        real.scene_scan.len()
    );
    while method.steps() < config.iterations {
        assert!(method.step().expect("a step").loss.is_finite());
    }
    assert!(method.final_scores(None).expect("scores").truth.is_none());
}

#[test]
fn scans_without_a_capture_are_refused() {
    let data = Prior4dDataConfig {
        scene_scan: Some("nowhere".into()),
        ..Prior4dDataConfig::default()
    };
    let error = data
        .build(&Device::flex())
        .err()
        .expect("refused")
        .to_string();
    assert!(error.contains("data.capture"), "{error}");
}
