//! Stage D's scores (§5.1.2 of Prior-4D and the spec's additions), at the synchronised
//! evaluation camera, which no stage trains on: PSNR, SSIM (and 1 − SSIM, the paper's
//! "D-SSIM"), LPIPS where weights are given; the PSNR over the true person pixels alone (per
//! frame, averaged over the frames that show her: the whole image hardly sees what the avatar
//! prior adds — the evaluation camera sees the back the acting video never films); the avatar's normal angle error (mean, median)
//! against the true normals over the true person mask (a pixel the avatar leaves uncovered,
//! rendered normal shorter than 0.1, counts 90°); the mask
//! IoU of the rendered avatar (alpha > 0.5) against the true mask. The avatar is placed by the
//! (refined) acting camera of the same frame. On the acting frames, where the capture has its
//! truth ([`TruthScores`]): |σ/σ* − 1|, the foot penetration rate against the true floor
//! (lowest foot vertex more than Δ_c below it), the mean absolute and the mean signed height of
//! the 25 lowest foot vertices, the acting cameras' error (centre RMS in metres, mean rotation
//! in degrees) and the joint error of the refined body track (camera frame, mm).
//!
//! A real capture has no evaluation camera and no truth: it is scored at its held-out acting
//! frames ([`crate::data::ActingFrame::held_out`]), each seen from its own (given) camera with
//! the body placed there from the prior, against its given person mask; the truth scores are
//! then `None`, and the normal error is against the given normal maps where it has some
//! (`None` without).

use crate::avatar::posed_avatar;
use crate::camera::{RigidFrame, camera_to_world};
use crate::data::{CaptureTruth, Prior4dCapture};
use crate::error::Prior4dError;
use crate::joint::JointStage;
use crate::locate::place;
use burn::tensor::{Tensor, TensorData};
use serde::{Deserialize, Serialize};
use splatzoo_models::body::builtin_body;
use splatzoo_train::avatar::{mpjpe_mm, track_joints};
use splatzoo_train::harness::read_back;
use splatzoo_train::host_f32;
use splatzoo_train::loss::{masked_psnr, psnr, scalar, ssim};
use splatzoo_train::lpips::Lpips;

/// Everything one evaluation reports.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct JointScores {
    pub psnr: f64,
    /// PSNR over the true person mask; `None` where no evaluated frame shows the person.
    pub human_psnr: Option<f64>,
    pub ssim: f64,
    pub one_minus_ssim: f64,
    pub lpips: Option<f64>,
    /// `None` where the evaluation frames carry no normals (a real capture).
    pub normal_mean_degrees: Option<f64>,
    pub normal_median_degrees: Option<f64>,
    pub mask_iou: f64,
    pub sigma: f64,
    /// Against the capture's truth; `None` on a real capture (its keys then leave the JSON).
    #[serde(flatten)]
    pub truth: Option<TruthScores>,
    pub frames: usize,
}

/// The scores only the synthetic capture's truth ([`crate::data::CaptureTruth`]) allows.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct TruthScores {
    pub sigma_star: f64,
    pub sigma_error: f64,
    pub penetration_rate: f64,
    /// Mean |height| and mean signed height of the 25 lowest foot vertices, mm.
    pub foot_distance_mm: f64,
    pub foot_height_mm: f64,
    pub camera_centre_rms_mm: f64,
    pub camera_rotation_degrees: f64,
    pub mpjpe_mm: f64,
    pub prior_mpjpe_mm: f64,
}

fn angle_degrees(a: [f64; 3], b: [f64; 3]) -> f64 {
    let dot: f64 = (0..3).map(|k| a[k] * b[k]).sum();
    let la = a.iter().map(|v| v * v).sum::<f64>().sqrt();
    let lb = b.iter().map(|v| v * v).sum::<f64>().sqrt();
    (dot / (la * lb)).clamp(-1.0, 1.0).acos().to_degrees()
}

fn rotation_angle_degrees(a: [[f64; 3]; 3], b: [[f64; 3]; 3]) -> f64 {
    let trace: f64 = (0..3)
        .map(|i| (0..3).map(|k| a[i][k] * b[i][k]).sum::<f64>())
        .sum();
    ((trace - 1.0) / 2.0).clamp(-1.0, 1.0).acos().to_degrees()
}

