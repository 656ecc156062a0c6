//! Cross-crate interop tests live in `tests/interop.rs`: every `train-*` binary runs two steps
//! on its default configuration and its outputs are read back by the project's own readers,
//! and a checkpoint written by one process resumes in another bit-exactly on the CPU. The
//! binaries are the workspace's (`cargo test --workspace` builds them).
