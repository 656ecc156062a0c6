//! Where a body model's face is, and which vertices mark named surface points, for any body a
//! user loads: what keypoint fits ([`super::fit::body25_targets`]), face losses and face cameras
//! need beyond the skinning arrays.
//!
//! - The built-in body carries its own hand-placed marks ([`super::BuiltinBody`]).
//! - SMPL and SMPL-H (6890 vertices) and SMPL-X (10475 vertices) get the OpenPose-compatible
//!   vertex ids the `smplx` package publishes (`smplx/vertex_ids.py`: nose, eyes, ears, big
//!   and small toes, heels, the five fingertips), checked against the model's topology.
//! - Any other mesh (a re-topologised scan, a custom rig) takes a marks file ([`SurfaceMarks::
//!   from_file`]): JSON `{"landmarks": {"nose_tip": 332, …}, "face_vertices": [ … ]}`, the
//!   face list optional (a FLAME or hand-painted region overrides the rule below).
//!
//! The face region, where no list is given, follows the AAGaussian spec's rule (§6, item 6):
//! vertices whose dominant skinning joint is the head (or SMPL-X's jaw and eyes), whose rest
//! normal faces forward (`n · +z > 0.3`: SMPL-family bodies face +z), that lie below the
//! brow, taken as `0.6 ×` the eye-to-nose-tip drop above the eyes, and in front of the ears
//! (the rule's one addition: the spec's three tests let the jaw's underside in).

use super::builtin::builtin_body;
use super::model::{BodyKind, BodyModel, BodyModelError};
use crate::normals::vertex_normals_reference;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::Path;

/// Landmark names every table and marks file uses: the built-in body's fourteen, then the other
/// fingertips and the small toes the SMPL-family tables add (OpenPose's hand and foot points).
pub const LANDMARK_NAMES: [&str; 24] = [
    "nose_tip",
    "left_eye",
    "right_eye",
    "mouth",
    "chin",
    "left_ear",
    "right_ear",
    "head_top",
    "left_fingertip",
    "right_fingertip",
    "left_toe",
    "right_toe",
    "left_heel",
    "right_heel",
    "left_thumb_tip",
    "left_index_tip",
    "left_ring_tip",
    "left_pinky_tip",
    "right_thumb_tip",
    "right_index_tip",
    "right_ring_tip",
    "right_pinky_tip",
    "left_small_toe",
    "right_small_toe",
];

/// SMPL / SMPL-H vertex ids (6890-vertex topology), from `smplx/vertex_ids.py` (`smplh`).
const SMPL_LANDMARKS: [(&str, u32); 21] = [
    ("nose_tip", 332),
    ("left_eye", 2800),
    ("right_eye", 6260),
    ("left_ear", 583),
    ("right_ear", 4071),
    ("left_fingertip", 2445),
    ("right_fingertip", 5905),
    ("left_toe", 3216),
    ("right_toe", 6617),
    ("left_heel", 3387),
    ("right_heel", 6787),
    ("left_thumb_tip", 2746),
    ("left_index_tip", 2319),
    ("left_ring_tip", 2556),
    ("left_pinky_tip", 2673),
    ("right_thumb_tip", 6191),
    ("right_index_tip", 5782),
    ("right_ring_tip", 6016),
    ("right_pinky_tip", 6133),
    ("left_small_toe", 3226),
    ("right_small_toe", 6624),
];

/// SMPL-X vertex ids (10475-vertex topology), from `smplx/vertex_ids.py` (`smplx`).
const SMPLX_LANDMARKS: [(&str, u32); 21] = [
    ("nose_tip", 9120),
    ("left_eye", 9448),
    ("right_eye", 9929),
    ("left_ear", 6),
    ("right_ear", 616),
    ("left_fingertip", 5058),
    ("right_fingertip", 7794),
    ("left_toe", 5770),
    ("right_toe", 8463),
    ("left_heel", 8846),
    ("right_heel", 8635),
    ("left_thumb_tip", 5361),
    ("left_index_tip", 4933),
    ("left_ring_tip", 5169),
    ("left_pinky_tip", 5286),
    ("right_thumb_tip", 8079),
    ("right_index_tip", 7669),
    ("right_ring_tip", 7905),
    ("right_pinky_tip", 8022),
    ("left_small_toe", 5780),
    ("right_small_toe", 8474),
];

const SMPL_VERTICES: usize = 6890;
const SMPLX_VERTICES: usize = 10475;
/// `n · forward` above which a head vertex faces the camera in front of the face.
const FACING: f64 = 0.3;
/// The brow's height above the eyes, in eye-to-nose-tip drops.
const BROW_OVER_NOSE_DROP: f64 = 0.6;

/// A body's face region and named surface points.
#[derive(Debug, Clone, PartialEq)]
pub struct SurfaceMarks {
    /// `[V]` vertices of the face.
    pub face_region: Vec<bool>,
    /// Named vertices (names of [`LANDMARK_NAMES`]; a table may hold only some).
    pub landmarks: Vec<(String, u32)>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MarksFile {
    landmarks: BTreeMap<String, u32>,
    #[serde(default)]
    face_vertices: Option<Vec<u32>>,
}

impl SurfaceMarks {
    /// The vertex of a named landmark.
    pub fn landmark(&self, name: &str) -> Option<u32> {
        self.landmarks
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| *v)
    }

    /// The built-in body's own marks.
    pub fn builtin() -> Self {
        let body = builtin_body();
        Self {
            face_region: body.face_region.clone(),
            landmarks: body
                .landmarks
                .iter()
                .map(|(n, v)| ((*n).to_owned(), *v))
                .collect(),
        }
    }

