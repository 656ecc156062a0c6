//! `train-avatar`: a per-subject animatable Gaussian avatar from a monocular video, on the
//! synthetic `monocular` preset (a person walking a circle in a room, a hand-held camera; every
//! fifth frame held out as a novel pose, a fixed corner camera as the novel view).
//!
//! ```sh
//! cargo run --release --bin train-avatar                            # embedded default
//! cargo run --release --bin train-avatar -- --no-pose-refinement    # the ablation arm
//! cargo run --release --bin train-avatar -- --set node.placement=\"vertices\"
//! cargo run --release --bin train-avatar -- --resume runs/avatar/default/checkpoint.safetensors
//! ```
//!
//! Every knob is in the TOML configuration ([`splatzoo_train::avatar::AvatarConfig`]);
//! `--print-config` shows the defaults. Each run writes `runs/avatar/<name>/`: `config.toml`,
//! `log.txt`, `metrics.json` (novel-view and novel-pose scores, full image and human region,
//! pose error; the plain-template baseline), `checkpoint.safetensors`, `canonical.ply` (INRIA
//! layout), `refined_poses.npz` (AMASS layout) and `renders/` (render | masked truth).

fn main() -> std::process::ExitCode {
    splatzoo_train::harness::cli::main::<splatzoo_train::avatar::AvatarTrainer>()
}
