//! Cross-crate interop: the workspace's binaries end to end, their outputs read back by the
//! project's readers (`.ply`, checkpoints with their format tags, `metrics.json` as the
//! harness's history, PNG renders, ONNX graphs in tract), and checkpoints carried from one
//! process to another (resumed bit-exactly on the CPU, read by `render`, `drive-nlf` and
//! `animate-avatar`; `train-apf` and `train-prior4d` resumed across processes, the latter from
//! inside stage B and inside stage D; `train-illum` from inside stage 1, its checkpoint
//! relit by `relight-illum` and its human moved into a room-B run by `transfer-illum`).

use burn::tensor::Device;
use splatzoo_apf_gs::trainer::ApfTrainer;
use splatzoo_datasets::pose_sequence::{PoseSequence, write_pose_sequence};
use splatzoo_illum::method::Illum;
use splatzoo_nlf_gs::onnx;
use splatzoo_nlf_gs::trainer::NlfTrainer;
use splatzoo_prior_4d::Prior4d;
use splatzoo_train::avatar::AvatarTrainer;
use splatzoo_train::checkpoint::Checkpoint;
use splatzoo_train::harness::{History, Method, check_format};
use splatzoo_train::ply::{read_ply, read_ply_columns};
use splatzoo_train::static_scene::StaticTrainer;
use splatzoo_train::sweep::SweepSpec;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A workspace binary beside this test's executable (`target/<profile>/<name>`).
fn binary(name: &str) -> PathBuf {
    let exe = std::env::current_exe().expect("the test executable");
    let dir = exe
        .parent()
        .and_then(Path::parent)
        .expect("target/<profile>/deps");
    let path = dir.join(name);
    assert!(
        path.exists(),
        "{} is missing: run `cargo test --workspace`, which builds every binary",
        path.display()
    );
    path
}

fn run(dir: &Path, name: &str, args: &[&str]) -> Output {
    Command::new(binary(name))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("the binary starts")
}

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// The harness history of a finished run's `metrics.json`, after checking the run summary the
/// sweep reads (loop time, render FPS over a positive frame count, Gaussians, peak memory) and
/// the scene's module decisions.
fn history(path: &Path) -> History {
    let text = std::fs::read_to_string(path).expect("metrics.json");
    let summary: serde_json::Value = serde_json::from_str(&text).expect("JSON");
    for key in [
        "loop_seconds",
        "step_seconds",
        "render_fps",
        "peak_rss_bytes",
    ] {
        let v = summary[key].as_f64().unwrap_or(f64::NAN);
        assert!(v.is_finite() && v > 0.0, "{}: {key} = {v}", path.display());
    }
    assert!(summary["render_frames"].as_u64().unwrap_or(0) > 0);
    assert!(summary["gaussians"].as_u64().unwrap_or(0) > 0);
    let modules = summary["modules"].as_array().expect("the modules list");
    assert!(
        modules
            .iter()
            .all(|m| m["reason"].is_string() && m["enabled"].is_boolean())
    );
    serde_json::from_str(&text).expect("metrics.json is a harness history")
}

/// Every PNG in `dir` decodes and is not blank; returns how many there are.
fn renders_decode(dir: &Path) -> usize {
    let mut count = 0;
    for entry in std::fs::read_dir(dir).expect("renders/") {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "png") {
            continue;
        }
        let image = image::open(&path).expect("a PNG").to_rgb8();
        let first = image.get_pixel(0, 0);
        assert!(
            image.pixels().any(|p| p != first),
            "{} is one colour",
            path.display()
        );
        count += 1;
    }
    count
}

/// Tensors of two checkpoints, bit for bit.
fn same_tensors(a: &Path, b: &Path) {
    let (a, b) = (Checkpoint::read(a).unwrap(), Checkpoint::read(b).unwrap());
    assert_eq!(
        a.tensors.keys().collect::<Vec<_>>(),
        b.tensors.keys().collect::<Vec<_>>()
    );
    for (name, tensor) in &a.tensors {
        assert!(&b.tensors[name] == tensor, "{name} differs");
    }
}

