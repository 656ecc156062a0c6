//! SMPL, SMPL-H and SMPL-X from the `.npz` files their authors release (or `np.savez` of the
//! `.pkl` arrays). Keys read: `v_template [V, 3]`, `f [F, 3]`, `J_regressor [J, V]` (dense),
//! `kintree_table [2, J]` (row 0: parents, root's parent −1 or 2³²−1), `weights [V, J]`,
//! `shapedirs [V, 3, S]`, optional `posedirs [V, 3, 9 (J − 1)]` and SMPL-X's face landmarks
//! `lmk_faces_idx [51]` with `lmk_bary_coords [51, 3]`. The family follows from J:
//! 24 SMPL, 52 SMPL-H, 55 SMPL-X. SMPL-X keeps its expression directions in `shapedirs` after
//! the shape ones: columns 300.. when it has at least 400, else 10.. (as the `smplx` package).

use super::model::{BodyKind, BodyModel, BodyModelError, FaceLandmark};
use super::skeleton::SMPL_JOINT_NAMES;
use npyz::npz::NpzArchive;
use npyz::{DType, NpyFile, Order};
use std::io::Read;
use std::path::Path;

/// An array read as `f64` in C order, with its shape.
#[derive(Debug, Clone, PartialEq)]
pub struct Array {
    pub shape: Vec<usize>,
    pub values: Vec<f64>,
}

pub(crate) fn field_err(file: &str, key: &str, problem: impl Into<String>) -> BodyModelError {
    BodyModelError::Field {
        file: file.to_owned(),
        key: key.to_owned(),
        problem: problem.into(),
    }
}

/// Reorders a Fortran-ordered buffer of `shape` into C order.
pub(crate) fn fortran_to_c(values: Vec<f64>, shape: &[usize]) -> Vec<f64> {
    let mut out = vec![0.0; values.len()];
    let mut index = vec![0usize; shape.len()];
    for slot in out.iter_mut() {
        // Column-major position of the same multi-index.
        let mut f_pos = 0;
        let mut stride = 1;
        for (axis, &i) in index.iter().enumerate() {
            f_pos += i * stride;
            stride *= shape[axis];
        }
        *slot = values[f_pos];
        for axis in (0..shape.len()).rev() {
            index[axis] += 1;
            if index[axis] < shape[axis] {
                break;
            }
            index[axis] = 0;
        }
    }
    out
}

fn read_array<R: Read>(npy: NpyFile<R>, file: &str, key: &str) -> Result<Array, BodyModelError> {
    decode_npy(npy).map_err(|problem| field_err(file, key, problem))
}

/// Reads any numeric `.npy` payload (f8/f4/i8/i4/u8/u4/u1, C or Fortran order) as `f64` in C
/// order; the error says what was wrong, for the caller to place.
pub fn decode_npy<R: Read>(npy: NpyFile<R>) -> Result<Array, String> {
    let shape: Vec<usize> = npy.shape().iter().map(|&d| d as usize).collect();
    let fortran = npy.order() == Order::Fortran;
    let type_str = match npy.dtype() {
        DType::Plain(t) => t.to_string(),
        other => return Err(format!("unsupported dtype {other:?}")),
    };
    let io = |e: std::io::Error| format!("cannot read ({e})");
    let values: Vec<f64> = match type_str.as_str() {
        "<f8" => npy.into_vec::<f64>().map_err(io)?,
        "<f4" => npy
            .into_vec::<f32>()
            .map_err(io)?
            .into_iter()
            .map(f64::from)
            .collect(),
        "<i8" => npy
            .into_vec::<i64>()
            .map_err(io)?
            .into_iter()
            .map(|v| v as f64)
            .collect(),
        "<i4" => npy
            .into_vec::<i32>()
            .map_err(io)?
            .into_iter()
            .map(f64::from)
            .collect(),
        "<u8" => npy
            .into_vec::<u64>()
            .map_err(io)?
            .into_iter()
            .map(|v| v as f64)
            .collect(),
        "<u4" => npy
            .into_vec::<u32>()
            .map_err(io)?
            .into_iter()
            .map(f64::from)
            .collect(),
        "|u1" => npy
            .into_vec::<u8>()
            .map_err(io)?
            .into_iter()
            .map(f64::from)
            .collect(),
        "|O" => {
            return Err(
                "holds Python objects (e.g. a scipy sparse matrix); re-save it dense: `np.savez(out, **{k: np.asarray(v.todense() if hasattr(v, 'todense') else v) for k, v in d.items()})`"
                    .into(),
            );
        }
        other => return Err(format!("unsupported dtype {other}")),
    };
    let values = if fortran && shape.len() > 1 {
        fortran_to_c(values, &shape)
    } else {
        values
    };
    Ok(Array { shape, values })
}

