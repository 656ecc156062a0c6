//! Gaussians as an INRIA-layout binary `.ply` (x, y, z, nx, ny, nz, f_dc_0..2, f_rest_0..44,
//! opacity, scale_0..2, rot_0..3; little-endian `f32`), the file the INRIA viewers, SuperSplat,
//! gsplat and Brush read. `f_rest` is channel-major (`f_rest_{c·15 + k}` is coefficient `k + 1`
//! of channel `c`), scales are logs, opacity a logit, rotations (w, x, y, z). World space.

use crate::gaussians::{GaussianSet, SH_REST};
use burn::tensor::{Device, Tensor, TensorData};
use std::io::{BufRead, Read, Write};
use std::path::Path;

#[derive(Debug, thiserror::Error)]
pub enum PlyError {
    #[error("{file}: {problem}")]
    Format { file: String, problem: String },
    #[error("{file}: {source}")]
    Io {
        file: String,
        source: std::io::Error,
    },
}

fn property_names() -> Vec<String> {
    let mut names: Vec<String> = ["x", "y", "z", "nx", "ny", "nz"].map(String::from).to_vec();
    names.extend((0..3).map(|c| format!("f_dc_{c}")));
    names.extend((0..3 * SH_REST).map(|k| format!("f_rest_{k}")));
    names.push("opacity".into());
    names.extend((0..3).map(|k| format!("scale_{k}")));
    names.extend((0..4).map(|k| format!("rot_{k}")));
    names
}

use crate::host_f32 as floats;

/// Writes `set` to `path` atomically (a temporary sibling renamed into place).
pub fn write_ply(path: &Path, set: &GaussianSet) -> Result<(), PlyError> {
    write_ply_with(path, set, None, &[])
}

