//! `train-prior4d` speed and memory per backend on the default capture (200×150): optimiser
//! steps/s of stage A (the scene prior, at its starting points: density control starts later),
//! stage B (the avatar prior) and stage D (three renders a step: composite, human-only,
//! scene-only), the evaluation view's render rate (scene and placed avatar, read back) and
//! peak resident memory. The paper gives no speed or memory figure.
//!
//! ```sh
//! cargo bench --workspace --bench prior4d                 # flex, ndarray, wgpu
//! cargo bench --workspace --bench prior4d -- flex 20      # one backend, 20 steps a stage
//! ```
//!
//! Each backend runs in its own child process (the engine's bench harness).

#[path = "../../../train/benches/common/mod.rs"]
mod common;

use common::peak_rss_mib;
use splatzoo_prior_4d::config::Prior4dConfig;
use splatzoo_prior_4d::{Prior4d, Stage};
use splatzoo_train::backend::Backend;
use splatzoo_train::harness::Method;
use splatzoo_train::host_f32;
use splatzoo_train::scene::SceneNode;
use std::time::Instant;

const WARM_UP: usize = 3;
const FRAMES: usize = 5;

/// Steps/s over the next `steps` steps after `WARM_UP`, all inside `stage`.
fn stage_rate(method: &mut Prior4d, stage: Stage, steps: usize) -> f64 {
    for _ in 0..WARM_UP {
        method.step().expect("step");
    }
    let start = Instant::now();
    for _ in 0..steps {
        assert_eq!(method.stage(method.steps()), stage, "the stage ended early");
        method.step().expect("step");
    }
    steps as f64 / start.elapsed().as_secs_f64()
}

/// In the child: steps/s of stages A, B and D, the evaluation view's FPS, peak MiB and the
/// scene's and avatar's Gaussian counts.
fn child(backend: Backend, steps: usize) -> Vec<f64> {
    let per_stage = WARM_UP + steps;
    let mut config = Prior4dConfig {
        backend,
        ..Prior4dConfig::default()
    };
    config.scene.steps = per_stage;
    config.avatar.steps = per_stage;
    config.iterations = config.joint_start() + per_stage;
    // A few stage-A steps leave the points at their initial opacity (0.1): let stage C take
    // them as ground candidates.
    config.plane.min_opacity = 0.05;
    let device = backend.device();
    let mut method = Prior4d::new(config, &device).expect("the default capture");
    let scene = stage_rate(&mut method, Stage::Scene, steps);
    let avatar = stage_rate(&mut method, Stage::Avatar, steps);
    let joint = stage_rate(&mut method, Stage::Joint, steps);
    let stage_d = method.joint.as_ref().expect("stage D");
    let splats = stage_d.scene_splats(&method.capture);
    let start = Instant::now();
    for t in 0..FRAMES {
        let layers = stage_d
            .render_eval(&method.capture, &splats, t, true)
            .expect("render");
        let _ = host_f32(&layers.color);
    }
    let fps = FRAMES as f64 / start.elapsed().as_secs_f64();
    vec![
        scene,
        avatar,
        joint,
        fps,
        peak_rss_mib(),
        method.scene.node.gaussians() as f64,
        stage_d.avatar.gaussians() as f64,
    ]
}

fn main() {
    common::run(
        20,
        child,
        |steps| {
            println!(
                "train-prior4d on the default capture (200×150), {steps} timed steps a stage \
                 after {WARM_UP} warm-up; stage A at its starting points"
            );
            println!("(the paper gives no speed or memory figure)");
            println!(
                "| backend | A steps/s | B steps/s | D steps/s | eval FPS | peak memory (RSS) | scene / avatar Gaussians |"
            );
            println!("|---|---|---|---|---|---|---|");
        },
        |backend, figures| match figures {
            Ok(f) if f.len() == 7 => println!(
                "| {} | {:.2} | {:.2} | {:.2} | {:.1} | {:.0} MiB | {} / {} |",
                backend.name(),
                f[0],
                f[1],
                f[2],
                f[3],
                f[4],
                f[5],
                f[6]
            ),
            Ok(f) => println!("| {} | unexpected output {f:?} | | | | | |", backend.name()),
            Err(e) => println!("| {} | failed: {e} | | | | | |", backend.name()),
        },
    );
}
