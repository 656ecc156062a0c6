//! The synthetic protocol (spec §5, "our protocol"): the paper reports no metric, so the
//! avatar is scored against what the oracle's optimum is known to be — the prompted identity's
//! mesh renders from held-out cameras (16 azimuths × 3 elevations, never sampled in training):
//! PSNR/SSIM, prompt alignment in place of the CLIP score (the share of held-out views closer in
//! PSNR to the prompted identity than to any other of the K), the face view's PSNR against
//! the face crop inside the face mask, face asymmetry (|left − mirrored right| over the mask)
//! and the floater mass in front of the face (U6's failure); LPIPS too where the user gives its
//! weights (`lpips_weights`), and the CLIP score of the held-out views against the prompt where
//! the user gives a CLIP image encoder and the prompt's text embedding (`clip`).
//!
//! A user's photo has no held-out truth: its scores are the face view's against the face crop
//! (the face loss's own target, so a fit, not a held-out figure), the CLIP score where given,
//! the face asymmetry and the floater mass.

use crate::error::AagError;
use crate::trainer::{AagTrainer, planar_to_tensor, render_views};
use burn::tensor::{Tensor, TensorData};
use serde::{Deserialize, Serialize};
use splatzoo_train::TrainError;
use splatzoo_train::host_f32;
use splatzoo_train::loss::{masked_psnr, psnr, scalar, ssim};
use splatzoo_train::lpips::Lpips;

/// The held-out scores against the synthetic prompted identity (none for a user's photo).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HeldOutScores {
    /// Held-out PSNR/SSIM against the prompted identity.
    pub psnr: f64,
    pub ssim: f64,
    /// Held-out PSNR against each identity (index = label).
    pub psnr_per_identity: Vec<f64>,
    /// Share of held-out views closest to the prompted identity.
    pub prompt_alignment: f64,
    /// Held-out LPIPS against the prompted identity, with the user's LPIPS weights
    /// (`lpips_weights`; none ship).
    pub lpips: Option<f64>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AagScores {
    #[serde(flatten)]
    pub held_out: Option<HeldOutScores>,
    /// Face view against the face crop, inside the face mask (PSNR), and over the whole view
    /// (SSIM; both black off the body).
    pub face_psnr: f64,
    pub face_ssim: f64,
    /// Mean CLIP score (`100 · max(cos, 0)`) of the held-out views against the prompt, with the
    /// user's CLIP (`clip`; none ships).
    pub clip_score: Option<f64>,
    /// Mean |left − mirrored right| over the face mask in the face view (linear RGB).
    pub face_asymmetry: f64,
    /// Σ opacity of Gaussians more than τ in front of the face.
    pub floater_mass: f64,
    pub gaussians: usize,
}

impl AagTrainer {
    /// The scores of the avatar now (LPIPS with `lpips`).
    pub fn evaluate(&self, lpips: Option<&Lpips>) -> Result<AagScores, AagError> {
        let capture = &self.capture;
        let set = &self.node.set;
        let device = set.means.device();
        let splats = set.splats();
        let renders = render_views(&splats, &capture.eval_cameras)?;
        let images: Vec<_> = renders
            .iter()
            .map(|r| r.color.clone().clamp(0.0, 1.0).detach())
            .collect();
        let clip_score = match &self.clip {
            Some(clip) => {
                let mut sum = 0.0;
                for image in &images {
                    sum += clip.score(image.clone()).map_err(TrainError::from)?;
                }
                Some(sum / images.len().max(1) as f64)
            }
            None => None,
        };
        let held_out = capture
            .truth
            .as_ref()
            .map(|truth| self.held_out(&images, &truth.eval_targets, lpips));

        let face_size = capture.config.face_size as usize;
        let face = render_views(&splats, &[capture.face_camera])?.remove(0);
        let face_image = face.color.clamp(0.0, 1.0).detach();
        let mask = Tensor::<2>::from_data(
            TensorData::new(
                capture
                    .face_mask
                    .iter()
                    .map(|&m| f32::from(u8::from(m)))
                    .collect::<Vec<f32>>(),
                vec![face_size, face_size],
            ),
            &device,
        );
        let crop = planar_to_tensor(&capture.face_crop, face_size, &device);
        let face_psnr = masked_psnr(face_image.clone(), crop.clone(), mask);
        let face_ssim = scalar(ssim(face_image.clone(), crop));
        let pixels = host_f32(&face_image);
        let mut asymmetry = 0.0;
        let mut count = 0usize;
        for y in 0..face_size {
            for x in 0..face_size {
                let mirror = face_size - 1 - x;
                if capture.face_mask[y * face_size + x] && capture.face_mask[y * face_size + mirror]
                {
                    for c in 0..3 {
                        let a = pixels[(y * face_size + x) * 3 + c];
                        let b = pixels[(y * face_size + mirror) * 3 + c];
                        asymmetry += f64::from((a - b).abs());
                    }
                    count += 3;
                }
            }
        }
        let opacities: Vec<f32> = host_f32(&set.opacity_logits)
            .iter()
            .map(|l| 1.0 / (1.0 + (-l).exp()))
            .collect();
        Ok(AagScores {
            held_out,
            face_psnr,
            face_ssim,
            clip_score,
            face_asymmetry: asymmetry / count.max(1) as f64,
            floater_mass: self
                .line_of_sight
                .floater_mass(&host_f32(&set.means), &opacities),
            gaussians: set.len(),
        })
    }

    /// `images` (the held-out renders) against every identity's `targets` (`[identity][view]`).
    fn held_out(
        &self,
        images: &[Tensor<3>],
        targets: &[Vec<Vec<f32>>],
        lpips: Option<&Lpips>,
    ) -> HeldOutScores {
        let capture = &self.capture;
        let device = self.node.set.means.device();
        let size = capture.config.eval_size as usize;
        let k = targets.len();
        let prompt = capture.config.prompt;
        let mut per_identity = vec![0.0; k];
        let (mut ssim_sum, mut lpips_sum, mut aligned) = (0.0, 0.0, 0usize);
        for (v, image) in images.iter().enumerate() {
            let scores: Vec<f64> = targets
                .iter()
                .map(|views| psnr(image.clone(), planar_to_tensor(&views[v], size, &device)))
                .collect();
            let best = (0..k)
                .max_by(|a, b| scores[*a].total_cmp(&scores[*b]))
                .unwrap_or(prompt);
            aligned += usize::from(best == prompt);
            for (sum, s) in per_identity.iter_mut().zip(&scores) {
                *sum += s;
            }
            let target = planar_to_tensor(&targets[prompt][v], size, &device);
            if let Some(lpips) = lpips {
                lpips_sum += scalar(lpips.distance(image.clone(), target.clone()));
            }
            ssim_sum += scalar(ssim(image.clone(), target));
        }
        let views = images.len().max(1) as f64;
        let per_identity: Vec<f64> = per_identity.iter().map(|s| s / views).collect();
        HeldOutScores {
            psnr: per_identity[prompt],
            ssim: ssim_sum / views,
            psnr_per_identity: per_identity,
            prompt_alignment: aligned as f64 / views,
            lpips: lpips.map(|_| lpips_sum / views),
        }
    }
}
