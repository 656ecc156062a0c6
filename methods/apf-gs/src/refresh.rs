//! `decouple.refresh_every` (spec §3, our choice, off by default): Eq. 3's `M_kine` re-rendered
//! from the human nodes' refined poses instead of the initial prior θ₀. In the corruption
//! window θ₀ is badly wrong, so its silhouette supervises the human with the wrong pixels; once
//! pose refinement has moved θ(t), a refresh puts `M_kine` (and `M_acc = M_coarse \ M_kine`)
//! where the body now is.
//!
//! At the start of every `refresh_every`-th step each tracked person's kinematic body is posed
//! at every frame by their node (its canonical Gaussians, one per body vertex, skinned with the
//! frame's refined pose; no residual), and every training view's per-person masks are
//! recomputed from those meshes by the same code that made the first ones (the coarse split and
//! the boxes do not change). The meshes of the last refresh are checkpointed, so a resumed run
//! continues with the same masks.

use crate::data::people_masks;
use crate::error::ApfError;
use crate::trainer::ApfTrainer;
use burn::tensor::{Device, Tensor, TensorData};
use rayon::prelude::*;
use splatzoo_train::checkpoint::Checkpoint;
use splatzoo_train::host_f32;
use splatzoo_train::scene::SceneNode;

/// Checkpoint entry of the last refresh's meshes, `[people × frames, vertices, 3]`.
pub const REFRESHED_MESHES: &str = "apf.refreshed_kine_meshes";

/// `meshes[person][frame]`: world vertices of each person's kinematic body.
pub type PeopleMeshes = Vec<Vec<Vec<[f32; 3]>>>;

impl ApfTrainer {
    /// Whether `step` starts with a refresh.
    pub fn refreshes_at(&self, step: usize) -> bool {
        let every = self.config.decouple.refresh_every;
        self.config.decouple.enabled && every > 0 && step > 0 && step.is_multiple_of(every)
    }

    /// Every person's kinematic body at every frame, posed by their node as it is now.
    pub fn kinematic_meshes(&self) -> Result<PeopleMeshes, ApfError> {
        let vertices = self.model.vertex_count();
        self.scene
            .humans
            .iter()
            .map(|human| {
                let canonical = human.node.canonical_set();
                if canonical.len() != vertices {
                    return Err(ApfError::input(
                        human.node.name(),
                        format!(
                            "decouple.refresh_every poses the body from the node's Gaussians, one \
                             per body vertex ({vertices}); this node has {} (human.placement = \
                             \"vertices\" without density control)",
                            canonical.len()
                        ),
                    ));
                }
                Ok((0..self.capture.frames)
                    .map(|t| {
                        let posed = human.node.posed(canonical.splats(), t);
                        host_f32(&posed.splats.means)
                            .chunks_exact(3)
                            .map(|p| [p[0], p[1], p[2]])
                            .collect()
                    })
                    .collect())
            })
            .collect()
    }

    /// Recomputes every training view's per-person masks from `meshes` and keeps them for the
    /// checkpoint.
    pub fn apply_kinematic_meshes(&mut self, meshes: PeopleMeshes) {
        let (faces, rest) = self.model.faces.as_chunks::<3>();
        debug_assert!(rest.is_empty());
        let training: Vec<bool> = {
            let mut flags = vec![false; self.capture.views.len()];
            for &i in &self.capture.train {
                flags[i] = true;
            }
            flags
        };
        let people = &self.capture.people;
        let decouple = &self.config.decouple;
        self.capture
            .views
            .par_iter_mut()
            .zip(training)
            .filter(|(_, train)| *train)
            .for_each(|(view, _)| {
                let t = view.frame;
                let boxes: Vec<_> = people.iter().map(|p| p.boxes[t]).collect();
                let at_t: Vec<&[[f32; 3]]> = meshes.iter().map(|m| m[t].as_slice()).collect();
                view.people =
                    people_masks(decouple, &view.coarse, &view.camera, &boxes, &at_t, faces);
            });
        self.refreshed = Some(meshes);
    }

    /// The refresh due at the current step, if any.
    pub(crate) fn refresh_if_due(&mut self) -> Result<(), ApfError> {
        if self.refreshes_at(self.step) {
            let meshes = self.kinematic_meshes()?;
            self.apply_kinematic_meshes(meshes);
        }
        Ok(())
    }

    /// Puts the last refresh's meshes into `checkpoint`.
    pub(crate) fn save_refresh(&self, checkpoint: &mut Checkpoint, device: &Device) {
        let Some(meshes) = &self.refreshed else {
            return;
        };
        let (people, frames) = (meshes.len(), self.capture.frames);
        let vertices = self.model.vertex_count();
        let values: Vec<f32> = meshes
            .iter()
            .flatten()
            .flatten()
            .flatten()
            .copied()
            .collect();
        let tensor = Tensor::<3>::from_data(
            TensorData::new(values, [people * frames, vertices, 3]),
            device,
        );
        checkpoint.put(REFRESHED_MESHES, &tensor);
    }

    /// Restores the last refresh from `checkpoint`, where it has one.
    pub(crate) fn load_refresh(
        &mut self,
        checkpoint: &Checkpoint,
        device: &Device,
    ) -> Result<(), ApfError> {
        if !checkpoint.tensors.contains_key(REFRESHED_MESHES) {
            return Ok(());
        }
        let (people, frames) = (self.scene.humans.len(), self.capture.frames);
        let vertices = self.model.vertex_count();
        let tensor = checkpoint
            .tensor::<3>(
                REFRESHED_MESHES,
                [Some(people * frames), Some(vertices), Some(3)],
                device,
            )
            .map_err(splatzoo_train::TrainError::from)?;
        let values = host_f32(&tensor);
        let meshes: PeopleMeshes = values
            .chunks_exact(frames * vertices * 3)
            .map(|person| {
                person
                    .chunks_exact(vertices * 3)
                    .map(|frame| frame.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect())
                    .collect()
            })
            .collect();
        self.apply_kinematic_meshes(meshes);
        Ok(())
    }
}
