//! A synthetic scene written to disk and read back: the pose files re-pose the body model to the
//! rendered vertices and project onto the person's mask; the perturbed prior carries the noise
//! asked for; the nerfstudio export re-reads to the same cameras in the OpenGL convention;
//! malformed `transforms.json` files are refused naming the field; the `synth` command runs.

use burn::tensor::Device;
use splatzoo_datasets::nerfstudio::{NerfstudioFrame, read_transforms, write_transforms};
use splatzoo_datasets::pose_sequence::load_pose_sequence;
use splatzoo_datasets::posing::pose_frames;
use splatzoo_datasets::synth::export::{view_name, write_scene};
use splatzoo_datasets::synth::prior::PriorNoise;
use splatzoo_datasets::synth::{Preset, Scene, SceneConfig};
use splatzoo_models::body::builtin_body;
use std::path::Path;
use std::process::Command;

fn multiview(noise: PriorNoise) -> Scene {
    SceneConfig {
        width: 64,
        height: 64,
        frames: Some(3),
        supersample: 1,
        shadow_resolution: None,
        noise,
        ..SceneConfig::new(Preset::Multiview, 7)
    }
    .build(&Device::flex())
}

fn written(scene: &Scene, frames: &[usize]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let mut done = Vec::new();
    write_scene(scene, dir.path(), frames, |n| done.push(n)).unwrap();
    assert_eq!(done, (1..=frames.len()).collect::<Vec<_>>());
    dir
}

#[test]
fn poses_round_trip_through_the_body_model_and_land_on_the_mask() {
    let noise = PriorNoise {
        pose_noise: 0.1,
        pose_bias: 0.05,
        translation_noise: 0.02,
        translation_bias: 0.04,
        shape_noise: 0.5,
    };
    let scene = multiview(noise);
    let dir = written(&scene, &[0, 2]);
    let body = builtin_body();
    let truth = load_pose_sequence(&dir.path().join("people/person_00_truth.npz")).unwrap();
    assert_eq!(
        (truth.frames(), truth.joints, truth.shape_count),
        (2, 24, 12)
    );
    assert_eq!(
        truth.frame_betas(1),
        scene.people[0].identity.betas.as_slice()
    );
    let reposed = pose_frames(&body.model, &truth, &Device::flex());
    for (k, &f) in [0, 2].iter().enumerate() {
        for (p, q) in reposed[k].iter().zip(&scene.people[0].frames[f].vertices) {
            for c in 0..3 {
                assert!((p[c] - q[c]).abs() < 1e-5, "frame {f}: {p:?} vs {q:?}");
            }
        }
    }
    // The torso joints of the true pose project inside the human mask of every ring camera.
    for view in scene.render_frame(2) {
        let mask = view.human_mask();
        let cam = view.camera;
        for j in [0, 3, 6, 9, 12] {
            let p = scene.people[0].frames[2].joints[j];
            let w = cam.world_to_camera;
            let c: [f32; 3] =
                std::array::from_fn(|r| (0..3).map(|k| w[r][k] * p[k]).sum::<f32>() + w[r][3]);
            let (x, y) = (cam.fx * c[0] / c[2] + cam.cx, cam.fy * c[1] / c[2] + cam.cy);
            let i = y as usize * cam.width as usize + x as usize;
            assert!(
                mask[i],
                "joint {j} at ({x}, {y}) outside the mask of {}",
                view.track
            );
        }
    }
    // The prior: pose errors with the variance asked for, a fixed shape offset per sequence.
    let prior = load_pose_sequence(&dir.path().join("people/person_00_prior.npz")).unwrap();
    let squared: Vec<f64> = prior
        .poses
        .iter()
        .zip(&truth.poses)
        .map(|(a, b)| (a - b).powi(2))
        .collect();
    let variance = squared.iter().sum::<f64>() / squared.len() as f64;
    let expected = noise.pose_noise.powi(2) + noise.pose_bias.powi(2);
    assert!(
        (0.6..1.6).contains(&(variance / expected)),
        "pose error variance {variance} vs {expected}"
    );
    let offset: Vec<f64> = (0..12)
        .map(|k| prior.frame_betas(0)[k] - truth.frame_betas(0)[k])
        .collect();
    assert!(offset.iter().any(|o| o.abs() > 0.05));
    assert_eq!(
        prior.frame_betas(0),
        prior.frame_betas(1),
        "shape bias drifts"
    );
    let exact = multiview(PriorNoise::none());
    assert_eq!(exact.people[0].prior, exact.people[0].motion);
}