/// Looks arrays up by key; `Ok(None)` when the key is absent.
pub(crate) type Fetch<'a> = dyn FnMut(&str) -> Result<Option<Array>, BodyModelError> + 'a;

fn require(
    fetch: &mut Fetch,
    file: &str,
    key: &str,
    expected: &str,
) -> Result<Array, BodyModelError> {
    fetch(key)?.ok_or_else(|| {
        field_err(
            file,
            key,
            format!("missing; expected an array of shape {expected}"),
        )
    })
}

fn check_shape(
    a: &Array,
    file: &str,
    key: &str,
    expected: &[Option<usize>],
    text: &str,
) -> Result<(), BodyModelError> {
    let ok = a.shape.len() == expected.len()
        && a.shape
            .iter()
            .zip(expected)
            .all(|(s, e)| e.is_none_or(|e| *s == e));
    if ok {
        Ok(())
    } else {
        Err(field_err(
            file,
            key,
            format!("expected shape {text}, got {:?}", a.shape),
        ))
    }
}

fn to_f32(values: &[f64]) -> Vec<f32> {
    values.iter().map(|&v| v as f32).collect()
}

/// `[V, 3, K]` columns `range` of a `[V, 3, S]` array.
fn columns(a: &Array, range: std::ops::Range<usize>) -> Vec<f32> {
    let s = a.shape[2];
    let rows = a.shape[0] * 3;
    let mut out = Vec::with_capacity(rows * range.len());
    for r in 0..rows {
        out.extend(
            a.values[r * s + range.start..r * s + range.end]
                .iter()
                .map(|&v| v as f32),
        );
    }
    out
}

/// Joint names of the model families, in their order.
fn joint_names(kind: BodyKind) -> Vec<String> {
    let body: Vec<String> = SMPL_JOINT_NAMES.iter().map(|s| s.to_string()).collect();
    let hand = |side: &str| {
        ["index", "middle", "pinky", "ring", "thumb"]
            .iter()
            .flat_map(|f| (1..=3).map(move |k| format!("{side}_{f}{k}")))
            .collect::<Vec<_>>()
    };
    match kind {
        BodyKind::Smpl | BodyKind::Builtin => body,
        BodyKind::SmplH => [&body[..22], &hand("left"), &hand("right")].concat(),
        BodyKind::SmplX => [
            &body[..22],
            &[
                "jaw".into(),
                "left_eye_smplhf".into(),
                "right_eye_smplhf".into(),
            ],
            &hand("left")[..],
            &hand("right")[..],
        ]
        .concat(),
    }
}

/// Loads an SMPL-family model from an `.npz` file.
pub fn load_npz(path: &Path) -> Result<BodyModel, BodyModelError> {
    let file = path.display().to_string();
    let mut archive = NpzArchive::open(path).map_err(|e| BodyModelError::File {
        file: file.clone(),
        problem: format!("cannot open as .npz ({e})"),
    })?;
    let mut fetch = |key: &str| -> Result<Option<Array>, BodyModelError> {
        let npy = archive
            .by_name(key)
            .map_err(|e| field_err(&file, key, format!("cannot read ({e})")))?;
        npy.map(|npy| read_array(npy, &file, key)).transpose()
    };
    assemble(&file, &mut fetch)
}

