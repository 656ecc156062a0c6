//! `train-3dgs`: static-scene 3D Gaussian splatting, on the synthetic static preset (a yard
//! seen by 48 cameras; every 8th held out) or on a nerfstudio `transforms.json` folder. It is the
//! scene-prior stage other methods reuse.
//!
//! ```sh
//! cargo run --release --bin train-3dgs                      # embedded default
//! cargo run --release --bin train-3dgs -- --data path/to/nerfstudio/folder --backend wgpu
//! cargo run --release --bin train-3dgs -- --config my.toml --set densify.strategy=mcmc
//! cargo run --release --bin train-3dgs -- --resume runs/3dgs/default/checkpoint.safetensors
//! ```
//!
//! Every knob is in the TOML configuration ([`splatzoo_train::static_scene::StaticConfig`]);
//! `--print-config` shows the defaults. Each run writes `runs/3dgs/<name>/`: `config.toml`,
//! `log.txt`, `metrics.json` (every evaluation), `checkpoint.safetensors`, `point_cloud.ply`
//! (INRIA layout) and `renders/` (held-out render | ground truth). Ctrl-C writes a checkpoint
//! before exiting. The command line is the harness's ([`splatzoo_train::harness::cli`]).

fn main() -> std::process::ExitCode {
    splatzoo_train::harness::cli::main::<splatzoo_train::static_scene::StaticTrainer>()
}
