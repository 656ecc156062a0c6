//! The `train-3dgs` and `render` commands end to end: outputs of a run, interruption (by
//! `--stop-after` and by SIGINT) and a resume that ends bit-identical to an uninterrupted run,
//! nerfstudio folders in (and a damaged one refused), configuration printing and errors, and
//! rendering from a `.ply` or a checkpoint to PNGs and a turntable GIF.

use burn::tensor::Device;
use splatzoo_datasets::image_io::linear_to_srgb;
use splatzoo_datasets::synth::export::write_scene;
use splatzoo_datasets::synth::{Preset, SceneConfig};
use splatzoo_train::checkpoint::Checkpoint;
use splatzoo_train::ply::read_ply;
use std::io::BufRead;
use std::path::Path;
use std::process::{Command, Output, Stdio};

fn train(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_train-3dgs"))
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap()
}

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

const SMALL: [&str; 6] = [
    "--iterations",
    "30",
    "--size",
    "32",
    "--set",
    "eval_every=10",
];

#[test]
fn a_run_writes_its_outputs_and_an_interrupted_one_resumes_to_the_same_result() {
    let dir = tempfile::tempdir().unwrap();
    let straight = train(dir.path(), &[&SMALL[..], &["--name", "straight"]].concat());
    assert!(straight.status.success(), "{}", text(&straight));
    let out = dir.path().join("runs/3dgs/straight");
    for file in [
        "config.toml",
        "log.txt",
        "metrics.json",
        "checkpoint.safetensors",
        "point_cloud.ply",
    ] {
        assert!(out.join(file).exists(), "{file} missing");
    }
    let metrics = json(&out.join("metrics.json"));
    let evaluations = metrics["evaluations"].as_array().unwrap();
    assert_eq!(evaluations.len(), 3, "every 10 steps: {metrics}");
    let psnr = metrics["final"]["psnr"].as_f64().unwrap();
    assert!(psnr.is_finite() && psnr > 10.0, "held-out PSNR {psnr}");
    let set = read_ply(&out.join("point_cloud.ply"), &Device::flex()).unwrap();
    assert_eq!(set.len() as u64, metrics["gaussians"].as_u64().unwrap());
    assert_eq!(
        std::fs::read_dir(out.join("renders")).unwrap().count(),
        6,
        "one per held-out view"
    );

    let stopped = train(
        dir.path(),
        &[&SMALL[..], &["--name", "resumed", "--stop-after", "13"]].concat(),
    );
    assert_eq!(stopped.status.code(), Some(130), "{}", text(&stopped));
    let resumed_dir = dir.path().join("runs/3dgs/resumed");
    let checkpoint = Checkpoint::read(&resumed_dir.join("checkpoint.safetensors")).unwrap();
    assert_eq!(checkpoint.meta_parsed::<usize>("step").unwrap(), 13);
    let resume_from = resumed_dir.join("checkpoint.safetensors");
    let resumed = train(
        dir.path(),
        &[
            "--resume",
            resume_from.to_str().unwrap(),
            "--name",
            "resumed",
        ],
    );
    assert!(resumed.status.success(), "{}", text(&resumed));
    assert!(
        text(&resumed).contains("resumed at step 13"),
        "{}",
        text(&resumed)
    );
    assert_eq!(
        std::fs::read(resumed_dir.join("point_cloud.ply")).unwrap(),
        std::fs::read(out.join("point_cloud.ply")).unwrap(),
        "the resumed run ends bit-identical to the uninterrupted one"
    );
    let metrics = json(&resumed_dir.join("metrics.json"));
    let steps: Vec<u64> = metrics["evaluations"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["step"].as_u64().unwrap())
        .collect();
    assert_eq!(
        steps,
        vec![10, 20, 30],
        "evaluations carry over the interruption"
    );
    let log = std::fs::read_to_string(resumed_dir.join("log.txt")).unwrap();
    assert!(
        log.contains("interrupted at step 13") && log.contains("resumed"),
        "{log}"
    );
}