#[test]
fn train_3dgs_default_outputs_read_back_and_resume_across_processes() {
    let dir = tempfile::tempdir().unwrap();
    let straight = run(
        dir.path(),
        "train-3dgs",
        &["--iterations", "2", "--name", "a"],
    );
    assert!(straight.status.success(), "{}", text(&straight));
    let out = dir.path().join("runs/3dgs/a");
    let checkpoint = Checkpoint::read(&out.join("checkpoint.safetensors")).unwrap();
    check_format(&checkpoint, StaticTrainer::FORMAT).unwrap();
    assert!(check_format(&checkpoint, NlfTrainer::FORMAT).is_err());
    let set = read_ply(&out.join("point_cloud.ply"), &Device::flex()).unwrap();
    let metrics = history(&out.join("metrics.json"));
    assert_eq!(metrics.method, "3dgs");
    let last = metrics
        .evaluations
        .last()
        .expect("an evaluation at the end");
    assert_eq!(last.step, 2);
    assert_eq!(last.extra["gaussians"].as_u64(), Some(set.len() as u64));
    assert!(last.scores.psnr.is_finite());
    assert_eq!(renders_decode(&out.join("renders")), 6);

    // One step here, the next in another process: the same state as the straight run.
    let first = run(
        dir.path(),
        "train-3dgs",
        &["--iterations", "2", "--name", "b", "--stop-after", "1"],
    );
    assert_eq!(first.status.code(), Some(130), "{}", text(&first));
    let saved = dir.path().join("runs/3dgs/b/checkpoint.safetensors");
    let second = run(
        dir.path(),
        "train-3dgs",
        &["--name", "b", "--resume", saved.to_str().unwrap()],
    );
    assert!(second.status.success(), "{}", text(&second));
    same_tensors(&out.join("checkpoint.safetensors"), &saved);

    // `render` reads the checkpoint; `drive-nlf` refuses it by its format tag.
    let render = run(
        dir.path(),
        "render",
        &[
            "--checkpoint",
            saved.to_str().unwrap(),
            "--turntable",
            "2",
            "--out",
            "turn",
        ],
    );
    assert!(render.status.success(), "{}", text(&render));
    assert!(dir.path().join("turn/turntable.gif").exists());
    let refused = run(
        dir.path(),
        "drive-nlf",
        &["--checkpoint", saved.to_str().unwrap()],
    );
    assert!(
        !refused.status.success() && text(&refused).contains(NlfTrainer::FORMAT),
        "{}",
        text(&refused)
    );
}

#[test]
fn train_nlf_default_outputs_read_back_and_resume_across_processes() {
    let dir = tempfile::tempdir().unwrap();
    let straight = run(
        dir.path(),
        "train-nlf",
        &["--iterations", "2", "--name", "a"],
    );
    assert!(straight.status.success(), "{}", text(&straight));
    let out = dir.path().join("runs/nlf/a");
    let checkpoint = Checkpoint::read(&out.join("checkpoint.safetensors")).unwrap();
    check_format(&checkpoint, NlfTrainer::FORMAT).unwrap();
    let metrics = history(&out.join("metrics.json"));
    assert_eq!(metrics.method, "nlf");
    assert!(metrics.baselines.contains_key("mean_colour"));
    let last = metrics
        .evaluations
        .last()
        .expect("an evaluation at the end");
    assert!(last.extra.contains_key("at_input_views"));
    assert_eq!(renders_decode(&out.join("renders")), 9);
    let graphs = out.join("onnx");
    for (graph, names) in [("encoder", onnx::ENCODER_IO), ("decoder", onnx::DECODER_IO)] {
        let path = graphs.join(format!("{graph}.onnx"));
        let (inputs, outputs) = onnx::io_names(&path).unwrap();
        assert_eq!(
            (inputs, outputs),
            (vec![names.0.to_owned()], vec![names.1.to_owned()])
        );
        let error = onnx::verify(&path, &graphs.join(format!("{graph}.vectors.safetensors")));
        assert!(error.unwrap() < 1e-3, "{graph}");
    }

    // A small network for the cross-process resume.
    let small = [
        "--set",
        "onnx=false",
        "--iterations",
        "2",
        "--set",
        "train_subjects=2",
        "--set",
        "test_subjects=1",
        "--set",
        "size=32",
        "--set",
        "network.fpn_channels=8",
        "--set",
        "network.gaussians_per_face=1",
    ];
    let whole = run(
        dir.path(),
        "train-nlf",
        &[&small[..], &["--name", "c"]].concat(),
    );
    assert!(whole.status.success(), "{}", text(&whole));
    let first = run(
        dir.path(),
        "train-nlf",
        &[&small[..], &["--name", "b", "--stop-after", "1"]].concat(),
    );
    assert_eq!(first.status.code(), Some(130), "{}", text(&first));
    let saved = dir.path().join("runs/nlf/b/checkpoint.safetensors");
    let second = run(
        dir.path(),
        "train-nlf",
        &["--name", "b", "--resume", saved.to_str().unwrap()],
    );
    assert!(second.status.success(), "{}", text(&second));
    same_tensors(
        &dir.path().join("runs/nlf/c/checkpoint.safetensors"),
        &saved,
    );

    let drive = run(
        dir.path(),
        "drive-nlf",
        &[
            "--checkpoint",
            saved.to_str().unwrap(),
            "--frames",
            "2",
            "--out",
            "drive",
        ],
    );
    assert!(drive.status.success(), "{}", text(&drive));
    assert!(dir.path().join("drive/drive.gif").exists());
    // `render` refuses an NLF checkpoint by its format tag.
    let refused = run(
        dir.path(),
        "render",
        &["--checkpoint", saved.to_str().unwrap(), "--turntable", "2"],
    );
    assert!(
        !refused.status.success() && text(&refused).contains(StaticTrainer::FORMAT),
        "{}",
        text(&refused)
    );
}