    /// The marks of `model` from its family's table (`source` names the model in errors): the
    /// built-in body's own, or the SMPL / SMPL-X vertex ids with the face region by rule. A
    /// model of another topology needs [`Self::from_file`].
    pub fn for_model(model: &BodyModel, source: &str) -> Result<Self, BodyModelError> {
        let v = model.vertex_count();
        let table: &[(&str, u32)] = match model.kind {
            BodyKind::Builtin if v == builtin_body().model.vertex_count() => {
                return Ok(Self::builtin());
            }
            BodyKind::Smpl | BodyKind::SmplH if v == SMPL_VERTICES => &SMPL_LANDMARKS,
            BodyKind::SmplX if v == SMPLX_VERTICES => &SMPLX_LANDMARKS,
            kind => {
                return Err(BodyModelError::File {
                    file: source.to_owned(),
                    problem: format!(
                        "a {kind:?} model of {v} vertices has no built-in landmark table (SMPL/SMPL-H \
                         have {SMPL_VERTICES}, SMPL-X {SMPLX_VERTICES}): give a marks file, JSON \
                         {{\"landmarks\": {{\"nose_tip\": <vertex>, \"left_eye\": …}}, \
                         \"face_vertices\": [optional]}}"
                    ),
                });
            }
        };
        let landmarks: Vec<(String, u32)> =
            table.iter().map(|(n, i)| ((*n).to_owned(), *i)).collect();
        let face_region = face_region_by_rule(model, &landmarks, source)?;
        Ok(Self {
            face_region,
            landmarks,
        })
    }

    /// The marks of `model` from a JSON marks file (module doc); the face region by rule where
    /// the file lists none. Errors name the file, the key and the model's vertex count.
    pub fn from_file(model: &BodyModel, path: &Path) -> Result<Self, BodyModelError> {
        let file = path.display().to_string();
        let problem = |key: &str, problem: String| BodyModelError::Field {
            file: file.clone(),
            key: key.to_owned(),
            problem,
        };
        let text = std::fs::read_to_string(path).map_err(|e| BodyModelError::File {
            file: file.clone(),
            problem: format!("cannot read the marks file: {e}"),
        })?;
        let parsed: MarksFile = serde_json::from_str(&text).map_err(|e| BodyModelError::File {
            file: file.clone(),
            problem: format!(
                "expected JSON {{\"landmarks\": {{name: vertex}}, \"face_vertices\": [vertex]}}: {e}"
            ),
        })?;
        let v = model.vertex_count();
        let mut landmarks = Vec::with_capacity(parsed.landmarks.len());
        for (name, vertex) in parsed.landmarks {
            if !LANDMARK_NAMES.contains(&name.as_str()) {
                return Err(problem(
                    "landmarks",
                    format!("unknown landmark `{name}`: expected one of {LANDMARK_NAMES:?}"),
                ));
            }
            if vertex as usize >= v {
                return Err(problem(
                    "landmarks",
                    format!("`{name}` is vertex {vertex}, but the model has {v} vertices"),
                ));
            }
            landmarks.push((name, vertex));
        }
        let face_region = match parsed.face_vertices {
            Some(list) => {
                let mut region = vec![false; v];
                for vertex in list {
                    let slot = region.get_mut(vertex as usize).ok_or_else(|| {
                        problem(
                            "face_vertices",
                            format!("vertex {vertex}, but the model has {v} vertices"),
                        )
                    })?;
                    *slot = true;
                }
                region
            }
            None => face_region_by_rule(model, &landmarks, &file)?,
        };
        Ok(Self {
            face_region,
            landmarks,
        })
    }
}

/// The face region of `model` by the module doc's rule, from its `nose_tip`, `left_eye` and
/// `right_eye` landmarks (`source` names the model in errors).
pub fn face_region_by_rule(
    model: &BodyModel,
    landmarks: &[(String, u32)],
    source: &str,
) -> Result<Vec<bool>, BodyModelError> {
    let find = |name: &str| {
        landmarks
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| *v as usize)
            .ok_or_else(|| BodyModelError::Field {
                file: source.to_owned(),
                key: "landmarks".into(),
                problem: format!(
                    "the face region rule needs `{name}` (or give `face_vertices` in a marks file)"
                ),
            })
    };
    let (nose, left, right) = (find("nose_tip")?, find("left_eye")?, find("right_eye")?);
    let (left_ear, right_ear) = (find("left_ear")?, find("right_ear")?);
    let vertices: Vec<[f64; 3]> = model
        .template
        .chunks(3)
        .map(|p| [p[0], p[1], p[2]].map(f64::from))
        .collect();
    let normals = vertex_normals_reference(&vertices, &model.faces);
    let eye_height = 0.5 * (vertices[left][1] + vertices[right][1]);
    let brow = eye_height + BROW_OVER_NOSE_DROP * (eye_height - vertices[nose][1]).max(0.0);
    let ear_plane = 0.5 * (vertices[left_ear][2] + vertices[right_ear][2]);
    let face_joints: Vec<usize> = model
        .joint_names
        .iter()
        .enumerate()
        .filter(|(_, n)| *n == "head" || *n == "jaw" || n.contains("eye"))
        .map(|(j, _)| j)
        .collect();
    let j = model.joint_count();
    Ok((0..model.vertex_count())
        .map(|i| {
            let weights = &model.skin_weights[i * j..(i + 1) * j];
            let dominant = (0..j)
                .max_by(|&a, &b| weights[a].total_cmp(&weights[b]))
                .unwrap_or(0);
            face_joints.contains(&dominant)
                && normals[i][2] > FACING
                && vertices[i][1] < brow
                && vertices[i][2] > ear_plane
        })
        .collect())
}
