//! The synthetic generator's own export (`synth` command, [`crate::synth::export`]) read back
//! into the common types, so generated scenes and public datasets reach a method the same way:
//! views from `transforms.json` (`images/<frame>_<track>.png`, already in our conventions),
//! human masks `masks/human/…png` (non-zero = person; accessory and coarse masks beside them),
//! and per tracked person the true and the
//! perturbed pose tracks (`people/person_KK_{truth,prior}.npz`, AMASS layout: SMPL `transl`,
//! world frame; an untracked passer-by has none).

use super::{BodyFrame, Dataset, Format, MaskConvention, PoseTrack, Similarity};
use crate::DatasetError;
use crate::pose_sequence::load_pose_sequence;
use std::path::Path;

pub fn load(root: &Path) -> Result<Dataset, DatasetError> {
    let mut dataset = super::nerfstudio(root)?;
    dataset.format = Format::Synthetic;
    for view in &mut dataset.views {
        let stem = Path::new(&view.camera_name)
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        // `<frame:04>_<track>`.
        if let Some((_, track)) = stem.split_once('_') {
            view.camera_name = track.to_owned();
        }
        let mask = root.join("masks/human").join(format!("{stem}.png"));
        view.mask = mask.is_file().then_some(mask);
        view.mask_convention = MaskConvention::NonZeroIsPerson;
        for name in ["accessory", "coarse"] {
            let path = root.join("masks").join(name).join(format!("{stem}.png"));
            if path.is_file() {
                view.other_masks.insert(name.to_owned(), path);
            }
        }
    }
    let people_dir = root.join("people");
    let mut files: Vec<_> = std::fs::read_dir(&people_dir)
        .map(|d| d.filter_map(|e| e.ok().map(|e| e.path())).collect())
        .unwrap_or_else(|_| Vec::new());
    files.retain(|p| p.extension().is_some_and(|e| e == "npz"));
    files.sort();
    for path in files {
        let sequence = load_pose_sequence(&path)?;
        let frames = (0..sequence.frames())
            .map(|t| {
                let pose = sequence.pose(t);
                Some(BodyFrame {
                    global_orient: [pose[0], pose[1], pose[2]],
                    body_pose: pose[3..].to_vec(),
                    betas: sequence.frame_betas(t).to_vec(),
                    transl: sequence.translation(t),
                    world_from_smpl: Similarity::IDENTITY,
                    root_position: None,
                    extra: Default::default(),
                })
            })
            .collect();
        let name = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let person = name
            .strip_suffix("_truth")
            .map_or(name.clone(), str::to_owned);
        dataset.people.push(PoseTrack { person, frames });
    }
    Ok(dataset)
}