#[test]
fn train_avatar_default_outputs_read_back_and_animate() {
    let dir = tempfile::tempdir().unwrap();
    let straight = run(
        dir.path(),
        "train-avatar",
        &["--iterations", "2", "--name", "a"],
    );
    assert!(straight.status.success(), "{}", text(&straight));
    let out = dir.path().join("runs/avatar/a");
    let saved = out.join("checkpoint.safetensors");
    let checkpoint = Checkpoint::read(&saved).unwrap();
    check_format(&checkpoint, AvatarTrainer::FORMAT).unwrap();
    let canonical = read_ply(&out.join("canonical.ply"), &Device::flex()).unwrap();
    let metrics = history(&out.join("metrics.json"));
    assert_eq!(metrics.method, "avatar");
    assert!(metrics.baselines.contains_key("plain_template/novel_view"));
    let last = metrics
        .evaluations
        .last()
        .expect("an evaluation at the end");
    assert_eq!(
        last.extra["gaussians"].as_u64(),
        Some(canonical.len() as u64)
    );
    assert!(last.extra["mpjpe_mm"].as_f64().unwrap().is_finite());
    assert_eq!(renders_decode(&out.join("renders")), 12 + 12);

    // The avatar drives a new motion; `render` and `animate-avatar` refuse each other's files.
    let animate = run(
        dir.path(),
        "animate-avatar",
        &[
            "--checkpoint",
            saved.to_str().unwrap(),
            "--frames",
            "2",
            "--no-ply",
            "--out",
            "anim",
        ],
    );
    assert!(animate.status.success(), "{}", text(&animate));
    assert!(dir.path().join("anim/animation.gif").exists());
    let refused = run(
        dir.path(),
        "render",
        &["--checkpoint", saved.to_str().unwrap(), "--turntable", "2"],
    );
    assert!(
        !refused.status.success() && text(&refused).contains(StaticTrainer::FORMAT),
        "{}",
        text(&refused)
    );
}

