//! safetensors files of named tensors: [`decode`] and [`encode`] (shared with the trainer's
//! checkpoints), and [`WeightFile`], weights with PyTorch names (torchvision's `conv1.weight`,
//! `layer1.0.bn1.running_var`, …) read as `f32` (from F32 or F64), taken by name with their
//! shapes checked against a module's parameters. Missing or misshapen tensors are errors naming
//! the file and tensor.

use burn::module::Param;
use burn::tensor::{Device, Tensor, TensorData};
use std::collections::BTreeMap;
use std::path::Path;

#[derive(Debug, thiserror::Error)]
pub enum WeightsError {
    #[error("{file}: {problem}")]
    File { file: String, problem: String },
    #[error("{file}: `{name}`: {problem}")]
    Tensor {
        file: String,
        name: String,
        problem: String,
    },
}

/// The tensors of one file, by name.
pub struct WeightFile {
    pub file: String,
    pub tensors: Tensors,
    /// Names taken so far (to report what a model did not use).
    taken: std::cell::RefCell<Vec<String>>,
}

impl WeightFile {
    /// Tensors already in memory, `file` naming them in errors.
    pub fn new(file: impl Into<String>, tensors: Tensors) -> Self {
        Self {
            file: file.into(),
            tensors,
            taken: Default::default(),
        }
    }

    pub fn read(path: &Path) -> Result<Self, WeightsError> {
        let file = path.display().to_string();
        let bytes = std::fs::read(path).map_err(|e| WeightsError::File {
            file: file.clone(),
            problem: format!("cannot read ({e})"),
        })?;
        let (tensors, _) = decode(&bytes).map_err(|(name, problem)| match name {
            Some(name) => WeightsError::Tensor {
                file: file.clone(),
                name,
                problem,
            },
            None => WeightsError::File {
                file: file.clone(),
                problem,
            },
        })?;
        Ok(Self {
            file,
            tensors,
            taken: Default::default(),
        })
    }

    /// The tensor `name`, which must have exactly `shape`.
    pub fn tensor<const D: usize>(
        &self,
        name: &str,
        shape: [usize; D],
        device: &Device,
    ) -> Result<Tensor<D>, WeightsError> {
        let err = |problem: String| WeightsError::Tensor {
            file: self.file.clone(),
            name: name.to_owned(),
            problem,
        };
        let (found, values) = self
            .tensors
            .get(name)
            .ok_or_else(|| err(format!("missing (expected shape {shape:?})")))?;
        if found[..] != shape[..] {
            return Err(err(format!("shape {found:?}, expected {shape:?}")));
        }
        if let Some(i) = values.iter().position(|v| !v.is_finite()) {
            return Err(err(format!("non-finite value at flat index {i}")));
        }
        self.taken.borrow_mut().push(name.to_owned());
        Ok(Tensor::from_data(
            TensorData::new(values.clone(), shape.to_vec()),
            device,
        ))
    }

    /// Replaces `param` by the tensor `name` of the same shape.
    pub fn load_into<const D: usize>(
        &self,
        name: &str,
        param: &mut Param<Tensor<D>>,
    ) -> Result<(), WeightsError> {
        let current = param.val();
        let tensor = self.tensor(name, current.dims(), &current.device())?;
        *param = Param::from_tensor(tensor);
        Ok(())
    }

    /// Names present in the file that no load has taken (e.g. a classifier head `fc.*`).
    pub fn untaken(&self) -> Vec<String> {
        let taken = self.taken.borrow();
        self.tensors
            .keys()
            .filter(|k| !taken.contains(k))
            .cloned()
            .collect()
    }
}

/// Named tensors: shape and `f32` values.
pub type Tensors = BTreeMap<String, (Vec<usize>, Vec<f32>)>;