fn rows3(t: &Tensor<2>) -> Vec<[f64; 3]> {
    host_f32(t)
        .chunks(3)
        .map(|r| [f64::from(r[0]), f64::from(r[1]), f64::from(r[2])])
        .collect()
}

impl JointStage {
    /// Scene (`scene`, its splats now) and avatar at evaluation frame `t` seen from its camera,
    /// the avatar placed by the acting camera of its acting frame (refined when `refine`).
    pub fn render_eval(
        &self,
        capture: &Prior4dCapture,
        scene: &splatzoo_rasterizer::Splats,
        t: usize,
        refine: bool,
    ) -> Result<crate::render::Layers, Prior4dError> {
        let eval = &capture.eval[t];
        let frame = eval.acting_frame;
        let acting = self.acting_view(capture, frame, refine, None);
        let avatar = self.placed_avatar(capture, frame, &acting, self.log_sigma.clone());
        let view = RigidFrame::of_camera(&eval.camera, &self.log_sigma.device());
        self.layers(
            Some(scene),
            Some(&avatar),
            &view,
            &eval.camera,
            capture.scene_background,
        )
    }

    /// Renders the evaluation frames [`Self::evaluate`] scores (read back, unscored); returns
    /// how many.
    pub fn render_held_out(
        &self,
        capture: &Prior4dCapture,
        refine: bool,
        stride: usize,
    ) -> Result<usize, Prior4dError> {
        let scene = self.scene_splats(capture);
        let frames: Vec<usize> = (0..capture.eval.len()).step_by(stride.max(1)).collect();
        for &t in &frames {
            read_back(&self.render_eval(capture, &scene, t, refine)?.color);
        }
        Ok(frames.len())
    }

    /// Scores now; `sigma_star` is the true global scale for this avatar's body, where the
    /// capture knows it.
    pub fn evaluate(
        &self,
        capture: &Prior4dCapture,
        refine: bool,
        stride: usize,
        sigma_star: Option<f64>,
        lpips: Option<&Lpips>,
    ) -> Result<JointScores, Prior4dError> {
        let scene = self.scene_splats(capture);
        let frames: Vec<usize> = (0..capture.eval.len()).step_by(stride.max(1)).collect();
        let (mut p, mut s, mut lp, mut iou) = (0.0, 0.0, 0.0, 0.0);
        let mut human = Vec::new();
        let mut angles = Vec::new();
        for &t in &frames {
            let eval = &capture.eval[t];
            let layers = self.render_eval(capture, &scene, t, refine)?;
            let image = layers.color.clamp(0.0, 1.0);
            p += psnr(image.clone(), eval.image.clone());
            if eval.mask.data.iter().any(|&m| m) {
                let [h, w, _] = image.dims();
                let mask: Vec<f32> = eval.mask.data.iter().map(|&m| f32::from(m)).collect();
                let mask = Tensor::<2>::from_data(TensorData::new(mask, [h, w]), &image.device());
                human.push(masked_psnr(image.clone(), eval.image.clone(), mask));
            }
            s += scalar(ssim(image.clone(), eval.image.clone()));
            if let Some(l) = lpips {
                lp += scalar(l.distance(image, eval.image.clone()));
            }
            let alpha = host_f32(&layers.avatar_alpha);
            let normal = host_f32(&layers.normal);
            let (mut inter, mut union) = (0usize, 0usize);
            for (k, &a) in alpha.iter().enumerate() {
                let ours = a > 0.5;
                let truth = eval.mask.data[k];
                inter += usize::from(ours && truth);
                union += usize::from(ours || truth);
                // A zero normal is unknown there (a given map's gaps; never on the truth's).
                let known = eval
                    .normals
                    .as_ref()
                    .map(|normals| normals[k].map(f64::from));
                if let (true, Some(m)) = (truth, known)
                    && m.iter().map(|v| v * v).sum::<f64>() > 1e-12
                {
                    let n = [0, 1, 2].map(|c| f64::from(normal[3 * k + c]));
                    let covered = n.iter().map(|v| v * v).sum::<f64>() >= 0.01;
                    angles.push(if covered { angle_degrees(n, m) } else { 90.0 });
                }
            }
            iou += if union == 0 {
                1.0
            } else {
                inter as f64 / union as f64
            };
        }
        let n = frames.len().max(1) as f64;
        angles.sort_by(f64::total_cmp);
        let has_normals = frames.iter().any(|&t| capture.eval[t].normals.is_some());
        // No person in any evaluated frame: nothing to score, reported as the worst case.
        let mean_angle = if angles.is_empty() {
            90.0
        } else {
            angles.iter().sum::<f64>() / angles.len() as f64
        };
        let median_angle = angles.get(angles.len() / 2).copied().unwrap_or(90.0);
        let truth = match (&capture.truth, sigma_star) {
            (Some(truth), Some(sigma_star)) => {
                Some(self.truth_scores(capture, truth, refine, sigma_star)?)
            }
            _ => None,
        };
        Ok(JointScores {
            psnr: p / n,
            human_psnr: (!human.is_empty()).then(|| human.iter().sum::<f64>() / human.len() as f64),
            ssim: s / n,
            one_minus_ssim: 1.0 - s / n,
            lpips: lpips.map(|_| lp / n),
            normal_mean_degrees: has_normals.then_some(mean_angle),
            normal_median_degrees: has_normals.then_some(median_angle),
            mask_iou: iou / n,
            sigma: self.sigma(),
            truth,
            frames: frames.len(),
        })
    }