/// `train-aag` from a user's photo (the synthetic identity written as one by
/// `aag-write-photo`, with a random-weight ONNX denoiser as the guidance model): its outputs
/// read back, its scores say they are of the training face view (nothing is held out), a run
/// stopped and resumed in another process (the photo read and fitted again) ends bit for bit
/// where an uninterrupted one does, and `animate-aag` drives it with no identity to score.
#[test]
fn train_aag_from_a_photo_outputs_read_back_and_resume_across_processes() {
    let dir = tempfile::tempdir().unwrap();
    let small = [
        "--set",
        "render_size=8",
        "--set",
        "gaussians=300",
        "--set",
        "batch=2",
        "--set",
        "data.face_size=16",
        "--set",
        "data.eval_azimuths=2",
        "--set",
        "data.eval_elevations=[0.0]",
        "--set",
        "data.eval_size=16",
        "--set",
        "animation.frames=2",
        "--set",
        "animation.size=16",
    ];
    let with = |extra: &[&str]| -> Vec<String> {
        small.iter().chain(extra).map(|s| s.to_string()).collect()
    };
    let written = run(
        dir.path(),
        "aag-write-photo",
        &strs(&with(&[
            "--out",
            "photo",
            "--size",
            "256",
            "--tiny-guidance",
        ])),
    );
    assert!(written.status.success(), "{}", text(&written));
    let photo = [
        "--photo",
        "photo/portrait.png",
        "--guidance-config",
        "photo/tiny_guidance/guidance.toml",
        "--iterations",
        "3",
    ];
    let straight = with(&[&photo[..], &["--name", "a"]].concat());
    let out = run(dir.path(), "train-aag", &strs(&straight));
    assert!(out.status.success(), "{}", text(&out));
    assert!(text(&out).contains("training-view PSNR"), "{}", text(&out));
    let run_dir = dir.path().join("runs/aag/a");
    let saved = run_dir.join("checkpoint.safetensors");
    let metrics = history(&run_dir.join("metrics.json"));
    assert_eq!(metrics.method, "aag");
    let last = metrics
        .evaluations
        .last()
        .expect("an evaluation at the end");
    assert!(last.training_views && last.scores.psnr.is_finite());
    assert!(last.extra["aag"].get("psnr_per_identity").is_none());
    assert_eq!(
        last.scores.psnr,
        last.extra["aag"]["face_psnr"].as_f64().unwrap()
    );
    let avatar = read_ply(&run_dir.join("point_cloud.ply"), &Device::flex()).unwrap();
    assert_eq!(avatar.len(), 300);
    // The animation frames show the avatar alone (16 wide), no identity beside it.
    let frame = image::open(run_dir.join("animation/frame_0001.png")).unwrap();
    assert_eq!((frame.width(), frame.height()), (16, 16));

    let first = with(&[&photo[..], &["--name", "b", "--stop-after", "2"]].concat());
    let stopped = run(dir.path(), "train-aag", &strs(&first));
    assert_eq!(stopped.status.code(), Some(130), "{}", text(&stopped));
    let partial = dir.path().join("runs/aag/b/checkpoint.safetensors");
    let second = with(
        &[
            &photo[..],
            &["--name", "c", "--resume", partial.to_str().unwrap()],
        ]
        .concat(),
    );
    let resumed = run(dir.path(), "train-aag", &strs(&second));
    assert!(resumed.status.success(), "{}", text(&resumed));
    same_tensors(
        &saved,
        &dir.path().join("runs/aag/c/checkpoint.safetensors"),
    );

    let animate = run(
        dir.path(),
        "animate-aag",
        &[
            "--checkpoint",
            saved.to_str().unwrap(),
            "--frames",
            "2",
            "--no-ply",
            "--out",
            "anim",
        ],
    );
    assert!(animate.status.success(), "{}", text(&animate));
    let scores: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("anim/scores.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(scores["frames"].as_u64(), Some(2));
    assert!(scores.get("mean_psnr").is_none(), "{scores}");
}

/// `train-apf` on a small driving scene: its outputs read back, and a run stopped and resumed in
/// another process ends bit for bit where an uninterrupted one does.
#[test]
fn train_apf_outputs_read_back_and_resume_across_processes() {
    let dir = tempfile::tempdir().unwrap();
    let small = [
        "--iterations",
        "3",
        "--set",
        "warmup=1",
        "--set",
        "data.frames=15",
        "--set",
        "data.width=128",
        "--set",
        "data.height=72",
        "--set",
        "data.supersample=1",
        "--set",
        "data.background_points=2000",
        "--set",
        "attach.initial_gaussians=200",
        "--set",
        "repose_frames=2",
    ];
    let with = |extra: &[&str]| -> Vec<String> {
        small.iter().chain(extra).map(|s| s.to_string()).collect()
    };
    let straight = with(&["--name", "a"]);
    let out = run(dir.path(), "train-apf", &strs(&straight));
    assert!(out.status.success(), "{}", text(&out));
    let run_dir = dir.path().join("runs/apf/a");
    let saved = run_dir.join("checkpoint.safetensors");
    check_format(&Checkpoint::read(&saved).unwrap(), ApfTrainer::FORMAT).unwrap();
    let metrics = history(&run_dir.join("metrics.json"));
    assert_eq!(metrics.method, "apf");
    let last = metrics
        .evaluations
        .last()
        .expect("an evaluation at the end");
    assert!(last.scores.psnr.is_finite());
    assert!(last.extra["novel_view"]["human_true"]["psnr"].is_number());
    let background = read_ply(&run_dir.join("background.ply"), &Device::flex()).unwrap();
    assert!(!background.is_empty());
    let scene = read_ply(&run_dir.join("scene_frame_0014.ply"), &Device::flex()).unwrap();
    assert_eq!(Some(scene.len() as u64), last.extra["gaussians"].as_u64());
    assert_eq!(renders_decode(&run_dir.join("renders")), 3);
    for (stem, _, _) in splatzoo_apf_gs::onnx::GRAPHS {
        let graph = run_dir.join(format!("onnx/{stem}.onnx"));
        let vectors = run_dir.join(format!("onnx/{stem}.vectors.safetensors"));
        assert!(onnx::verify(&graph, &vectors).unwrap() < 1e-3, "{stem}");
    }
    // Every pedestrian with an accessory node is re-posed (this small scene may have none).
    let raw: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(run_dir.join("metrics.json")).unwrap())
            .unwrap();
    let carriers = raw["accessories"].as_array().map_or(0, Vec::len);
    let reposed = std::fs::read_dir(run_dir.join("reposed")).map_or(0, |d| d.count());
    assert_eq!(reposed, carriers);

    let first = with(&["--name", "b", "--stop-after", "2"]);
    let stopped = run(dir.path(), "train-apf", &strs(&first));
    assert_eq!(stopped.status.code(), Some(130), "{}", text(&stopped));
    let partial = dir.path().join("runs/apf/b/checkpoint.safetensors");
    let second = with(&["--name", "c", "--resume", partial.to_str().unwrap()]);
    let resumed = run(dir.path(), "train-apf", &strs(&second));
    assert!(resumed.status.success(), "{}", text(&resumed));
    same_tensors(
        &saved,
        &dir.path().join("runs/apf/c/checkpoint.safetensors"),
    );
}

