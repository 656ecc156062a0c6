//! The `train-nlf` and `drive-nlf` commands end to end: baselines, metrics, ONNX files, an
//! interrupted run resumed bit-exactly, refused inputs, and driving a trained avatar.

use burn::tensor::Device;
use splatzoo_train::checkpoint::Checkpoint;
use std::path::Path;
use std::process::{Command, Output};

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

/// A small `train-nlf` run: `iterations` steps, one training and one held-out identity at 32².
fn train_nlf(dir: &Path, name: &str, extra: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_train-nlf"))
        .args(["--name", name])
        .args(["--set", "iterations=4", "--set", "eval_every=2"])
        .args(["--set", "train_subjects=2", "--set", "test_subjects=1"])
        .args(["--set", "size=32", "--set", "network.gaussians_per_face=1"])
        .args(["--set", "network.fpn_channels=8"])
        .args(extra)
        .current_dir(dir)
        .output()
        .unwrap()
}

#[test]
fn train_nlf_runs_end_to_end_with_its_baselines() {
    let dir = tempfile::tempdir().unwrap();
    // LPIPS weights in AlexNet's torchvision layout, with few channels.
    let device = Device::flex();
    let mut alex = Checkpoint::default();
    for (index, out, inp, k) in [
        (0, 4, 3, 11),
        (3, 4, 4, 5),
        (6, 4, 4, 3),
        (8, 4, 4, 3),
        (10, 4, 4, 3),
    ] {
        let n = out * inp * k * k;
        let weight: Vec<f32> = (0..n)
            .map(|i| ((i * 7919) % 13) as f32 / 13.0 - 0.45)
            .collect();
        alex.put(
            &format!("features.{index}.weight"),
            &burn::tensor::Tensor::<4>::from_data(
                burn::tensor::TensorData::new(weight, [out, inp, k, k]),
                &device,
            ),
        );
        alex.put(
            &format!("features.{index}.bias"),
            &burn::tensor::Tensor::<1>::zeros([out], &device),
        );
    }
    alex.write(&dir.path().join("alex.safetensors")).unwrap();
    let run = train_nlf(
        dir.path(),
        "smoke",
        &["--set", "lpips_weights=\"alex.safetensors\""],
    );
    assert!(run.status.success(), "{}", text(&run));
    let out = dir.path().join("runs/nlf/smoke");
    let metrics = json(&out.join("metrics.json"));
    for key in ["mean_colour", "untrained"] {
        let p = metrics["baselines"][key]["psnr"].as_f64().unwrap();
        assert!(p.is_finite() && p > 5.0, "{key}: {p}");
        let l = metrics["baselines"][key]["lpips"].as_f64().unwrap();
        assert!(l.is_finite() && l >= 0.0, "{key}: LPIPS {l}");
    }
    // Training moves the network: held-out PSNR rises above the untrained network's.
    let trained = metrics["final"]["psnr"].as_f64().unwrap();
    let untrained = metrics["baselines"]["untrained"]["psnr"].as_f64().unwrap();
    assert!(
        trained > untrained + 0.5,
        "held-out PSNR {trained} after training, {untrained} untrained"
    );
    let at_inputs = metrics["final"]["at_input_views"]["psnr"].as_f64().unwrap();
    assert!(at_inputs.is_finite() && at_inputs != trained);
    assert!(metrics["final"]["lpips"].as_f64().unwrap() >= 0.0);
    assert_eq!(metrics["evaluations"].as_array().unwrap().len(), 2);
    assert!(out.join("config.toml").exists() && out.join("renders").is_dir());
    for file in [
        "encoder.onnx",
        "decoder.onnx",
        "encoder.vectors.safetensors",
        "decoder.vectors.safetensors",
        "anchors.safetensors",
        "README.md",
    ] {
        let size = std::fs::metadata(out.join("onnx").join(file)).map(|m| m.len());
        assert!(size.as_ref().is_ok_and(|&s| s > 0), "onnx/{file}: {size:?}");
    }

    // Stopped after 1 step, resumed for the rest: the same network and Adam moments as the
    // uninterrupted run, bit for bit, and the same metrics history.
    let stopped = train_nlf(
        dir.path(),
        "split",
        &["--stop-after", "1", "--set", "onnx=false"],
    );
    assert_eq!(stopped.status.code(), Some(130), "{}", text(&stopped));
    let checkpoint = dir.path().join("runs/nlf/split/checkpoint.safetensors");
    let resumed = Command::new(env!("CARGO_BIN_EXE_train-nlf"))
        .args(["--name", "split", "--resume", checkpoint.to_str().unwrap()])
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert!(resumed.status.success(), "{}", text(&resumed));
    assert!(
        text(&resumed).contains("resumed at step 1"),
        "{}",
        text(&resumed)
    );
    let whole = Checkpoint::read(&out.join("checkpoint.safetensors")).unwrap();
    let split = Checkpoint::read(&checkpoint).unwrap();
    assert_eq!(whole.tensors.len(), split.tensors.len());
    assert!(
        whole.tensors.keys().any(|k| k.ends_with(".exp_avg_sq")),
        "Adam moments are saved"
    );
    for (name, tensor) in &whole.tensors {
        assert!(
            &split.tensors[name] == tensor,
            "{name} differs after resuming"
        );
    }
    let split_metrics = json(&dir.path().join("runs/nlf/split/metrics.json"));
    assert_eq!(split_metrics["final"]["psnr"], metrics["final"]["psnr"]);
    for key in ["mean_colour", "untrained"] {
        assert_eq!(
            split_metrics["baselines"][key]["psnr"],
            metrics["baselines"][key]["psnr"]
        );
    }
    // Encoder weights that are not there are named.
    let weights = train_nlf(
        dir.path(),
        "weights",
        &["--set", "encoder_weights=\"resnet18-missing.safetensors\""],
    );
    assert!(
        !weights.status.success() && text(&weights).contains("resnet18-missing.safetensors"),
        "{}",
        text(&weights)
    );
    // A checkpoint of another network is refused, naming the difference.
    let other = Command::new(env!("CARGO_BIN_EXE_train-nlf"))
        .args(["--resume", checkpoint.to_str().unwrap()])
        .args(["--set", "network.fpn_channels=16"])
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert!(
        !other.status.success() && text(&other).contains("network configuration"),
        "{}",
        text(&other)
    );

    // The checkpoint drives an avatar through a walk: PNG frames and a GIF, frames differ.
    let drive = Command::new(env!("CARGO_BIN_EXE_drive-nlf"))
        .args([
            "--checkpoint",
            out.join("checkpoint.safetensors").to_str().unwrap(),
        ])
        .args(["--frames", "4", "--size", "32", "--out", "drive"])
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert!(drive.status.success(), "{}", text(&drive));
    let frames = dir.path().join("drive");
    assert!(frames.join("drive.gif").exists());
    let first = std::fs::read(frames.join("frame_0000.png")).unwrap();
    let last = std::fs::read(frames.join("frame_0003.png")).unwrap();
    assert_ne!(first, last, "the walk moves the avatar");
    let missing = Command::new(env!("CARGO_BIN_EXE_drive-nlf"))
        .args(["--checkpoint", "nowhere.safetensors"])
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert!(!missing.status.success() && text(&missing).contains("nowhere.safetensors"));
    let bad = Command::new(env!("CARGO_BIN_EXE_train-nlf"))
        .args(["--set", "network.fusion=\"median\""])
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert!(
        !bad.status.success() && text(&bad).contains("fusion"),
        "{}",
        text(&bad)
    );
}

