//! Animation (§3.4 of AAGaussian, U9): the trained canonical avatar, bound to the body surface
//! ([`crate::binding`]), re-posed zero-shot frame by frame by a pose sequence (a built-in walk
//! then wave, or a user's AMASS `.npz`) through the body prior's posed mesh, and compared with
//! the prompted identity's own mesh posed the same way (rendered by the independent CPU
//! renderer): the identity-kept score (none for a user's photo: no identity to pose).
//! Writes `frame_XXXX.png` (avatar | identity, or the avatar alone), `animation.gif` and a
//! posed INRIA `frame_XXXX.ply` per frame.
//!
//! \[P\] Only the 21 body joints drive the avatar (root orientation, translation and hands
//! are zeroed, as HumanGaussian's `poses[:, 1:22]`); `root = true` keeps the root orientation.

use crate::binding::{SurfaceBinding, bind};
use crate::cameras::orbit_camera;
use crate::data::PortraitCapture;
use crate::error::AagError;
use crate::identities::planar_rgb;
use crate::trainer::{planar_to_tensor, render_views};
use burn::tensor::{Device, Tensor};
use serde::{Deserialize, Serialize};
use splatzoo_datasets::pose_sequence::PoseSequence;
use splatzoo_datasets::synth::motion::{Motion, Start, generate};
use splatzoo_rasterizer::Camera;
use splatzoo_train::gaussians::{GaussianRows, GaussianSet};
use splatzoo_train::images::{side_by_side, srgb_image, write_gif, write_png};
use splatzoo_train::loss::{psnr, scalar, ssim};
use splatzoo_train::ply::write_ply;
use std::path::Path;
use std::time::Instant;

/// Joints of the built-in body (the SMPL layout).
pub const JOINTS: usize = 24;

/// How the avatar is driven and scored.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AnimationConfig {
    /// Frames of the built-in motion (half walking in place, half waving); 0 skips the
    /// animation at the end of `train-aag`.
    pub frames: usize,
    pub fps: f64,
    /// Square image side of the frames and the scores.
    pub size: u32,
    /// Camera azimuths (degrees, 0 = the front) each frame is scored from; the first is drawn.
    pub azimuths: Vec<f64>,
    /// \[C\] Turn each Gaussian with its face (HumanGaussian keeps rotations: `false`).
    pub rotate: bool,
    /// Keep the sequence's root orientation (\[P\]: zeroed).
    pub root: bool,
    /// \[H\] Rows whose centre the face anchor misses by more than this (normalised units) are
    /// culled.
    pub cull_distance: f64,
}

impl Default for AnimationConfig {
    fn default() -> Self {
        Self {
            frames: 48,
            fps: 24.0,
            size: 128,
            azimuths: vec![0.0, 60.0],
            rotate: true,
            root: false,
            cull_distance: 0.01,
        }
    }
}

impl AnimationConfig {
    pub fn validate(&self) -> Result<(), String> {
        if self.size < 4 || self.azimuths.is_empty() {
            return Err(format!(
                "animation.size must be ≥ 4 (got {}) and animation.azimuths non-empty",
                self.size
            ));
        }
        if !(self.fps.is_finite() && self.fps > 0.0) {
            return Err(format!("animation.fps must be positive, got {}", self.fps));
        }
        if !(self.cull_distance.is_finite() && self.cull_distance >= 0.0) {
            return Err(format!(
                "animation.cull_distance must be finite and ≥ 0, got {}",
                self.cull_distance
            ));
        }
        Ok(())
    }
}

/// The built-in motion: walking in place, then raising the right hand and waving.
pub fn builtin_motion(frames: usize, fps: f64) -> PoseSequence {
    let half = frames.max(2) as f64 / fps / 2.0;
    generate(
        &[
            Motion::Walk {
                seconds: half,
                speed: 1.2,
                turn_rate: 0.0,
            },
            Motion::Wave { seconds: half },
        ],
        Start {
            position: [0.0, 0.0],
            heading: 0.0,
            standing_height: 0.0,
        },
        fps,
    )
}