#[test]
fn train_prior4d_outputs_read_back_and_resume_across_stages_and_processes() {
    let dir = tempfile::tempdir().unwrap();
    let small = [
        "--iterations",
        "26",
        "--set",
        "data.width=64",
        "--set",
        "data.height=48",
        "--set",
        "data.acting_frames=6",
        "--set",
        "data.scene_views=8",
        "--set",
        "data.scan_views=6",
        "--set",
        "data.supersample=1",
        "--set",
        "data.scene_points=3000",
        "--set",
        "scene.steps=10",
        "--set",
        "scene.densify.start=2",
        "--set",
        "scene.densify.stop=8",
        "--set",
        "scene.densify.every=4",
        "--set",
        "avatar.steps=8",
        "--set",
        "avatar.subdivisions=0",
        "--set",
        "avatar.holdout_every=3",
        "--set",
        "plane.min_opacity=0.05",
        "--set",
        "joint.eval_stride=3",
        "--set",
        "checkpoint_every=0",
    ];
    let with = |extra: &[&str]| -> Vec<String> {
        small.iter().chain(extra).map(|s| s.to_string()).collect()
    };
    let out = run(dir.path(), "train-prior4d", &strs(&with(&["--name", "a"])));
    assert!(out.status.success(), "{}", text(&out));
    let run_dir = dir.path().join("runs/prior4d/a");
    let saved = run_dir.join("checkpoint.safetensors");
    check_format(&Checkpoint::read(&saved).unwrap(), Prior4d::FORMAT).unwrap();
    let metrics = history(&run_dir.join("metrics.json"));
    assert_eq!(metrics.method, "prior4d");
    let last = metrics
        .evaluations
        .last()
        .expect("an evaluation at the end");
    assert!(last.scores.psnr.is_finite());
    for key in [
        "mask_iou",
        "normal_mean_degrees",
        "sigma_error",
        "penetration_rate",
        "mpjpe_mm",
    ] {
        assert!(last.extra["joint"][key].is_number(), "{key}");
    }
    assert!(last.extra["priors_only"]["psnr"].is_number());
    let scene = read_ply(&run_dir.join("scene.ply"), &Device::flex()).unwrap();
    let prior = read_ply(&run_dir.join("scene_prior.ply"), &Device::flex()).unwrap();
    assert_eq!(
        scene.len(),
        prior.len(),
        "stage D keeps the scene's Gaussians"
    );
    let posed = read_ply(&run_dir.join("posed_frame_0000.ply"), &Device::flex()).unwrap();
    let avatar = read_ply(&run_dir.join("avatar_canonical.ply"), &Device::flex()).unwrap();
    assert_eq!(posed.len(), scene.len() + avatar.len());
    assert_eq!(renders_decode(&run_dir.join("renders")), 2);
    assert!(run_dir.join("eval.gif").exists());
    // Stopped inside stages A, B and D and at D's first step, resumed in new processes: the
    // same end.
    for (name, stop) in [("a6", "6"), ("b", "14"), ("d0", "18"), ("d", "22")] {
        let first = with(&["--name", name, "--stop-after", stop]);
        let stopped = run(dir.path(), "train-prior4d", &strs(&first));
        assert_eq!(stopped.status.code(), Some(130), "{}", text(&stopped));
        let partial = dir
            .path()
            .join(format!("runs/prior4d/{name}/checkpoint.safetensors"));
        let resumed_name = format!("{name}_resumed");
        let second = with(&[
            "--name",
            &resumed_name,
            "--resume",
            partial.to_str().unwrap(),
        ]);
        let resumed = run(dir.path(), "train-prior4d", &strs(&second));
        assert!(resumed.status.success(), "{}", text(&resumed));
        same_tensors(
            &saved,
            &dir.path().join(format!(
                "runs/prior4d/{resumed_name}/checkpoint.safetensors"
            )),
        );
    }
}