#[test]
fn ctrl_c_writes_a_checkpoint_before_exiting() {
    let dir = tempfile::tempdir().unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_train-3dgs"))
        .args([
            "--iterations",
            "1000000",
            "--size",
            "24",
            "--name",
            "sigint",
        ])
        .current_dir(dir.path())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut lines = std::io::BufReader::new(child.stdout.take().unwrap()).lines();
    let first = lines.next().unwrap().unwrap();
    assert!(first.contains("ready in"), "{first}");
    std::thread::sleep(std::time::Duration::from_millis(1500));
    let kill = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let rest: Vec<String> = lines.map(|l| l.unwrap()).collect();
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(130), "{rest:?}");
    let path = dir.path().join("runs/3dgs/sigint/checkpoint.safetensors");
    let checkpoint = Checkpoint::read(&path).unwrap();
    assert!(checkpoint.meta_parsed::<usize>("step").unwrap() > 0);
    assert!(rest.iter().any(|l| l.contains("--resume")), "{rest:?}");
}

#[test]
fn nerfstudio_folders_train_and_damaged_ones_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("yard");
    let device = Device::flex();
    let scene = SceneConfig {
        width: 32,
        height: 32,
        ..SceneConfig::new(Preset::Static, 2)
    }
    .build(&device);
    write_scene(&scene, &data, &[0], |_| {}).unwrap();
    let sky = scene.environment.background.map(linear_to_srgb);
    let background = format!("data.background=[{}, {}, {}]", sky[0], sky[1], sky[2]);
    let run = train(
        dir.path(),
        &[
            "--data",
            data.to_str().unwrap(),
            "--iterations",
            "20",
            "--name",
            "ns",
            "--set",
            &background,
        ],
    );
    assert!(run.status.success(), "{}", text(&run));
    // The same scene straight from the generator: the folder (8-bit images, millimetre depth)
    // must train to nearly the same result.
    let direct = train(
        dir.path(),
        &[
            "--set",
            "data.seed=2",
            "--size",
            "32",
            "--iterations",
            "20",
            "--name",
            "direct",
        ],
    );
    assert!(direct.status.success(), "{}", text(&direct));
    let psnr = |name: &str| {
        json(&dir.path().join(format!("runs/3dgs/{name}/metrics.json")))["final"]["psnr"]
            .as_f64()
            .unwrap()
    };
    let (from_folder, from_generator) = (psnr("ns"), psnr("direct"));
    assert!(from_folder > 10.0, "{from_folder}");
    assert!(
        (from_folder - from_generator).abs() < 0.3,
        "{from_folder} vs {from_generator}"
    );
    assert!(
        text(&run).contains("42 train / 6 held-out"),
        "{}",
        text(&run)
    );
    // A truncated image is refused, naming it.
    let victim = std::fs::read_dir(data.join("images"))
        .unwrap()
        .next()
        .unwrap()
        .unwrap()
        .path();
    let bytes = std::fs::read(&victim).unwrap();
    std::fs::write(&victim, &bytes[..bytes.len() / 3]).unwrap();
    let bad = train(
        dir.path(),
        &["--data", data.to_str().unwrap(), "--iterations", "5"],
    );
    assert!(!bad.status.success());
    let name = victim.file_name().unwrap().to_string_lossy().into_owned();
    assert!(text(&bad).contains(&name), "{}", text(&bad));
}

