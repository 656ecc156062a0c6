//! SMPL-family models from a Python pickle (`.pkl`) holding plain numpy arrays, as released for
//! SMPL-H/SMPL-X and as `pickle.dump` of converted SMPL files, read with [`crate::pickle`]
//! (SMPL's `J_regressor` is a scipy sparse matrix, densified). The original SMPL release pickles
//! `chumpy` objects, which cannot be read without Python: that gets an error saying how to
//! convert the file.

use super::model::{BodyModel, BodyModelError};
use super::npz::{Array, assemble, field_err};
use crate::pickle::{Value, dict_get, to_array, unpickle};
use std::path::Path;

/// Loads an SMPL-family model from a `.pkl` of numpy arrays (keys as in [`super::load_npz`]).
pub fn load_pkl(path: &Path) -> Result<BodyModel, BodyModelError> {
    let file = path.display().to_string();
    let data = std::fs::read(path).map_err(|e| BodyModelError::File {
        file: file.clone(),
        problem: format!("cannot read ({e})"),
    })?;
    let root = unpickle(&data).map_err(|problem| BodyModelError::File {
        file: file.clone(),
        problem: format!("not a readable pickle: {problem}"),
    })?;
    let Value::Dict(items) = &*root else {
        return Err(BodyModelError::File {
            file,
            problem: "the pickle does not hold a dict of arrays".into(),
        });
    };
    let mut fetch = |key: &str| -> Result<Option<Array>, BodyModelError> {
        let Some(v) = dict_get(items, key) else {
            return Ok(None);
        };
        to_array(v).map(Some).map_err(|problem| {
            let hint = if problem.contains("chumpy") {
                ". This is the original chumpy pickle: convert it once with Python (see the README, \
                 'Body models') to .npz or a pickle of plain numpy arrays"
            } else {
                ""
            };
            field_err(&file, key, format!("{problem}{hint}"))
        })
    };
    assemble(&file, &mut fetch)
}