/// `train-illum` at a tiny size (data, stages, samples), without periodic checkpoints.
const ILLUM_SMALL: &[&str] = &[
    "--iterations",
    "6",
    "--set",
    "data.width=48",
    "--set",
    "data.height=36",
    "--set",
    "data.frames=6",
    "--set",
    "data.test_every=3",
    "--set",
    "data.novel_pose_frames=1",
    "--set",
    "data.supersample=1",
    "--set",
    "data.shadow_resolution=64",
    "--set",
    "data.scene_points=600",
    "--set",
    "stage1.steps=3",
    "--set",
    "stage2.samples=4",
    "--set",
    "stage2.eval_samples=4",
    "--set",
    "visibility.labels=128",
    "--set",
    "visibility.warmup=4",
    "--set",
    "checkpoint_every=0",
];

#[test]
fn train_illum_outputs_read_back_resume_across_processes_and_relight() {
    let dir = tempfile::tempdir().unwrap();
    let small = ILLUM_SMALL;
    let with = |extra: &[&str]| -> Vec<String> {
        small.iter().chain(extra).map(|s| s.to_string()).collect()
    };
    let out = run(dir.path(), "train-illum", &strs(&with(&["--name", "a"])));
    assert!(out.status.success(), "{}", text(&out));
    let run_dir = dir.path().join("runs/illum/a");
    let saved = run_dir.join("checkpoint.safetensors");
    check_format(&Checkpoint::read(&saved).unwrap(), Illum::FORMAT).unwrap();
    let metrics = history(&run_dir.join("metrics.json"));
    assert_eq!(metrics.method, "illum");
    let last = metrics
        .evaluations
        .last()
        .expect("an evaluation at the end");
    assert!(last.scores.psnr.is_finite());
    for key in [
        "human_psnr",
        "albedo_psnr",
        "relit_human_psnr",
        "shadow_error",
    ] {
        assert!(last.extra["illum"][key].is_number(), "{key}");
    }
    // Stage 1's F_Δ and F_c and, stage 2 having run, F_vis, F_ao and F_m as ONNX graphs.
    for (stem, _, _) in splatzoo_illum::onnx::BODY_GRAPHS
        .into_iter()
        .chain(splatzoo_illum::onnx::STAGE2_GRAPHS)
    {
        assert!(run_dir.join(format!("onnx/{stem}.onnx")).exists(), "{stem}");
    }
    let scene = read_ply(&run_dir.join("scene.ply"), &Device::flex()).unwrap();
    let human = read_ply(&run_dir.join("human_canonical.ply"), &Device::flex()).unwrap();
    let posed_path = run_dir.join("posed_frame_0002.ply");
    let posed = read_ply(&posed_path, &Device::flex()).unwrap();
    assert_eq!(posed.len(), scene.len() + human.len());
    // The human's material maps ride along as extra properties; the scene's rows carry zeros.
    let maps = read_ply_columns(&posed_path, &["human", "roughness", "metallic", "nx"]).unwrap();
    let (scene_rows, human_rows) = maps[0].split_at(scene.len());
    assert!(scene_rows.iter().all(|&f| f == 0.0) && human_rows.iter().all(|&f| f == 1.0));
    for column in &maps[1..3] {
        assert!(column[..scene.len()].iter().all(|&v| v == 0.0));
        assert!(
            column[scene.len()..]
                .iter()
                .all(|v| (0.0..=1.0).contains(v))
        );
    }
    assert!(
        maps[3][scene.len()..].iter().any(|&v| v != 0.0),
        "human normals written"
    );
    let canonical = read_ply_columns(
        &run_dir.join("human_canonical.ply"),
        &["albedo_0", "metallic", "roughness"],
    )
    .unwrap();
    for column in &canonical {
        assert_eq!(column.len(), human.len());
        assert!(column.iter().all(|v| (0.0..=1.0).contains(v)));
    }
    // Canonical normals: unit vectors, mostly pointing away from the body's centroid (the inner
    // sides of the limbs face it: about 70 % point away on this body, flipped normals 30 %).
    let normals =
        read_ply_columns(&run_dir.join("human_canonical.ply"), &["nx", "ny", "nz"]).unwrap();
    let means = splatzoo_train::host_f32(&human.means);
    let centroid: Vec<f32> = (0..3)
        .map(|c| means.iter().skip(c).step_by(3).sum::<f32>() / human.len() as f32)
        .collect();
    let mut outward = 0;
    for k in 0..human.len() {
        let n = [normals[0][k], normals[1][k], normals[2][k]];
        let length = n.iter().map(|v| v * v).sum::<f32>().sqrt();
        assert!((length - 1.0).abs() < 1e-3, "normal {k}: {n:?}");
        let away: f32 = (0..3)
            .map(|c| n[c] * (means[3 * k + c] - centroid[c]))
            .sum();
        outward += usize::from(away > 0.0);
    }
    let share = outward as f64 / human.len() as f64;
    assert!(
        share > 0.6,
        "only {share} of the canonical normals point outwards"
    );
    assert_eq!(renders_decode(&run_dir.join("renders")), 2);
    for graph in ["visibility", "shadow", "materials_code", "materials"] {
        assert!(
            run_dir.join(format!("onnx/{graph}.onnx")).exists(),
            "{graph}"
        );
    }
    // Stopped inside stage 1, resumed in a new process: the same end.
    let stopped = run(
        dir.path(),
        "train-illum",
        &strs(&with(&["--name", "b", "--stop-after", "2"])),
    );
    assert_eq!(stopped.status.code(), Some(130), "{}", text(&stopped));
    let partial = dir.path().join("runs/illum/b/checkpoint.safetensors");
    let resumed = run(
        dir.path(),
        "train-illum",
        &strs(&with(&[
            "--name",
            "c",
            "--resume",
            partial.to_str().unwrap(),
        ])),
    );
    assert!(resumed.status.success(), "{}", text(&resumed));
    same_tensors(
        &saved,
        &dir.path().join("runs/illum/c/checkpoint.safetensors"),
    );
    // Relit under a turning sky.
    let relit = run(
        dir.path(),
        "relight-illum",
        &["--checkpoint", saved.to_str().unwrap(), "--spin", "2"],
    );
    assert!(relit.status.success(), "{}", text(&relit));
    assert!(run_dir.join("relit/relit.gif").exists());
    assert!(run_dir.join("relit/relit_0001.png").exists());
    // The same person trained in room B; A's human moved into B's scene and light.
    let room_b = run(
        dir.path(),
        "train-illum",
        &strs(&with(&["--name", "room-b", "--set", "data.room=\"b\""])),
    );
    assert!(room_b.status.success(), "{}", text(&room_b));
    let scene_b = dir.path().join("runs/illum/room-b/checkpoint.safetensors");
    let moved = run(
        dir.path(),
        "transfer-illum",
        &[
            "--human",
            saved.to_str().unwrap(),
            "--scene",
            scene_b.to_str().unwrap(),
            "--stride",
            "3",
        ],
    );
    assert!(moved.status.success(), "{}", text(&moved));
    assert!(
        text(&moved).contains("lit by B's probes"),
        "{}",
        text(&moved)
    );
    assert_eq!(
        renders_decode(&dir.path().join("runs/illum/room-b/transfer")),
        2,
        "frames 0 and 3 of B's video"
    );
    // Driven by another walk (a y-up file of two frames), stood elsewhere on B's floor, turned.
    let walk = dir.path().join("walk.npz");
    let mut poses = vec![0.0; 2 * 72];
    poses[72 + 12] = 0.4; // the second frame bends a leg joint
    write_pose_sequence(
        &walk,
        &PoseSequence {
            joints: 24,
            poses,
            translations: vec![5.0, 0.95, 5.0, 5.2, 0.95, 5.0],
            betas: vec![0.0; 2 * 10],
            shape_count: 10,
            fps: Some(30.0),
        },
    )
    .unwrap();
    let placed_dir = dir.path().join("placed");
    let placed = run(
        dir.path(),
        "transfer-illum",
        &[
            "--human",
            saved.to_str().unwrap(),
            "--scene",
            scene_b.to_str().unwrap(),
            "--stride",
            "3",
            "--poses",
            walk.to_str().unwrap(),
            "--up",
            "y",
            "--place",
            "0.3,-0.2",
            "--yaw",
            "-45",
            "--out",
            placed_dir.to_str().unwrap(),
        ],
    );
    assert!(placed.status.success(), "{}", text(&placed));
    assert!(
        text(&placed).contains("first root at (0.30, 0.95, -0.20) m, turned -45°"),
        "{}",
        text(&placed)
    );
    assert_eq!(renders_decode(&placed_dir), 2);
    let refused = run(
        dir.path(),
        "transfer-illum",
        &["--human", "h", "--scene", "s", "--place", "1,x"],
    );
    assert!(!refused.status.success());
    assert!(text(&refused).contains("`x`"), "{}", text(&refused));
}