/// SMPL-X's static face landmarks, where the file has `lmk_faces_idx` `[51]` and
/// `lmk_bary_coords` `[51, 3]` (both or neither).
fn face_landmarks(
    fetch: &mut Fetch,
    file: &str,
) -> Result<Option<Vec<FaceLandmark>>, BodyModelError> {
    let (faces, bary) = match (fetch("lmk_faces_idx")?, fetch("lmk_bary_coords")?) {
        (None, None) => return Ok(None),
        (Some(faces), Some(bary)) => (faces, bary),
        (Some(_), None) => {
            return Err(field_err(
                file,
                "lmk_bary_coords",
                "missing beside `lmk_faces_idx`; expected [L, 3]",
            ));
        }
        (None, Some(_)) => {
            return Err(field_err(
                file,
                "lmk_faces_idx",
                "missing beside `lmk_bary_coords`; expected [L]",
            ));
        }
    };
    check_shape(
        &faces,
        file,
        "lmk_faces_idx",
        &[Some(51)],
        "[51] (SMPL-X's static face landmarks)",
    )?;
    let l = faces.shape[0];
    check_shape(
        &bary,
        file,
        "lmk_bary_coords",
        &[Some(l), Some(3)],
        &format!("[{l}, 3]"),
    )?;
    if let Some(bad) = faces.values.iter().find(|f| **f < 0.0 || f.fract() != 0.0) {
        return Err(field_err(
            file,
            "lmk_faces_idx",
            format!("{bad} is not a face index"),
        ));
    }
    Ok(Some(
        faces
            .values
            .iter()
            .zip(bary.values.chunks(3))
            .map(|(&face, w)| FaceLandmark {
                face: face as u32,
                weights: [w[0] as f32, w[1] as f32, w[2] as f32],
            })
            .collect(),
    ))
}

/// Builds and validates a model from the SMPL-family arrays `fetch` finds.
pub(crate) fn assemble(file: &str, fetch: &mut Fetch) -> Result<BodyModel, BodyModelError> {
    let file = file.to_owned();
    let template = require(fetch, &file, "v_template", "[V, 3]")?;
    check_shape(&template, &file, "v_template", &[None, Some(3)], "[V, 3]")?;
    let v = template.shape[0];
    let kintree = require(fetch, &file, "kintree_table", "[2, J]")?;
    check_shape(&kintree, &file, "kintree_table", &[Some(2), None], "[2, J]")?;
    let j = kintree.shape[1];
    let kind = match (j, v) {
        (24, _) => BodyKind::Smpl,
        (52, _) => BodyKind::SmplH,
        (55, _) => BodyKind::SmplX,
        _ => {
            return Err(field_err(
                &file,
                "kintree_table",
                format!("{j} joints: expected 24 (SMPL), 52 (SMPL-H) or 55 (SMPL-X)"),
            ));
        }
    };
    let faces = require(fetch, &file, "f", "[F, 3]")?;
    check_shape(&faces, &file, "f", &[None, Some(3)], "[F, 3]")?;
    if let Some(bad) = faces.values.iter().find(|&&f| f < 0.0 || f.fract() != 0.0) {
        return Err(field_err(
            &file,
            "f",
            format!("holds {bad}; expected vertex indices"),
        ));
    }
    let regressor = require(fetch, &file, "J_regressor", &format!("[{j}, {v}]"))?;
    check_shape(
        &regressor,
        &file,
        "J_regressor",
        &[Some(j), Some(v)],
        &format!("[{j}, {v}]"),
    )?;
    let weights = require(fetch, &file, "weights", &format!("[{v}, {j}]"))?;
    check_shape(
        &weights,
        &file,
        "weights",
        &[Some(v), Some(j)],
        &format!("[{v}, {j}]"),
    )?;
    let shapedirs = require(fetch, &file, "shapedirs", &format!("[{v}, 3, S]"))?;
    check_shape(
        &shapedirs,
        &file,
        "shapedirs",
        &[Some(v), Some(3), None],
        &format!("[{v}, 3, S]"),
    )?;
    let pose_len = 9 * (j - 1);
    let posedirs = fetch("posedirs")?;
    if let Some(p) = &posedirs {
        check_shape(
            p,
            &file,
            "posedirs",
            &[Some(v), Some(3), Some(pose_len)],
            &format!("[{v}, 3, {pose_len}]"),
        )?;
    }
    let face_landmarks = face_landmarks(fetch, &file)?;

    let parents = kintree.values[..j]
        .iter()
        .enumerate()
        .map(|(k, &p)| {
            if k == 0 || p < 0.0 || p >= j as f64 {
                None
            } else {
                Some(p as usize)
            }
        })
        .collect();
    let s = shapedirs.shape[2];
    let (shape_dirs, expression_dirs) = match kind {
        BodyKind::SmplX if s >= 400 => (
            columns(&shapedirs, 0..300),
            Some(columns(&shapedirs, 300..s)),
        ),
        BodyKind::SmplX if s > 10 => (columns(&shapedirs, 0..10), Some(columns(&shapedirs, 10..s))),
        _ => (to_f32(&shapedirs.values), None),
    };
    let model = BodyModel {
        kind,
        template: to_f32(&template.values),
        faces: faces.values.iter().map(|&f| f as u32).collect(),
        joint_regressor: to_f32(&regressor.values),
        parents,
        skin_weights: to_f32(&weights.values),
        shape_dirs,
        pose_dirs: posedirs.map(|p| to_f32(&p.values)),
        expression_dirs,
        joint_names: joint_names(kind),
        face_landmarks,
    };
    model.validate(&file)?;
    Ok(model)
}