/// Frame `t`'s driving pose: the 21 body joints (and the root with `root`), the rest zero.
pub fn driving_pose(
    sequence: &PoseSequence,
    t: usize,
    root: bool,
) -> Result<[f64; 3 * JOINTS], AagError> {
    if sequence.joints != JOINTS {
        return Err(AagError::input(
            "pose sequence",
            format!(
                "has {} joints per frame; the built-in body takes {JOINTS}",
                sequence.joints
            ),
        ));
    }
    let source = sequence.pose(t);
    let mut pose = [0.0; 3 * JOINTS];
    let first = if root { 0 } else { 1 };
    pose[3 * first..3 * 22].copy_from_slice(&source[3 * first..3 * 22]);
    if pose.iter().any(|v| !v.is_finite()) {
        return Err(AagError::input(
            "pose sequence",
            format!("frame {t} has a non-finite joint angle"),
        ));
    }
    Ok(pose)
}

/// The identity-kept scores of one animation: the avatar against the prompted identity posed
/// alike.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct IdentityKept {
    /// PSNR of the bound avatar in the canonical pose against the identity in that pose.
    pub canonical_psnr: f64,
    /// Per frame, the mean over the scoring cameras.
    pub frame_psnr: Vec<f64>,
    pub mean_psnr: f64,
    pub min_psnr: f64,
    pub mean_ssim: f64,
    /// `canonical_psnr − mean_psnr`: what posing costs (spec T9: ≤ 1.5 dB).
    pub gap_db: f64,
}

impl IdentityKept {
    /// `: PSNR to the identity posed alike … (gap … dB)`.
    pub fn line(&self) -> String {
        format!(
            ": PSNR to the identity posed alike {:.2} dB mean, {:.2} dB worst frame, {:.2} dB in \
             the canonical pose (gap {:.2} dB)",
            self.mean_psnr, self.min_psnr, self.canonical_psnr, self.gap_db
        )
    }
}

/// One animation: how it was bound and how fast it runs, and the identity-kept scores where
/// the capture has the synthetic truth.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct AnimationScores {
    pub frames: usize,
    #[serde(flatten)]
    pub identity: Option<IdentityKept>,
    pub gaussians: usize,
    pub culled: usize,
    /// Frames per second of posing and rasterizing one view (no scoring, no files).
    pub fps: f64,
}

/// Where and whether frames are written.
pub struct FrameOutput<'a> {
    pub dir: &'a Path,
    pub ply: bool,
}

/// Drives `set` (the canonical avatar of `capture`'s prompted identity) through `sequence`,
/// scoring each frame against the identity's mesh posed alike where the capture has it;
/// writes frames into `output`.
pub fn animate(
    set: &GaussianSet,
    capture: &PortraitCapture,
    sequence: &PoseSequence,
    config: &AnimationConfig,
    output: Option<FrameOutput<'_>>,
) -> Result<AnimationScores, AagError> {
    config
        .validate()
        .map_err(|m| AagError::input("animation config", m))?;
    let device = set.means.device();
    let faces = &capture.body.faces;
    let rows = set.to_rows();
    let means: Vec<[f32; 3]> = (0..rows.len()).map(|i| rows.mean(i)).collect();
    let binding = bind(&means, &capture.canonical, faces, config.cull_distance);
    let cameras: Vec<Camera> = config
        .azimuths
        .iter()
        .map(|&az| {
            orbit_camera(
                [0.0; 3],
                az,
                0.0,
                capture.config.eval_distance,
                capture.config.eval_fovy_degrees,
                config.size,
            )
        })
        .collect();
    let canonical_pose = capture.config.canonical.axis_angle();
    let reference = score_pose(
        &binding,
        &rows,
        capture,
        &canonical_pose,
        &cameras,
        config,
        &device,
    )?;
    let mut kept = IdentityKept {
        canonical_psnr: reference.score.map_or(0.0, |s| s.0),
        ..IdentityKept::default()
    };
    let (mut images, mut seconds, mut ssim_sum) = (Vec::new(), 0.0, 0.0);
    let dataset = |e| AagError::Train(splatzoo_train::TrainError::Dataset(e));
    for t in 0..sequence.frames() {
        let pose = driving_pose(sequence, t, config.root)?;
        let frame = score_pose(&binding, &rows, capture, &pose, &cameras, config, &device)?;
        seconds += frame.seconds;
        if let Some((psnr, ssim)) = frame.score {
            kept.frame_psnr.push(psnr);
            ssim_sum += ssim;
        }
        if let Some(out) = &output {
            let mut panels = vec![srgb_image(&frame.avatar)];
            panels.extend(frame.truth.as_ref().map(srgb_image));
            let image = side_by_side(&panels);
            write_png(&out.dir.join(format!("frame_{t:04}.png")), &image).map_err(dataset)?;
            if out.ply {
                write_ply(&out.dir.join(format!("frame_{t:04}.ply")), &frame.posed)
                    .map_err(splatzoo_train::TrainError::from)?;
            }
            images.push(image);
        }
    }
    let frames = sequence.frames();
    let n = kept.frame_psnr.len().max(1) as f64;
    kept.mean_psnr = kept.frame_psnr.iter().sum::<f64>() / n;
    kept.min_psnr = kept
        .frame_psnr
        .iter()
        .copied()
        .fold(f64::INFINITY, f64::min);
    kept.mean_ssim = ssim_sum / n;
    kept.gap_db = kept.canonical_psnr - kept.mean_psnr;
    let scores = AnimationScores {
        frames,
        identity: reference.score.is_some().then_some(kept),
        gaussians: binding.kept.len(),
        culled: binding.culled,
        fps: frames.max(1) as f64 / seconds.max(1e-9),
    };
    if let Some(out) = &output {
        let fps = config.fps.round().max(1.0) as u32;
        write_gif(&out.dir.join("animation.gif"), &images, fps).map_err(dataset)?;
    }
    Ok(scores)
}