/// [`write_ply`] with per-Gaussian `normals` (`[N · 3]`, written into INRIA's `nx ny nz`, zero
/// without them) and `extra` float properties (`[N]` each) after INRIA's, e.g. material maps;
/// viewers and [`read_ply`] skip properties they do not know, [`read_ply_columns`] reads them.
pub fn write_ply_with(
    path: &Path,
    set: &GaussianSet,
    normals: Option<&[f32]>,
    extra: &[(&str, &[f32])],
) -> Result<(), PlyError> {
    let n = set.len();
    let format = |problem: String| PlyError::Format {
        file: path.display().to_string(),
        problem,
    };
    if let Some(normals) = normals.filter(|v| v.len() != 3 * n) {
        return Err(format(format!(
            "{} normal values for {n} Gaussians, expected {}",
            normals.len(),
            3 * n
        )));
    }
    let taken = property_names();
    for (name, values) in extra {
        if values.len() != n {
            return Err(format(format!(
                "property `{name}`: {} values for {n} Gaussians",
                values.len()
            )));
        }
        let plain = !name.is_empty() && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
        if !plain || taken.iter().any(|t| t == name) {
            return Err(format(format!(
                "property `{name}`: a new name of letters, digits and `_` is expected"
            )));
        }
    }
    let (means, dc, rest) = (floats(&set.means), floats(&set.sh_dc), floats(&set.sh_rest));
    let (opacity, scales, quats) = (
        floats(&set.opacity_logits),
        floats(&set.log_scales),
        floats(&set.quats),
    );
    let mut names = taken;
    names.extend(extra.iter().map(|(name, _)| name.to_string()));
    let mut bytes = Vec::with_capacity(n * names.len() * 4 + 2048);
    write!(
        bytes,
        "ply\nformat binary_little_endian 1.0\nelement vertex {n}\n"
    )
    .expect("in memory");
    for name in &names {
        writeln!(bytes, "property float {name}").expect("in memory");
    }
    bytes.extend_from_slice(b"end_header\n");
    for i in 0..n {
        let mut row = Vec::with_capacity(names.len());
        row.extend_from_slice(&means[3 * i..3 * i + 3]);
        row.extend_from_slice(normals.map_or(&[0.0; 3], |v| &v[3 * i..3 * i + 3]));
        row.extend_from_slice(&dc[3 * i..3 * i + 3]);
        for c in 0..3 {
            for k in 0..SH_REST {
                row.push(rest[(i * SH_REST + k) * 3 + c]);
            }
        }
        row.push(opacity[i]);
        row.extend_from_slice(&scales[3 * i..3 * i + 3]);
        row.extend_from_slice(&quats[4 * i..4 * i + 4]);
        row.extend(extra.iter().map(|(_, values)| values[i]));
        for v in row {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
    }
    let io = |source| PlyError::Io {
        file: path.display().to_string(),
        source,
    };
    splatzoo_models::files::write_bytes(path, &bytes).map_err(io)
}

/// A binary PLY's vertex table: property names, vertex count and the raw little-endian floats.
struct Table {
    file: String,
    properties: Vec<String>,
    count: usize,
    raw: Vec<u8>,
}

impl Table {
    fn format(&self, problem: String) -> PlyError {
        PlyError::Format {
            file: self.file.clone(),
            problem,
        }
    }

    fn column(&self, name: &str) -> Option<usize> {
        self.properties.iter().position(|p| p == name)
    }

    fn required(&self, name: &str) -> Result<usize, PlyError> {
        self.column(name)
            .ok_or_else(|| self.format(format!("property `{name}` missing")))
    }

    fn value(&self, i: usize, c: usize) -> f32 {
        let at = (i * self.properties.len() + c) * 4;
        f32::from_le_bytes(self.raw[at..at + 4].try_into().expect("4 bytes"))
    }

    /// The named columns, interleaved per vertex.
    fn gather(&self, names: &[String]) -> Result<Vec<f32>, PlyError> {
        let cols = names
            .iter()
            .map(|nm| self.required(nm))
            .collect::<Result<Vec<_>, _>>()?;
        Ok((0..self.count)
            .flat_map(|i| cols.iter().map(move |&c| (i, c)))
            .map(|(i, c)| self.value(i, c))
            .collect())
    }
}

/// The values of each named property (`[N]` each), e.g. the extras [`write_ply_with`] wrote.
pub fn read_ply_columns(path: &Path, names: &[&str]) -> Result<Vec<Vec<f32>>, PlyError> {
    let table = read_table(path)?;
    names
        .iter()
        .map(|name| table.gather(&[name.to_string()]))
        .collect()
}

/// Reads an INRIA-layout `.ply` (any property order; missing `f_rest_*` read as zero, as in
/// degree-0 exports; other properties skipped).
pub fn read_ply(path: &Path, device: &Device) -> Result<GaussianSet, PlyError> {
    let table = read_table(path)?;
    let n = table.count;
    let names = |prefix: &str, k: usize| (0..k).map(|j| format!("{prefix}{j}")).collect::<Vec<_>>();
    let means = table.gather(&["x", "y", "z"].map(String::from))?;
    let dc = table.gather(&names("f_dc_", 3))?;
    let opacity = table.gather(&["opacity".to_string()])?;
    let scales = table.gather(&names("scale_", 3))?;
    let quats = table.gather(&names("rot_", 4))?;
    let mut rest = vec![0.0f32; n * SH_REST * 3];
    for c in 0..3 {
        for k in 0..SH_REST {
            if let Some(col) = table.column(&format!("f_rest_{}", c * SH_REST + k)) {
                for i in 0..n {
                    rest[(i * SH_REST + k) * 3 + c] = table.value(i, col);
                }
            }
        }
    }
    let t2 = |v: Vec<f32>, k: usize| Tensor::<2>::from_data(TensorData::new(v, [n, k]), device);
    Ok(GaussianSet {
        means: t2(means, 3),
        quats: t2(quats, 4),
        log_scales: t2(scales, 3),
        opacity_logits: Tensor::<1>::from_data(TensorData::new(opacity, [n]), device),
        sh_dc: Tensor::from_data(TensorData::new(dc, [n, 1, 3]), device),
        sh_rest: Tensor::from_data(TensorData::new(rest, [n, SH_REST, 3]), device),
    })
}

/// The header and vertex table of a binary little-endian PLY of float properties.
fn read_table(path: &Path) -> Result<Table, PlyError> {
    let file = path.display().to_string();
    let format = |problem: String| PlyError::Format {
        file: file.clone(),
        problem,
    };
    let mut reader =
        std::io::BufReader::new(std::fs::File::open(path).map_err(|source| PlyError::Io {
            file: file.clone(),
            source,
        })?);
    let mut properties = Vec::new();
    let mut count = None;
    let mut line = String::new();
    let mut first = true;
    loop {
        line.clear();
        let read = reader.read_line(&mut line).map_err(|source| PlyError::Io {
            file: file.clone(),
            source,
        })?;
        if read == 0 {
            return Err(format("header ends before `end_header`".into()));
        }
        let words: Vec<&str> = line.split_whitespace().collect();
        if first {
            if words != ["ply"] {
                return Err(format("not a PLY file (first line is not `ply`)".into()));
            }
            first = false;
            continue;
        }
        match words.as_slice() {
            ["format", "binary_little_endian", _] => {}
            ["format", other, _] => {
                return Err(format(format!(
                    "format `{other}`: only binary_little_endian is read"
                )));
            }
            ["element", "vertex", n] => {
                count = Some(
                    n.parse::<usize>()
                        .map_err(|_| format(format!("vertex count `{n}`")))?,
                );
            }
            ["element", other, _] => return Err(format(format!("unexpected element `{other}`"))),
            ["property", "float", name] => properties.push(name.to_string()),
            ["property", ty, name] => {
                return Err(format(format!(
                    "property `{name}` is `{ty}`; Gaussians are `float`"
                )));
            }
            ["end_header"] => break,
            _ => {}
        }
    }
    let n = count.ok_or_else(|| format("no `element vertex` line".into()))?;
    let stride = properties.len();
    let mut raw = vec![0u8; n * stride * 4];
    reader.read_exact(&mut raw).map_err(|_| {
        format(format!(
            "truncated: {n} vertices × {stride} floats expected after the header"
        ))
    })?;
    Ok(Table {
        file,
        properties,
        count: n,
        raw,
    })
}