/// Parses a safetensors file: F32 and F64 tensors as `f32` (torchvision's integer
/// `num_batches_tracked` counters are skipped), and the metadata. An error carries the tensor's
/// name where one is at fault.
#[allow(clippy::type_complexity)]
pub fn decode(
    bytes: &[u8],
) -> Result<(Tensors, BTreeMap<String, String>), (Option<String>, String)> {
    let (_, header) = safetensors::SafeTensors::read_metadata(bytes)
        .map_err(|e| (None, format!("not a safetensors file ({e})")))?;
    let parsed = safetensors::SafeTensors::deserialize(bytes)
        .map_err(|e| (None, format!("not a safetensors file ({e})")))?;
    let mut tensors = BTreeMap::new();
    for (name, view) in parsed.tensors() {
        let data = view.data();
        let values: Vec<f32> = match view.dtype() {
            safetensors::Dtype::F32 => data
                .chunks_exact(4)
                .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
                .collect(),
            safetensors::Dtype::F64 => data
                .chunks_exact(8)
                .map(|b| f64::from_le_bytes(b.try_into().expect("8 bytes")) as f32)
                .collect(),
            safetensors::Dtype::I64 if name.ends_with("num_batches_tracked") => continue,
            other => return Err((Some(name), format!("dtype {other:?}, expected F32 or F64"))),
        };
        tensors.insert(name, (view.shape().to_vec(), values));
    }
    let metadata = header
        .metadata()
        .clone()
        .unwrap_or_default()
        .into_iter()
        .collect();
    Ok((tensors, metadata))
}

/// The safetensors bytes of `tensors` (as F32) with `metadata`.
pub fn encode(tensors: &Tensors, metadata: &BTreeMap<String, String>) -> Result<Vec<u8>, String> {
    let raw: Vec<(String, Vec<usize>, Vec<u8>)> = tensors
        .iter()
        .map(|(n, (s, v))| {
            (
                n.clone(),
                s.clone(),
                v.iter().flat_map(|x| x.to_le_bytes()).collect(),
            )
        })
        .collect();
    let views = raw.iter().map(|(n, s, b)| {
        (
            n.clone(),
            safetensors::tensor::TensorView::new(safetensors::Dtype::F32, s.clone(), b)
                .expect("byte length matches the shape"),
        )
    });
    let metadata = (!metadata.is_empty()).then(|| metadata.clone().into_iter().collect());
    safetensors::serialize(views, metadata).map_err(|e| format!("cannot serialise ({e})"))
}

/// Writes tensors as an F32 safetensors file (fixtures, exports), atomically.
pub fn write_safetensors(path: &Path, tensors: &Tensors) -> std::io::Result<()> {
    let bytes = encode(tensors, &BTreeMap::new()).map_err(std::io::Error::other)?;
    crate::files::write_bytes(path, &bytes)
}

/// Every float parameter of `module` under its dotted field path (`encoder.lateral.0.weight`),
/// as Burn's derive names the fields.
pub fn module_tensors<M: burn::module::Module>(module: &M) -> Tensors {
    struct Collect {
        path: Vec<String>,
        out: Tensors,
    }
    impl burn::module::ModuleVisitor for Collect {
        fn enter_module(&mut self, name: &str, _: &str) {
            self.path.push(name.to_owned());
        }
        fn exit_module(&mut self, _: &str, _: &str) {
            self.path.pop();
        }
        fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
            let t = param.val();
            let values = t
                .to_data()
                .convert::<f32>()
                .try_into_vec::<f32>()
                .expect("converted to f32");
            self.out
                .insert(self.path.join("."), (t.dims().to_vec(), values));
        }
    }
    let mut c = Collect {
        path: Vec::new(),
        out: BTreeMap::new(),
    };
    module.visit(&mut c);
    c.out
}

/// `module` with every float parameter replaced by the tensor of the same path in `file`
/// (written by [`module_tensors`]); the first missing or misshapen one is the error.
pub fn load_module<M: burn::module::Module>(
    module: M,
    file: &WeightFile,
) -> Result<M, WeightsError> {
    struct Load<'a> {
        path: Vec<String>,
        file: &'a WeightFile,
        error: Option<WeightsError>,
    }
    impl burn::module::ModuleMapper for Load<'_> {
        fn enter_module(&mut self, name: &str, _: &str) {
            self.path.push(name.to_owned());
        }
        fn exit_module(&mut self, _: &str, _: &str) {
            self.path.pop();
        }
        fn map_float<const D: usize>(&mut self, param: Param<Tensor<D>>) -> Param<Tensor<D>> {
            let current = param.val();
            match self
                .file
                .tensor(&self.path.join("."), current.dims(), &current.device())
            {
                // `map` keeps the parameter's training state (`train()` must still make it
                // require a gradient).
                Ok(t) => param.map(|_| t),
                Err(e) => {
                    self.error.get_or_insert(e);
                    param
                }
            }
        }
    }
    let mut l = Load {
        path: Vec::new(),
        file,
        error: None,
    };
    let module = module.map(&mut l);
    match l.error {
        Some(e) => Err(e),
        None => Ok(module),
    }
}