fn strs(v: &[String]) -> Vec<&str> {
    v.iter().map(String::as_str).collect()
}

/// Every sweep file the project ships names a trainer that exists and knobs it accepts (the
/// sweep's dry run asks the trainer for each point's effective configuration), and every
/// method's and engine trainer's main sweep has at least three knobs.
#[test]
fn every_shipped_sweep_file_names_knobs_its_trainer_accepts() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap();
    let mut folders: Vec<PathBuf> = std::fs::read_dir(root.join("methods"))
        .unwrap()
        .map(|m| m.unwrap().path().join("configs"))
        .collect();
    folders.push(root.join("train/configs"));
    let files: Vec<PathBuf> = folders
        .iter()
        .filter_map(|f| std::fs::read_dir(f).ok())
        .flatten()
        .map(|e| e.unwrap().path())
        .filter(|p| {
            let name = p.file_name().unwrap().to_string_lossy();
            name.starts_with("sweep") && name.ends_with(".toml")
        })
        .collect();
    let main: Vec<&PathBuf> = files
        .iter()
        .filter(|p| {
            let name = p.file_name().unwrap().to_string_lossy();
            ["sweep.toml", "sweep-3dgs.toml", "sweep-avatar.toml"].contains(&name.as_ref())
        })
        .collect();
    assert_eq!(
        main.len(),
        7,
        "five methods and two engine trainers: {main:?}"
    );
    for file in &main {
        let spec = SweepSpec::read(file).unwrap();
        assert!(
            spec.knobs.len() >= 3,
            "{}: {} knobs",
            file.display(),
            spec.knobs.len()
        );
    }
    let dir = tempfile::tempdir().unwrap();
    for file in &files {
        let out = run(
            dir.path(),
            "sweep",
            &["--grid", file.to_str().unwrap(), "--dry-run"],
        );
        assert!(out.status.success(), "{}: {}", file.display(), text(&out));
    }
}

