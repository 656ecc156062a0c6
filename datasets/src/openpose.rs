//! OpenPose's per-frame keypoint JSON (`*_keypoints.json`, as `--write_json` writes it):
//! `{"people": [{"pose_keypoints_2d": [x, y, c, …], "face_keypoints_2d": […],
//! "hand_left_keypoints_2d": […], "hand_right_keypoints_2d": […]}, …]}` with the BODY_25 body
//! (75 values), the 70-point face and 21-point hands (each optional: empty or absent). Pixel
//! coordinates, confidence 0 for an undetected point. Other body layouts (COCO-18, MPI-15) are
//! named in the error rather than guessed. A motion video is a folder of such files, one per
//! frame, read in name order.

use crate::DatasetError;
use crate::files::write_atomically;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// BODY_25's keypoint names, in order.
pub const BODY_25: [&str; 25] = [
    "nose",
    "neck",
    "right_shoulder",
    "right_elbow",
    "right_wrist",
    "left_shoulder",
    "left_elbow",
    "left_wrist",
    "mid_hip",
    "right_hip",
    "right_knee",
    "right_ankle",
    "left_hip",
    "left_knee",
    "left_ankle",
    "right_eye",
    "left_eye",
    "right_ear",
    "left_ear",
    "left_big_toe",
    "left_small_toe",
    "left_heel",
    "right_big_toe",
    "right_small_toe",
    "right_heel",
];

/// Points in the face and in each hand.
pub const FACE_POINTS: usize = 70;
pub const HAND_POINTS: usize = 21;

/// One detected person: `(x, y, confidence)` per point.
#[derive(Debug, Clone, PartialEq)]
pub struct PersonKeypoints {
    pub body: Vec<[f32; 3]>,
    /// Empty when the file has no face for this person.
    pub face: Vec<[f32; 3]>,
    pub left_hand: Vec<[f32; 3]>,
    pub right_hand: Vec<[f32; 3]>,
}

#[derive(Debug, Serialize, Deserialize)]
struct RawFile {
    #[serde(default)]
    version: Option<f64>,
    people: Vec<RawPerson>,
}

#[derive(Debug, Default, Serialize, Deserialize)]
struct RawPerson {
    #[serde(default)]
    pose_keypoints_2d: Vec<f32>,
    #[serde(default)]
    face_keypoints_2d: Vec<f32>,
    #[serde(default)]
    hand_left_keypoints_2d: Vec<f32>,
    #[serde(default)]
    hand_right_keypoints_2d: Vec<f32>,
}

fn triples(
    path: &Path,
    key: &str,
    values: &[f32],
    points: usize,
    optional: bool,
) -> Result<Vec<[f32; 3]>, DatasetError> {
    if values.is_empty() && optional {
        return Ok(Vec::new());
    }
    if values.len() != 3 * points {
        let body = key.ends_with("pose_keypoints_2d");
        let hint = match (body, values.len()) {
            (true, 54) => " (that is COCO-18; run OpenPose with BODY_25)",
            (true, 45) => " (that is MPI-15; run OpenPose with BODY_25)",
            _ => "",
        };
        return Err(DatasetError::field(
            path,
            key,
            format!(
                "{} values, expected {} ({points} points × (x, y, confidence)){hint}",
                values.len(),
                3 * points
            ),
        ));
    }
    if let Some(bad) = values.iter().position(|v| !v.is_finite()) {
        return Err(DatasetError::field(
            path,
            key,
            format!("non-finite value at index {bad}"),
        ));
    }
    Ok(values.chunks(3).map(|c| [c[0], c[1], c[2]]).collect())
}

/// Every person in one OpenPose JSON file.
pub fn read_keypoints(path: &Path) -> Result<Vec<PersonKeypoints>, DatasetError> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| DatasetError::file(path, format!("cannot read ({e})")))?;
    let raw: RawFile = serde_json::from_str(&text)
        .map_err(|e| DatasetError::file(path, format!("not OpenPose keypoint JSON ({e})")))?;
    raw.people
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let key = |k: &str| format!("people[{i}].{k}");
            Ok(PersonKeypoints {
                body: triples(
                    path,
                    &key("pose_keypoints_2d"),
                    &p.pose_keypoints_2d,
                    25,
                    false,
                )?,
                face: triples(
                    path,
                    &key("face_keypoints_2d"),
                    &p.face_keypoints_2d,
                    FACE_POINTS,
                    true,
                )?,
                left_hand: triples(
                    path,
                    &key("hand_left_keypoints_2d"),
                    &p.hand_left_keypoints_2d,
                    HAND_POINTS,
                    true,
                )?,
                right_hand: triples(
                    path,
                    &key("hand_right_keypoints_2d"),
                    &p.hand_right_keypoints_2d,
                    HAND_POINTS,
                    true,
                )?,
            })
        })
        .collect()
}

/// The most confident person of one file (summed body confidence), if any.
pub fn read_main_person(path: &Path) -> Result<Option<PersonKeypoints>, DatasetError> {
    let people = read_keypoints(path)?;
    Ok(people.into_iter().max_by(|a, b| {
        let score = |p: &PersonKeypoints| p.body.iter().map(|k| f64::from(k[2])).sum::<f64>();
        score(a).total_cmp(&score(b))
    }))
}

/// The `.json` files of a folder, in name order (a video's frames).
pub fn keypoint_files(dir: &Path) -> Result<Vec<PathBuf>, DatasetError> {
    let entries = std::fs::read_dir(dir)
        .map_err(|e| DatasetError::file(dir, format!("cannot list ({e})")))?;
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "json"))
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(DatasetError::file(dir, "no OpenPose .json files"));
    }
    Ok(files)
}

/// Writes one person as an OpenPose JSON file (synthetic captures and tests).
pub fn write_keypoints(path: &Path, person: &PersonKeypoints) -> Result<(), DatasetError> {
    let flat = |points: &[[f32; 3]]| points.iter().flatten().copied().collect::<Vec<f32>>();
    let raw = RawFile {
        version: Some(1.3),
        people: vec![RawPerson {
            pose_keypoints_2d: flat(&person.body),
            face_keypoints_2d: flat(&person.face),
            hand_left_keypoints_2d: flat(&person.left_hand),
            hand_right_keypoints_2d: flat(&person.right_hand),
        }],
    };
    let text = serde_json::to_string(&raw).expect("plain data");
    write_atomically(path, |tmp| std::fs::write(tmp, &text))
}
