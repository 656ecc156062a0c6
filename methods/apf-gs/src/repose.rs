//! Re-posing a trained pedestrian with a new motion, their accessory carried along by Eq. 8:
//! a skinned node over the new motion takes the trained avatar (canonical Gaussians, shape),
//! the accessory hangs from the same joint with the learned `ΔT_attach` (rigidly: `D_ψ` is
//! conditioned on the capture's time, which a new motion does not share), and a camera follows
//! the body from the front. The residual field is applied with the person's condition averaged
//! over the capture's frames.

use crate::scene::{Guided, human_name, pose_human};
use crate::trainer::ApfTrainer;
use burn::tensor::Tensor;
use image::RgbImage;
use splatzoo_datasets::pose_sequence::PoseSequence;
use splatzoo_datasets::synth::motion::{Motion, Start, generate};
use splatzoo_datasets::synth::scene::standing_height;
use splatzoo_rasterizer::Camera;
use splatzoo_train::TrainError;
use splatzoo_train::checkpoint::Checkpoint;
use splatzoo_train::densify::{DensifyConfig, Strategy};
use splatzoo_train::host_f32;
use splatzoo_train::scene::{FrameContext, FrameQuery, NodeOutput, SceneNode, SkinnedGaussianNode};

/// A re-posed clip.
pub struct Reposed {
    pub frames: Vec<RgbImage>,
    /// The accessory's centroid in its parent joint's frame at every frame (constant: the
    /// accessory moves with the joint).
    pub accessory_in_parent: Vec<[f32; 3]>,
}

/// A walk with a turn for person `h`'s shape (24 fps).
pub fn default_motion(trainer: &ApfTrainer, h: usize, frames: usize) -> PoseSequence {
    let betas = trainer.capture.people[h].prior.frame_betas(0).to_vec();
    let device = trainer.background.device();
    generate(
        &[Motion::Walk {
            seconds: frames as f64 / 24.0,
            speed: 1.2,
            turn_rate: 0.6,
        }],
        Start {
            position: [0.0, 0.0],
            heading: 0.0,
            standing_height: standing_height(&betas, &device),
        },
        24.0,
    )
}

/// Person `h` (and their accessory, if any) driven by `motion`, `width`×`height` frames.
pub fn repose(
    trainer: &ApfTrainer,
    h: usize,
    motion: &PoseSequence,
    [width, height]: [u32; 2],
) -> Result<Reposed, TrainError> {
    let device = trainer.background.device();
    let human = &trainer.scene.humans[h];
    let mut saved = Checkpoint::default();
    human.node.save(&mut saved, &human_name(h));
    let mut node = SkinnedGaussianNode::new(
        &human_name(h),
        human.node.model(),
        motion,
        vec![false; motion.frames()],
        &trainer.config.human,
        trainer.config.human_rates,
        &DensifyConfig {
            strategy: Strategy::None,
            ..DensifyConfig::default()
        },
        1.0,
        0,
        &device,
    )?;
    node.load_avatar(&saved, &human_name(h), &device)?;
    let nets = burn::module::Module::valid(&trainer.nets);
    let stage = trainer.stage(trainer.step);
    // The person's condition averaged over the capture.
    let guided = stage.residual.then(|| {
        let all: Vec<Guided> = (0..trainer.capture.frames)
            .map(|t| crate::guide::guide(&nets, &trainer.capture, &trainer.config, h, t))
            .collect();
        let n = all.len() as f64;
        Guided {
            sigma: Tensor::cat(all.iter().map(|g| g.sigma.clone()).collect(), 0).mean_dim(0),
            logit: Tensor::cat(all.iter().map(|g| g.logit.clone()).collect(), 0).mean_dim(0),
            condition: Tensor::cat(all.iter().map(|g| g.condition.clone()).collect(), 0).sum_dim(0)
                / n,
        }
    });
    let accessory = trainer.scene.accessories.iter().find(|a| a.person == h);
    let mut frames = Vec::new();
    let mut accessory_in_parent = Vec::new();
    for t in 0..motion.frames() {
        let pelvis = motion.translation(t).map(|v| v as f32);
        let camera = Camera::look_at(
            [pelvis[0], pelvis[1] + 0.2, pelvis[2] + 3.5],
            pelvis,
            [0.0, 1.0, 0.0],
            45.0,
            width,
            height,
        );
        let query = FrameQuery {
            camera: &camera,
            frame: t,
            time: t as f64 / 24.0,
        };
        let human_splats = pose_human(
            &node,
            human,
            t,
            guided.as_ref(),
            &nets,
            &trainer.config,
            false,
        );
        let outputs = vec![(
            human_name(h),
            NodeOutput {
                splats: human_splats.splats,
                joints: Some(human_splats.joints),
                bounds: None,
            },
        )];
        let mut parts = vec![outputs[0].1.splats.clone()];
        if let Some(a) = accessory {
            let out = a
                .node
                .render_with(&query, &FrameContext { outputs: &outputs }, None);
            let means = host_f32(&out.splats.means);
            let joints = host_f32(outputs[0].1.joints.as_ref().expect("joints"));
            let k = a.node.joint;
            let m = &joints[16 * k..16 * k + 16];
            let n = (means.len() / 3).max(1) as f32;
            let centroid: [f32; 3] =
                std::array::from_fn(|c| means.chunks(3).map(|p| p[c]).sum::<f32>() / n);
            let d = [centroid[0] - m[3], centroid[1] - m[7], centroid[2] - m[11]];
            accessory_in_parent.push(std::array::from_fn(|c| {
                (0..3).map(|r| m[4 * r + c] * d[r]).sum()
            }));
            parts.push(out.splats);
        }
        let splats = splatzoo_train::scene::concatenate(parts);
        let render = trainer.raster(&splats, camera, false, false)?;
        frames.push(splatzoo_train::images::srgb_image(&render.color));
    }
    Ok(Reposed {
        frames,
        accessory_in_parent,
    })
}
