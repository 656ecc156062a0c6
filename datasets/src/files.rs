//! Atomic file writes ([`splatzoo_models::files`]) with errors naming the file in this crate's
//! error type.

use crate::DatasetError;
use std::path::Path;

/// Runs `write` on a temporary file beside `path` and renames it to `path` when it succeeds;
/// on failure the temporary file is removed and `path` is untouched.
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&Path) -> std::io::Result<()>,
) -> Result<(), DatasetError> {
    splatzoo_models::files::write_atomically(path, write)
        .map_err(|e| DatasetError::file(path, format!("cannot write ({e})")))
}

/// Writes `bytes` to `path` atomically.
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<(), DatasetError> {
    splatzoo_models::files::write_bytes(path, bytes)
        .map_err(|e| DatasetError::file(path, format!("cannot write ({e})")))
}