/// `train-nlf` on a THuman2.0 layout (the datasets crate's GHG fixture) and `drive-nlf` on its
/// checkpoint: the held-out subject of the capture is driven, and a subject the capture does not
/// have is refused by name.
#[test]
fn train_and_drive_nlf_on_a_capture() {
    use splatzoo_datasets::fixtures::{ghg_fit, ghg_subject};
    let dir = tempfile::tempdir().unwrap();
    let thuman = dir.path().join("THuman");
    let positions = [0, 3, 6, 8, 11, 13];
    for (split, subject) in [("train", "0004"), ("train", "0007"), ("val", "0011")] {
        ghg_subject(&thuman.join(split), subject, &positions, 1);
        ghg_fit(&thuman, subject);
    }
    let run = train_nlf(
        dir.path(),
        "thuman",
        &[
            "--set",
            "data.train=\"THuman/train\"",
            "--set",
            "data.test=\"THuman/val\"",
            "--set",
            "onnx=false",
        ],
    );
    assert!(run.status.success(), "{}", text(&run));
    assert!(
        text(&run).contains("subjects: 2 training"),
        "{}",
        text(&run)
    );
    let checkpoint = dir.path().join("runs/nlf/thuman/checkpoint.safetensors");
    let drive = |subject: &str| {
        Command::new(env!("CARGO_BIN_EXE_drive-nlf"))
            .args(["--checkpoint", checkpoint.to_str().unwrap()])
            .args(["--subject", subject, "--frames", "2", "--out", "drive"])
            .current_dir(dir.path())
            .output()
            .unwrap()
    };
    let driven = drive("10000");
    assert!(driven.status.success(), "{}", text(&driven));
    assert!(dir.path().join("drive/drive.gif").exists());
    let absent = drive("10001");
    assert!(!absent.status.success());
    assert!(
        text(&absent).contains("1 subject(s) with a fit"),
        "{}",
        text(&absent)
    );
}