#[test]
fn the_nerfstudio_export_rereads_to_the_same_cameras() {
    let scene = multiview(PriorNoise::default());
    let dir = written(&scene, &[1]);
    let frames = read_transforms(&dir.path().join("transforms.json")).unwrap();
    assert_eq!(frames.len(), 16);
    let target = [0.0f64, 0.85, 0.0];
    for (t, frame) in frames.iter().enumerate() {
        let expected = scene.tracks[t].cameras[1];
        let name = view_name(&scene, 1, t);
        assert_eq!(frame.file_path, format!("images/{name}.png"));
        let (a, b) = (frame.camera, expected);
        assert_eq!((a.width, a.height), (b.width, b.height));
        for (x, y) in [(a.fx, b.fx), (a.fy, b.fy), (a.cx, b.cx), (a.cy, b.cy)] {
            assert!((x - y).abs() < 1e-4 * y.abs().max(1.0));
        }
        for r in 0..3 {
            for c in 0..4 {
                let (x, y) = (a.world_to_camera[r][c], b.world_to_camera[r][c]);
                assert!((x - y).abs() < 1e-5, "track {t} [{r}][{c}]: {x} vs {y}");
            }
        }
        assert_eq!(frame.time, Some(0.5));
        // The files it names exist with the camera's size; masks mark the person.
        let image = image::open(dir.path().join(&frame.file_path)).unwrap();
        assert_eq!((image.width(), image.height()), (64, 64));
        let mask = image::open(dir.path().join(frame.mask_path.as_ref().unwrap()))
            .unwrap()
            .to_luma8();
        assert!(mask.pixels().filter(|p| p.0[0] == 255).count() > 100);
        let depth_mm = image::open(dir.path().join(frame.depth_file_path.as_ref().unwrap()))
            .unwrap()
            .to_luma16();
        let depth: Vec<f32> = npyz::NpyFile::new(
            std::fs::File::open(dir.path().join(format!("depth/{name}.npy"))).unwrap(),
        )
        .unwrap()
        .into_vec()
        .unwrap();
        for (mm, m) in depth_mm.pixels().zip(&depth) {
            assert!((mm.0[0] as f32 - m * 1000.0).abs() <= 0.5001);
        }
    }
    // Independently of the reader: the OpenGL camera-to-world puts the camera at its centre and
    // looks down its −z axis at the ring's target.
    let text = std::fs::read_to_string(dir.path().join("transforms.json")).unwrap();
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    for (t, f) in json["frames"].as_array().unwrap().iter().enumerate() {
        let m: Vec<Vec<f64>> = serde_json::from_value(f["transform_matrix"].clone()).unwrap();
        let centre = scene.tracks[t].cameras[1].position();
        let to_target: Vec<f64> = (0..3).map(|k| target[k] - m[k][3]).collect();
        let n = to_target.iter().map(|x| x * x).sum::<f64>().sqrt();
        for k in 0..3 {
            assert!((m[k][3] - centre[k] as f64).abs() < 1e-4);
            assert!(
                (-m[k][2] - to_target[k] / n).abs() < 1e-4,
                "track {t} looks away"
            );
        }
        assert!(m[1][1] > 0.9, "camera up is not world up");
    }
    assert_eq!(
        json["fl_x"].as_f64().unwrap() as f32,
        scene.tracks[0].cameras[0].fx
    );
    let scene_json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("scene.json")).unwrap())
            .unwrap();
    assert_eq!(scene_json["preset"], "multiview");
    assert_eq!(scene_json["tracks"].as_array().unwrap().len(), 16);
}

fn write_json(dir: &Path, text: &str) -> std::path::PathBuf {
    let path = dir.join("transforms.json");
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn malformed_transforms_are_refused_naming_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let identity = "[[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]";
    let cases = [
        (
            format!(r#"{{"w": 8, "h": 8, "frames": [{{"file_path": "a.png", "transform_matrix": {identity}}}]}}"#),
            "frames[0].fl_x",
        ),
        (
            format!(r#"{{"fl_x": 8, "h": 8, "frames": [{{"file_path": "a.png", "transform_matrix": {identity}}}]}}"#),
            "frames[0].w",
        ),
        (
            r#"{"fl_x": 8, "w": 8, "h": 8, "frames": [{"file_path": "a.png", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,2,1]]}]}"#.to_string(),
            "transform_matrix",
        ),
        (r#"{"fl_x": 8, "w": 8}"#.to_string(), "frames"),
    ];
    for (text, expected) in cases {
        let path = write_json(dir.path(), &text);
        let error = read_transforms(&path).unwrap_err().to_string();
        assert!(error.contains(expected), "{error}");
        assert!(error.contains("transforms.json"), "{error}");
    }
    // Blender's camera_angle_x stands in for fl_x.
    let path = write_json(
        dir.path(),
        &format!(
            r#"{{"camera_angle_x": 1.5707963, "w": 100, "h": 50, "frames": [{{"file_path": "a.png", "transform_matrix": {identity}}}]}}"#
        ),
    );
    let frames = read_transforms(&path).unwrap();
    assert!((frames[0].camera.fx - 50.0).abs() < 1e-3);
    assert_eq!(frames[0].camera.cy, 25.0);
    // Per-frame intrinsics when cameras differ.
    let mut cameras: Vec<NerfstudioFrame> = frames.clone();
    cameras.push(NerfstudioFrame {
        camera: splatzoo_rasterizer::Camera {
            fx: 70.0,
            ..frames[0].camera
        },
        ..frames[0].clone()
    });
    write_transforms(&path, &cameras).unwrap();
    let reread = read_transforms(&path).unwrap();
    assert_eq!(reread[1].camera.fx, 70.0);
    assert!((reread[0].camera.fx - 50.0).abs() < 1e-3);
}

#[test]
fn the_synth_command_writes_a_scene_and_refuses_bad_arguments() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("yard");
    let run = Command::new(env!("CARGO_BIN_EXE_synth"))
        .args(["--preset", "static", "--width", "24", "--height", "24"])
        .args(["--shadow-resolution", "128", "--subjects", "2"])
        .args(["--out", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    for s in ["subject_000", "subject_001"] {
        let frames = read_transforms(&out.join(s).join("transforms.json")).unwrap();
        assert_eq!(frames.len(), 48);
        assert!(out.join(s).join("scene.json").exists());
    }
    let bad = Command::new(env!("CARGO_BIN_EXE_synth"))
        .args(["--preset", "static", "--supersample", "0"])
        .args(["--out", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--supersample"));
}