/// Writes a model in the SMPL `.npz` layout [`load_npz`] reads (`v_template`, `f`,
/// `J_regressor`, `kintree_table`, `weights`, `shapedirs`, and `posedirs` and the face
/// landmarks `lmk_faces_idx` / `lmk_bary_coords` when present), through
/// a temporary file renamed into place. Expression directions are not written.
pub fn save_npz(model: &BodyModel, path: &Path) -> Result<(), BodyModelError> {
    use npyz::WriterBuilder;
    let file = path.display().to_string();
    let v = model.vertex_count() as u64;
    let j = model.joint_count() as u64;
    let write = |tmp: &Path| -> std::io::Result<()> {
        let mut npz = npyz::npz::NpzWriter::create(tmp)?;
        {
            let mut put = |name: &str, shape: &[u64], values: &mut dyn Iterator<Item = f64>| {
                let mut w = npz
                    .array::<f64>(name, Default::default())?
                    .default_dtype()
                    .shape(shape)
                    .begin_nd()?;
                w.extend(values)?;
                w.finish()
            };
            let f64s = |x: &[f32]| x.iter().map(|&v| v as f64).collect::<Vec<f64>>();
            put(
                "v_template",
                &[v, 3],
                &mut f64s(&model.template).into_iter(),
            )?;
            put(
                "J_regressor",
                &[j, v],
                &mut f64s(&model.joint_regressor).into_iter(),
            )?;
            put(
                "weights",
                &[v, j],
                &mut f64s(&model.skin_weights).into_iter(),
            )?;
            let s = model.shape_count() as u64;
            put(
                "shapedirs",
                &[v, 3, s],
                &mut f64s(&model.shape_dirs).into_iter(),
            )?;
            if let Some(p) = &model.pose_dirs {
                put("posedirs", &[v, 3, 9 * (j - 1)], &mut f64s(p).into_iter())?;
            }
            if let Some(landmarks) = &model.face_landmarks {
                let l = landmarks.len() as u64;
                put(
                    "lmk_bary_coords",
                    &[l, 3],
                    &mut landmarks.iter().flat_map(|m| m.weights.map(f64::from)),
                )?;
            }
        }
        {
            let faces = model.faces.iter().map(|&x| x as i64);
            let mut w = npz
                .array::<i64>("f", Default::default())?
                .default_dtype()
                .shape(&[model.face_count() as u64, 3])
                .begin_nd()?;
            w.extend(faces)?;
            w.finish()?;
            let parents = model.parents.iter().map(|p| p.map_or(-1, |p| p as i64));
            let children = 0..j as i64;
            let mut w = npz
                .array::<i64>("kintree_table", Default::default())?
                .default_dtype()
                .shape(&[2, j])
                .begin_nd()?;
            w.extend(parents.chain(children))?;
            w.finish()?;
            if let Some(landmarks) = &model.face_landmarks {
                let mut w = npz
                    .array::<i64>("lmk_faces_idx", Default::default())?
                    .default_dtype()
                    .shape(&[landmarks.len() as u64])
                    .begin_nd()?;
                w.extend(landmarks.iter().map(|m| i64::from(m.face)))?;
                w.finish()?;
            }
        }
        let mut inner = npz.zip_writer().finish().map_err(std::io::Error::other)?;
        std::io::Write::flush(&mut inner)?;
        inner.get_ref().sync_all()
    };
    crate::files::write_atomically(path, write).map_err(|e| BodyModelError::File {
        file,
        problem: format!("cannot write ({e})"),
    })
}
