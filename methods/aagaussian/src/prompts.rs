//! Prompt embeddings for a real denoiser (spec §3, "Prompts"): a user's text encoder writes them
//! once into a safetensors file, and each stacked model row reads the one its prompt kind and
//! view class select. Keys (each `[L, D]` f32, all alike):
//! - `cond.front`, `cond.side`, `cond.back`, `cond.overhead`: the prompt with HumanGaussian's
//!   view suffixes (or `cond` alone for every view);
//! - `negative.<view>` or `negative`: the negative prompt;
//! - `null`: the empty prompt.
//!
//! Nothing is downloaded: a missing key is an error naming the file and the keys it looked for.

use crate::error::AagError;
use crate::score::{Conditioning, PromptKind, ViewClass};
use splatzoo_train::checkpoint::Checkpoint;
use std::path::Path;

const VIEWS: [ViewClass; 4] = [
    ViewClass::Front,
    ViewClass::Side,
    ViewClass::Back,
    ViewClass::Overhead,
];

/// Every row a model call can need, `[L, D]` each.
#[derive(Debug, Clone, PartialEq)]
pub struct PromptEmbeddings {
    /// Tokens per prompt and channels per token.
    pub tokens: usize,
    pub channels: usize,
    /// `[view]` for Cond and Negative (in [`VIEWS`] order), then Null.
    cond: Vec<Vec<f32>>,
    negative: Vec<Vec<f32>>,
    null: Vec<f32>,
}

fn view_name(view: ViewClass) -> &'static str {
    match view {
        ViewClass::Front => "front",
        ViewClass::Side => "side",
        ViewClass::Back => "back",
        ViewClass::Overhead => "overhead",
    }
}

fn view_index(view: ViewClass) -> usize {
    VIEWS
        .iter()
        .position(|v| *v == view)
        .expect("every view is listed")
}

impl PromptEmbeddings {
    /// Reads `path` (see the module doc for its keys).
    pub fn read(path: &Path) -> Result<Self, AagError> {
        let file = Checkpoint::read(path).map_err(splatzoo_train::TrainError::from)?;
        let what = || format!("prompt embeddings {}", path.display());
        let mut shape: Option<Vec<usize>> = None;
        let mut row = |keys: &[String]| -> Result<Vec<f32>, AagError> {
            let (key, (dims, values)) = keys
                .iter()
                .find_map(|k| file.tensors.get(k.trim_matches('`')).map(|t| (k, t)))
                .ok_or_else(|| {
                    AagError::input(what(), format!("no entry {}", keys.join(" nor ")))
                })?;
            if dims.len() != 2 {
                return Err(AagError::input(
                    what(),
                    format!("{key} is {dims:?}, expected [L, D]"),
                ));
            }
            match &shape {
                None => shape = Some(dims.clone()),
                Some(s) if s != dims => {
                    return Err(AagError::input(
                        what(),
                        format!("{key} is {dims:?}, but earlier rows are {s:?} ([L, D] all alike)"),
                    ));
                }
                Some(_) => {}
            }
            if let Some(bad) = values.iter().position(|v| !v.is_finite()) {
                return Err(AagError::input(
                    what(),
                    format!("{key} has a non-finite value at flat index {bad}"),
                ));
            }
            Ok(values.clone())
        };
        let keys =
            |kind: &str, v: ViewClass| [format!("`{kind}.{}`", view_name(v)), format!("`{kind}`")];
        let mut cond = Vec::with_capacity(VIEWS.len());
        let mut negative = Vec::with_capacity(VIEWS.len());
        for &v in &VIEWS {
            cond.push(row(&keys("cond", v))?);
            negative.push(row(&keys("negative", v))?);
        }
        let null = row(&["`null`".to_owned()])?;
        let shape = shape.expect("rows were read");
        let (tokens, channels) = (shape[0], shape[1]);
        Ok(Self {
            tokens,
            channels,
            cond,
            negative,
            null,
        })
    }

    /// One row.
    pub fn row(&self, kind: PromptKind, view: ViewClass) -> &[f32] {
        match kind {
            PromptKind::Cond => &self.cond[view_index(view)],
            PromptKind::Negative => &self.negative[view_index(view)],
            PromptKind::Null => &self.null,
        }
    }

    /// `[N, L, D]` for a call's rows.
    pub fn stacked(&self, cond: &Conditioning) -> Vec<f32> {
        cond.prompts
            .iter()
            .zip(&cond.views)
            .flat_map(|(&kind, &view)| self.row(kind, view).iter().copied())
            .collect()
    }

    /// Embeddings from rows given in memory (tests, and a Burn twin's inputs): `cond` and
    /// `negative` per view in front, side, back, overhead order.
    pub fn from_rows(
        tokens: usize,
        channels: usize,
        cond: Vec<Vec<f32>>,
        negative: Vec<Vec<f32>>,
        null: Vec<f32>,
    ) -> Self {
        let n = tokens * channels;
        assert!(cond.len() == 4 && negative.len() == 4, "four views each");
        assert!(
            cond.iter().chain(&negative).all(|r| r.len() == n) && null.len() == n,
            "rows are [L, D]"
        );
        Self {
            tokens,
            channels,
            cond,
            negative,
            null,
        }
    }

    /// Writes the per-view layout to `path` (what a user's text encoder would write).
    pub fn write(&self, path: &Path) -> Result<(), AagError> {
        let mut file = Checkpoint::default();
        let shape = vec![self.tokens, self.channels];
        let mut put = |key: String, row: &[f32]| {
            file.tensors.insert(key, (shape.clone(), row.to_vec()));
        };
        for (k, &v) in VIEWS.iter().enumerate() {
            put(format!("cond.{}", view_name(v)), &self.cond[k]);
            put(format!("negative.{}", view_name(v)), &self.negative[k]);
        }
        put("null".into(), &self.null);
        file.write(path).map_err(splatzoo_train::TrainError::from)?;
        Ok(())
    }
}