    /// On every acting frame: σ against σ*, the feet against the true floor (`y = 0` in scene
    /// units), the cameras and the body track against the truth.
    fn truth_scores(
        &self,
        capture: &Prior4dCapture,
        truth: &CaptureTruth,
        refine: bool,
        sigma_star: f64,
    ) -> Result<TruthScores, Prior4dError> {
        let scale = truth.scale;
        let margin = 0.02 * scale;
        let (mut penetrating, mut heights, mut distances) = (0usize, 0.0, 0.0);
        let (mut centre_sq, mut rotation_err) = (0.0, 0.0);
        for t in 0..capture.acting.len() {
            let view = self.acting_view(capture, t, refine, None);
            let posed = posed_avatar(&self.avatar, t, &capture.acting[t].camera, &self.faces);
            let placed = place(posed.splats, self.log_sigma.clone(), &view);
            let means = rows3(&placed.means);
            let mut feet: Vec<f64> = self.feet.iter().map(|&k| means[k][1]).collect();
            feet.sort_by(f64::total_cmp);
            if feet.first().is_some_and(|&h| h < -margin) {
                penetrating += 1;
            }
            let lowest = &feet[..feet.len().min(25)];
            let count = lowest.len().max(1) as f64;
            heights += lowest.iter().sum::<f64>() / count;
            distances += lowest.iter().map(|h| h.abs()).sum::<f64>() / count;
            let camera = truth.acting_cameras.get(t).ok_or_else(|| {
                Prior4dError::input(
                    "capture truth",
                    format!(
                        "{} true cameras for {} acting frames",
                        truth.acting_cameras.len(),
                        capture.acting.len()
                    ),
                )
            })?;
            let (r_true, c_true) = camera_to_world(camera);
            let r = rows3(&view.rotation);
            let c = host_f32(&view.centre);
            centre_sq += (0..3)
                .map(|k| (f64::from(c[k]) - c_true[k]).powi(2))
                .sum::<f64>();
            rotation_err += rotation_angle_degrees([r[0], r[1], r[2]], r_true);
        }
        let f = capture.acting.len().max(1) as f64;

        let device = self.log_sigma.device();
        let model = &builtin_body().model;
        let true_joints = track_joints(model, &truth.acting_motion, &device);
        let prior = track_joints(model, &capture.acting_prior, &device);
        let refined: Vec<Tensor<2>> = (0..capture.acting.len())
            .map(|t| self.avatar.joint_positions(t))
            .collect();
        let refined = Tensor::stack::<3>(refined, 0);
        let sigma = self.sigma();
        Ok(TruthScores {
            sigma_star,
            sigma_error: (sigma / sigma_star - 1.0).abs(),
            penetration_rate: penetrating as f64 / f,
            foot_distance_mm: distances / f / scale * 1000.0,
            foot_height_mm: heights / f / scale * 1000.0,
            camera_centre_rms_mm: (centre_sq / f).sqrt() / scale * 1000.0,
            camera_rotation_degrees: rotation_err / f,
            mpjpe_mm: mpjpe_mm(refined, true_joints.clone()),
            prior_mpjpe_mm: mpjpe_mm(prior, true_joints),
        })
    }
}