#[test]
fn configurations_print_and_bad_ones_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let shown = train(
        dir.path(),
        &[
            "--print-config",
            "--densify",
            "mcmc",
            "--set",
            "lambda_dssim=0.3",
        ],
    );
    assert!(shown.status.success(), "{}", text(&shown));
    let config: splatzoo_train::static_scene::StaticConfig =
        toml::from_str(&String::from_utf8_lossy(&shown.stdout)).unwrap();
    assert_eq!(config.lambda_dssim, 0.3);
    assert_eq!(
        config.densify.strategy,
        splatzoo_train::densify::Strategy::Mcmc
    );
    for (args, expected) in [
        (vec!["--set", "densify.no_such_knob=1"], "no_such_knob"),
        (vec!["--iterations", "0"], "iterations"),
        (vec!["--set", "lambda_dssim=2"], "lambda_dssim"),
        (
            vec!["--resume", "missing.safetensors"],
            "missing.safetensors",
        ),
    ] {
        let out = train(dir.path(), &args);
        assert!(!out.status.success(), "{args:?}");
        assert!(text(&out).contains(expected), "{args:?}: {}", text(&out));
    }
}

#[test]
fn render_writes_colour_depth_alpha_and_a_turntable() {
    let dir = tempfile::tempdir().unwrap();
    let run = train(
        dir.path(),
        &["--iterations", "10", "--size", "32", "--name", "r"],
    );
    assert!(run.status.success(), "{}", text(&run));
    let run_dir = dir.path().join("runs/3dgs/r");
    // Cameras in nerfstudio form: the scene's own export (32², one frame).
    let data = dir.path().join("yard");
    let scene = SceneConfig {
        width: 32,
        height: 32,
        ..SceneConfig::new(Preset::Static, 0)
    }
    .build(&Device::flex());
    write_scene(&scene, &data, &[0], |_| {}).unwrap();
    let out = dir.path().join("render");
    let render = Command::new(env!("CARGO_BIN_EXE_render"))
        .args(["--ply", run_dir.join("point_cloud.ply").to_str().unwrap()])
        .args(["--cameras", data.join("transforms.json").to_str().unwrap()])
        .args([
            "--turntable",
            "4",
            "--size",
            "24",
            "--out",
            out.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(render.status.success(), "{}", text(&render));
    let pngs = std::fs::read_dir(&out).unwrap().count();
    assert_eq!(
        pngs,
        48 * 3 + 1,
        "colour, depth and alpha per camera, and the GIF"
    );
    let first = std::fs::read_dir(data.join("images"))
        .unwrap()
        .next()
        .unwrap()
        .unwrap()
        .path();
    let stem = first.file_stem().unwrap().to_string_lossy().into_owned();
    let depth = image::open(out.join(format!("{stem}_depth.png"))).unwrap();
    assert!(matches!(depth, image::DynamicImage::ImageLuma16(_)));
    let depth = depth.into_luma16();
    assert!(
        depth.pixels().any(|p| p[0] > 0),
        "some depth where the scene is"
    );
    let colour = image::open(out.join(format!("{stem}.png"))).unwrap();
    assert_eq!((colour.width(), colour.height()), (32, 32));
    let gif = std::fs::File::open(out.join("turntable.gif")).unwrap();
    use image::AnimationDecoder;
    let frames = image::codecs::gif::GifDecoder::new(std::io::BufReader::new(gif))
        .unwrap()
        .into_frames()
        .collect_frames()
        .unwrap();
    assert_eq!(frames.len(), 4);
    assert_ne!(frames[0].buffer(), frames[2].buffer(), "the orbit moves");
    // From the checkpoint: the same Gaussians, the same image.
    let again = dir.path().join("again");
    let render = Command::new(env!("CARGO_BIN_EXE_render"))
        .args([
            "--checkpoint",
            run_dir.join("checkpoint.safetensors").to_str().unwrap(),
        ])
        .args(["--cameras", data.join("transforms.json").to_str().unwrap()])
        .args(["--out", again.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(render.status.success(), "{}", text(&render));
    assert_eq!(
        std::fs::read(again.join(format!("{stem}.png"))).unwrap(),
        std::fs::read(out.join(format!("{stem}.png"))).unwrap()
    );
    let none = Command::new(env!("CARGO_BIN_EXE_render"))
        .args(["--ply", "nowhere.ply", "--turntable", "2"])
        .output()
        .unwrap();
    assert!(
        !none.status.success() && text(&none).contains("nowhere.ply"),
        "{}",
        text(&none)
    );
}
