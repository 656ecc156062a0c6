//! Scores of `train-avatar`: image quality on a view set, full-image and over the human region
//! (per-image MSE over the mask's pixels turned into PSNR, then averaged over images, as
//! GauHuman and drivestudio score), joint error of a pose track against the truth, and the
//! plain-template baseline (Gaussians fixed on the posed mesh, each the mean colour of its
//! projections into the training images).

use super::data::AvatarFrame;
use crate::harness::{ScoreSum, Scores};
use crate::host_f32;
use crate::loss::{masked_psnr, masked_ssim, psnr, scalar, ssim};
use crate::lpips::Lpips;
use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_datasets::pose_sequence::PoseSequence;
use splatzoo_models::body::BodyModel;
use splatzoo_models::body::lbs::{BodyTensors, PoseInput, pose};
use splatzoo_rasterizer::{Camera, Render};

/// How the human region is scored (written into `metrics.json`).
pub const HUMAN_REGION: &str = "per-image MSE over the dataset's person-mask pixels → PSNR, averaged over images; SSIM averaged over mask pixels";

/// Scores of one view set.
pub struct ViewScores {
    pub full: Scores,
    pub human: Scores,
}

/// Scores renders (clamped to [0, 1]) against the masked targets of their frames.
pub fn score_views(
    pairs: impl Iterator<Item = (Render, AvatarFrame)>,
    background: &Tensor<1>,
    lpips: Option<&Lpips>,
) -> ViewScores {
    let (mut full, mut human) = (ScoreSum::default(), ScoreSum::default());
    for (render, view) in pairs {
        let image = render.color.clamp(0.0, 1.0);
        let target = view.masked_target(background);
        let perceptual = lpips.map(|l| scalar(l.distance(image.clone(), target.clone())));
        full.add(
            psnr(image.clone(), target.clone()),
            scalar(ssim(image.clone(), target.clone())),
            perceptual,
        );
        human.add(
            masked_psnr(image.clone(), target.clone(), view.mask.clone()),
            scalar(masked_ssim(image, target, view.mask.clone())),
            perceptual,
        );
    }
    ViewScores {
        full: full.mean(),
        human: human.mean(),
    }
}

/// `[F, J, 3]` joints of a track on `model`, every frame in one batch.
pub fn track_joints(model: &BodyModel, track: &PoseSequence, device: &Device) -> Tensor<3> {
    let (f, j) = (track.frames(), model.joint_count());
    let s = track.shape_count.min(model.shape_count());
    let betas: Vec<f32> = (0..f)
        .flat_map(|t| track.frame_betas(t)[..s].iter().map(|&b| b as f32))
        .collect();
    let body = BodyTensors::new(model, device);
    let input = PoseInput::from_axis_angle(
        Tensor::from_data(TensorData::new(betas, [f, s]), device),
        Tensor::from_data(
            TensorData::new(
                track.poses.iter().map(|&v| v as f32).collect::<Vec<_>>(),
                [f, 3 * j],
            ),
            device,
        ),
        Tensor::from_data(
            TensorData::new(
                track
                    .translations
                    .iter()
                    .map(|&v| v as f32)
                    .collect::<Vec<_>>(),
                [f, 3],
            ),
            device,
        ),
    );
    pose(&body, &input).joints
}

/// Mean joint position error in millimetres, world frame, no alignment.
pub fn mpjpe_mm(joints: Tensor<3>, truth: Tensor<3>) -> f64 {
    let d = (joints - truth).powi_scalar(2).sum_dim(2).sqrt();
    scalar(d.mean()) * 1000.0
}

/// Pixel coordinates of world points under `camera` (pixel centres at +0.5) and camera z.
pub fn project(camera: &Camera, points: &[[f32; 3]]) -> Vec<(f32, f32, f32)> {
    let m = camera.world_to_camera;
    points
        .iter()
        .map(|p| {
            let c: [f32; 3] =
                std::array::from_fn(|r| m[r][0] * p[0] + m[r][1] * p[1] + m[r][2] * p[2] + m[r][3]);
            let z = c[2];
            (
                camera.fx * c[0] / z + camera.cx,
                camera.fy * c[1] / z + camera.cy,
                z,
            )
        })
        .collect()
}

/// Adds the colour under each visible Gaussian (centre inside the mask and in front of the
/// template's own depth by at most `tolerance` metres) to `sum`/`count`.
pub fn accumulate_colours(
    camera: &Camera,
    view: &AvatarFrame,
    means: &[[f32; 3]],
    depth: &Tensor<2>,
    tolerance: f32,
    sum: &mut [[f64; 3]],
    count: &mut [usize],
) {
    let [h, w] = view.mask.dims();
    let (image, mask, depth) = (host_f32(&view.image), host_f32(&view.mask), host_f32(depth));
    for (g, (u, v, z)) in project(camera, means).into_iter().enumerate() {
        if z <= 0.0 || u < 0.0 || v < 0.0 {
            continue;
        }
        let (x, y) = (u as usize, v as usize);
        if x >= w || y >= h {
            continue;
        }
        let p = y * w + x;
        if mask[p] < 0.5 || z > depth[p] + tolerance {
            continue;
        }
        for c in 0..3 {
            sum[g][c] += image[3 * p + c] as f64;
        }
        count[g] += 1;
    }
}
