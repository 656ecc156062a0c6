//! Checkpoints: named `f32` tensors with PyTorch-style dotted names (`splats.means`,
//! `optimizer.means.exp_avg`) and string metadata (step, random state, configuration) in one
//! safetensors file, written atomically so that an interrupted write never leaves half a file.
//! Values are stored bit for bit, which is what lets `--resume` continue exactly.

use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_models::networks::weights::{
    WeightFile, WeightsError, decode, encode, load_module, module_tensors,
};
use std::collections::BTreeMap;
use std::path::Path;

#[derive(Debug, thiserror::Error)]
pub enum CheckpointError {
    #[error("{file}: {problem}")]
    File { file: String, problem: String },
    #[error("{file}: `{name}`: {problem}")]
    Entry {
        file: String,
        name: String,
        problem: String,
    },
}

/// Tensors and metadata, in memory.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Checkpoint {
    /// Where it was read from (named in errors); empty for a new one.
    pub origin: String,
    pub tensors: BTreeMap<String, (Vec<usize>, Vec<f32>)>,
    pub metadata: BTreeMap<String, String>,
}

impl Checkpoint {
    /// Stores every parameter of `module` as `<prefix>.<parameter path>`.
    pub fn put_module<M: burn::module::Module>(&mut self, prefix: &str, module: &M) {
        for (k, v) in module_tensors(module) {
            self.tensors.insert(format!("{prefix}.{k}"), v);
        }
    }

    /// `fresh` with the parameters [`Self::put_module`] stored under `prefix` (entries under
    /// `<prefix>.optimizer.` — a [`crate::module_adam::ModuleAdam`]'s moments — are not
    /// parameters and are skipped).
    pub fn module<M: burn::module::Module>(
        &self,
        fresh: M,
        prefix: &str,
    ) -> Result<M, WeightsError> {
        let prefix = format!("{prefix}.");
        let tensors = self
            .tensors
            .iter()
            .filter_map(|(k, v)| {
                k.strip_prefix(&prefix)
                    .filter(|rest| !rest.starts_with("optimizer."))
                    .map(|rest| (rest.to_owned(), v.clone()))
            })
            .collect();
        load_module(fresh, &WeightFile::new(self.origin.clone(), tensors))
    }

    pub fn put<const D: usize>(&mut self, name: &str, tensor: &Tensor<D>) {
        let values = crate::host_f32(tensor);
        self.tensors
            .insert(name.to_owned(), (tensor.dims().to_vec(), values));
    }

    pub fn put_meta(&mut self, key: &str, value: impl ToString) {
        self.metadata.insert(key.to_owned(), value.to_string());
    }

    fn entry_error(&self, name: &str, problem: impl Into<String>) -> CheckpointError {
        CheckpointError::Entry {
            file: self.origin.clone(),
            name: name.to_owned(),
            problem: problem.into(),
        }
    }

    /// The tensor `name`; `expected` fixes every dimension that is `Some`.
    pub fn tensor<const D: usize>(
        &self,
        name: &str,
        expected: [Option<usize>; D],
        device: &Device,
    ) -> Result<Tensor<D>, CheckpointError> {
        let (shape, values) = self
            .tensors
            .get(name)
            .ok_or_else(|| self.entry_error(name, "missing"))?;
        let fits = shape.len() == D
            && expected
                .iter()
                .zip(shape)
                .all(|(e, &s)| e.is_none_or(|e| e == s));
        if !fits {
            let want: Vec<String> = expected
                .iter()
                .map(|e| e.map_or("_".to_owned(), |e| e.to_string()))
                .collect();
            return Err(self.entry_error(
                name,
                format!("shape {shape:?}, expected [{}]", want.join(", ")),
            ));
        }
        if let Some(bad) = values.iter().position(|v| !v.is_finite()) {
            return Err(self.entry_error(name, format!("non-finite value at flat index {bad}")));
        }
        Ok(Tensor::from_data(
            TensorData::new(values.clone(), shape.clone()),
            device,
        ))
    }

    pub fn meta(&self, key: &str) -> Result<&str, CheckpointError> {
        self.metadata
            .get(key)
            .map(String::as_str)
            .ok_or_else(|| self.entry_error(key, "metadata entry missing"))
    }

    /// A metadata entry parsed as `T`.
    pub fn meta_parsed<T: std::str::FromStr>(&self, key: &str) -> Result<T, CheckpointError> {
        let text = self.meta(key)?;
        text.parse()
            .map_err(|_| self.entry_error(key, format!("cannot parse `{text}`")))
    }

    /// Writes the safetensors file atomically.
    pub fn write(&self, path: &Path) -> Result<(), CheckpointError> {
        let file_error = |problem: String| CheckpointError::File {
            file: path.display().to_string(),
            problem,
        };
        let buffer = encode(&self.tensors, &self.metadata).map_err(file_error)?;
        splatzoo_datasets::files::write_bytes(path, &buffer).map_err(|e| file_error(e.to_string()))
    }

    pub fn read(path: &Path) -> Result<Self, CheckpointError> {
        let origin = path.display().to_string();
        let bytes = std::fs::read(path).map_err(|e| CheckpointError::File {
            file: origin.clone(),
            problem: format!("cannot read ({e})"),
        })?;
        let (tensors, metadata) = decode(&bytes).map_err(|(name, problem)| match name {
            Some(name) => CheckpointError::Entry {
                file: origin.clone(),
                name,
                problem,
            },
            None => CheckpointError::File {
                file: origin.clone(),
                problem,
            },
        })?;
        Ok(Checkpoint {
            origin,
            tensors,
            metadata,
        })
    }
}
