//! Checkpoints: named `f32` tensors with PyTorch-style dotted names (`splats.means`,
//! `optimizer.means.exp_avg`) and string metadata (step, random state, configuration) in one
//! safetensors file, written atomically so that an interrupted write never leaves half a file.
//! Values are stored bit for bit, which is what lets `--resume` continue exactly.

use burn::tensor::{Device, Tensor, TensorData};
use std::collections::{BTreeMap, HashMap};
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
        let bytes: Vec<(String, Vec<usize>, Vec<u8>)> = self
            .tensors
            .iter()
            .map(|(name, (shape, values))| {
                let raw = values.iter().flat_map(|v| v.to_le_bytes()).collect();
                (name.clone(), shape.clone(), raw)
            })
            .collect();
        let views = bytes.iter().map(|(name, shape, raw)| {
            let view =
                safetensors::tensor::TensorView::new(safetensors::Dtype::F32, shape.clone(), raw)
                    .expect("byte length matches the shape");
            (name.clone(), view)
        });
        let metadata: HashMap<String, String> = self.metadata.clone().into_iter().collect();
        let file_error = |problem: String| CheckpointError::File {
            file: path.display().to_string(),
            problem,
        };
        let buffer = safetensors::serialize(views, Some(metadata))
            .map_err(|e| file_error(format!("cannot serialise ({e})")))?;
        splatzoo_datasets::files::write_bytes(path, &buffer).map_err(|e| file_error(e.to_string()))
    }

    pub fn read(path: &Path) -> Result<Self, CheckpointError> {
        let file_error = |problem: String| CheckpointError::File {
            file: path.display().to_string(),
            problem,
        };
        let bytes = std::fs::read(path).map_err(|e| file_error(format!("cannot read ({e})")))?;
        let (_, header) = safetensors::SafeTensors::read_metadata(&bytes)
            .map_err(|e| file_error(format!("not a safetensors file ({e})")))?;
        let parsed = safetensors::SafeTensors::deserialize(&bytes)
            .map_err(|e| file_error(format!("not a safetensors file ({e})")))?;
        let mut checkpoint = Checkpoint {
            origin: path.display().to_string(),
            metadata: header
                .metadata()
                .clone()
                .unwrap_or_default()
                .into_iter()
                .collect(),
            ..Default::default()
        };
        for (name, view) in parsed.tensors() {
            if view.dtype() != safetensors::Dtype::F32 {
                return Err(checkpoint
                    .entry_error(&name, format!("dtype {:?}, expected F32", view.dtype())));
            }
            let values = view
                .data()
                .chunks_exact(4)
                .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
                .collect();
            checkpoint
                .tensors
                .insert(name, (view.shape().to_vec(), values));
        }
        Ok(checkpoint)
    }
}
