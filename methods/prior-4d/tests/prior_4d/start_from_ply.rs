//! Stage D from user-given `.ply` files: a scene prior and an avatar written by an earlier run
//! are read back bit-exactly as stages A and B's results (with no steps of either), the scene's
//! geometry stays the file's through stage D, and bad files are refused by name.

use crate::trainer::into_stage_d;
use crate::values;
use burn::tensor::Device;
use splatzoo_prior_4d::Prior4d;
use splatzoo_prior_4d::config::Prior4dConfig;
use splatzoo_train::densify::Strategy;
use splatzoo_train::gaussians::GaussianSet;
use splatzoo_train::harness::Method;
use splatzoo_train::ply::write_ply;
use std::path::Path;

fn same(what: &str, got: &GaussianSet, want: &GaussianSet) {
    for (field, a, b) in [
        (
            "means",
            values(got.means.clone()),
            values(want.means.clone()),
        ),
        (
            "quats",
            values(got.quats.clone()),
            values(want.quats.clone()),
        ),
        (
            "log_scales",
            values(got.log_scales.clone()),
            values(want.log_scales.clone()),
        ),
        (
            "opacity",
            values(got.opacity_logits.clone()),
            values(want.opacity_logits.clone()),
        ),
        (
            "sh_dc",
            values(got.sh_dc.clone()),
            values(want.sh_dc.clone()),
        ),
    ] {
        assert_eq!(a, b, "{what}: {field} differ from the file's");
    }
}

/// A config whose stages A and B are the given files, no steps of either.
fn from_files(scene: &Path, avatar: &Path) -> Prior4dConfig {
    let mut config = into_stage_d(0);
    config.scene.initial_ply = Some(scene.to_owned());
    config.avatar.initial_ply = Some(avatar.to_owned());
    config.scene.steps = 0;
    config.scene.densify.strategy = Strategy::None;
    config.avatar.steps = 0;
    config.iterations = 3;
    config
}

#[test]
fn stage_d_starts_from_user_ply_files() {
    let device = Device::flex();
    let dir = tempfile::tempdir().unwrap();
    let (scene_path, avatar_path) = (dir.path().join("scene.ply"), dir.path().join("avatar.ply"));
    let config = into_stage_d(5);
    let mut earlier = Prior4d::new(config.clone(), &device).expect("a tiny run");
    while earlier.steps() < config.joint_start() {
        earlier.step().expect("a step");
    }
    write_ply(&scene_path, &earlier.scene.node.set).unwrap();
    write_ply(&avatar_path, earlier.avatar.node.canonical_set()).unwrap();

    let config = from_files(&scene_path, &avatar_path);
    let mut method = Prior4d::new(config.clone(), &device).expect("starts from the files");
    assert_eq!(config.joint_start(), 0);
    same("scene", &method.scene.node.set, &earlier.scene.node.set);
    same(
        "avatar",
        method.avatar.node.canonical_set(),
        earlier.avatar.node.canonical_set(),
    );
    let decisions = method.decisions().join("\n");
    for path in [&scene_path, &avatar_path] {
        let shown = path.display().to_string();
        assert!(decisions.contains(&shown), "no {shown} in:\n{decisions}");
    }
    while method.steps() < config.iterations {
        let report = method.step().expect("a stage-D step");
        assert!(report.loss.is_finite(), "loss {}", report.loss);
    }
    // Stage D trains the scene's SH only: its geometry is still the file's.
    let joint = method.joint.as_ref().expect("stage D");
    let (got, want) = (&joint.scene.set, &earlier.scene.node.set);
    assert_eq!(values(got.means.clone()), values(want.means.clone()));
    assert_eq!(
        values(got.log_scales.clone()),
        values(want.log_scales.clone())
    );
}

#[test]
fn bad_ply_files_are_refused_by_name() {
    let device = Device::flex();
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing.ply");
    let scene_path = dir.path().join("scene.ply");
    let tiny = GaussianSet::from_points(
        &[[0.0, 0.0, 1.0], [0.5, 0.0, 1.0]],
        &[[0.5; 3], [0.2; 3]],
        &[0.1, 0.1],
        &device,
    );
    write_ply(&scene_path, &tiny).unwrap();
    let error = |config: Prior4dConfig| match Prior4d::new(config, &device) {
        Ok(_) => panic!("a bad file was accepted"),
        Err(e) => e.to_string(),
    };
    let e = error(from_files(&missing, &scene_path));
    assert!(
        e.contains("scene.initial_ply") && e.contains("missing.ply"),
        "{e}"
    );
    // Two Gaussians are not an avatar of the body's vertices.
    let e = error(from_files(&scene_path, &scene_path));
    assert!(
        e.contains("avatar.initial_ply") && e.contains("2 Gaussians"),
        "{e}"
    );
}