/// One posed frame.
struct PosedFrame {
    posed: GaussianSet,
    /// The first camera's avatar render and the identity's (where the capture has it),
    /// `[H, W, 3]`.
    avatar: Tensor<3>,
    truth: Option<Tensor<3>>,
    /// Mean PSNR and SSIM over the cameras against the identity posed alike.
    score: Option<(f64, f64)>,
    /// Posing the Gaussians and rasterizing one view.
    seconds: f64,
}

/// The avatar (`rows`, canonical) posed by `binding`, against the prompted identity posed
/// alike where the capture has it: mean PSNR and SSIM over `cameras`.
fn score_pose(
    binding: &SurfaceBinding,
    rows: &GaussianRows,
    capture: &PortraitCapture,
    pose: &[f64; 3 * JOINTS],
    cameras: &[Camera],
    config: &AnimationConfig,
    device: &Device,
) -> Result<PosedFrame, AagError> {
    let label = capture.config.prompt;
    let body = capture.posed_body(pose, device);
    let start = Instant::now();
    let posed = GaussianSet::from_rows(
        &binding.pose(rows, &body, &capture.body.faces, config.rotate),
        device,
    );
    let renders = render_views(&posed.splats(), cameras)?;
    let images: Vec<Tensor<3>> = renders
        .into_iter()
        .map(|r| r.color.clamp(0.0, 1.0))
        .collect();
    let seconds = start.elapsed().as_secs_f64() / cameras.len() as f64;
    let size = config.size as usize;
    let (Some(truth), Some(vertices)) = (
        capture.truth.as_ref(),
        capture.posed_vertices(label, pose, device),
    ) else {
        return Ok(PosedFrame {
            posed,
            avatar: images[0].clone(),
            truth: None,
            score: None,
            seconds,
        });
    };
    let (mut psnr_sum, mut ssim_sum, mut truths) = (0.0, 0.0, Vec::new());
    for (image, camera) in images.iter().zip(cameras) {
        let target = truth.bank.render_posed(label, &vertices, camera);
        let target = planar_to_tensor(&planar_rgb(&target), size, device);
        psnr_sum += psnr(image.clone(), target.clone());
        ssim_sum += scalar(ssim(image.clone(), target.clone()));
        truths.push(target);
    }
    let views = cameras.len() as f64;
    Ok(PosedFrame {
        posed,
        avatar: images[0].clone(),
        truth: Some(truths.swap_remove(0)),
        score: Some((psnr_sum / views, ssim_sum / views)),
        seconds,
    })
}
