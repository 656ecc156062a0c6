//! `train-nlf`: NLF-GS trained across synthetic identities (the multi-view studio preset on a
//! six-camera ring; inputs and supervision at 0°, 120°, 240°), evaluated zero-shot on held-out
//! identities at the novel views 60°, 180°, 300° (and at the input views) against two
//! baselines: the untrained network and each Gaussian taking the mean colour of its
//! projections. Writes `runs/nlf/<name>/` with `config.toml`, `metrics.json`, `log.txt`,
//! held-out renders (render | truth), `checkpoint.safetensors` (the network by parameter path,
//! the Adam moments, the configuration; `drive-nlf` reads it, `--resume` continues from it) and
//! `onnx/`: the encoder and decoder as ONNX graphs with test vectors
//! ([`splatzoo_nlf_gs::onnx`]). The command line is the harness's
//! ([`splatzoo_train::harness::cli`]).
//!
//! ```sh
//! cargo run --release --bin train-nlf
//! cargo run --release --bin train-nlf -- --set iterations=50 --set network.depth=\"50\"
//! cargo run --release --bin train-nlf -- --resume runs/nlf/default/checkpoint.safetensors
//! ```

fn main() -> std::process::ExitCode {
    splatzoo_train::harness::cli::main::<splatzoo_nlf_gs::trainer::NlfTrainer>()
}