/// `illum-write-neuman` writes the tiny synthetic video as a NeuMan folder; `train-illum` trains
/// on it (`data.capture`): the truth scores are absent from `metrics.json`, the image and F_vis
/// scores present, the decisions say why, and the posed `.ply` and renders are written.
#[test]
fn train_illum_trains_on_a_neuman_folder_without_truth() {
    let dir = tempfile::tempdir().unwrap();
    let data: Vec<&str> = ILLUM_SMALL
        .chunks(2)
        .filter(|pair| pair[0] == "--set" && pair[1].starts_with("data."))
        .flatten()
        .copied()
        .collect();
    let mut args = vec!["--out", "neuman"];
    args.extend(&data);
    let out = run(dir.path(), "illum-write-neuman", &args);
    assert!(out.status.success(), "{}", text(&out));
    let mut args = ILLUM_SMALL.to_vec();
    args.extend(["--set", "data.capture=\"neuman\"", "--name", "disk"]);
    let out = run(dir.path(), "train-illum", &args);
    assert!(out.status.success(), "{}", text(&out));
    assert!(text(&out).contains("no truth on disk"), "{}", text(&out));
    let run_dir = dir.path().join("runs/illum/disk");
    let metrics = history(&run_dir.join("metrics.json"));
    let last = metrics
        .evaluations
        .last()
        .expect("an evaluation at the end");
    assert!(last.scores.psnr.is_finite());
    let illum = &last.extra["illum"];
    assert!(illum["human_psnr"].is_number() && illum["visibility_accuracy"].is_number());
    for key in [
        "albedo_psnr",
        "relit_human_psnr",
        "shadow_error",
        "novel_pose_psnr",
    ] {
        assert!(illum.get(key).is_none(), "{key} without truth: {illum}");
    }
    assert!(run_dir.join("posed_frame_0002.ply").exists());
    assert_eq!(renders_decode(&run_dir.join("renders")), 2);
}
