//! APF-GS's scores (spec §5, A11): on reconstruction (training timesteps) and novel-view
//! synthesis (held-out timesteps), full-image PSNR/SSIM/LPIPS and human-region PSNR/SSIM by
//! drivestudio's formula (per image, MSE over the mask's pixels → PSNR, averaged over images;
//! SSIM's map averaged over the mask), on the dataset's coarse mask and on the true human mask,
//! plus the true accessory region; leakage of the human nodes into accessory pixels and the
//! IoU of their alpha with the true human; the σ trace against the injected pose error; the
//! refined pose's joint error against the prior's.

use crate::networks::ApfNetworks;
use crate::scene::{Composed, FrameInputs, Stage};
use crate::trainer::ApfTrainer;
use burn::module::Module;
use burn::tensor::{Device, Tensor, TensorData};
use serde::Serialize;
use splatzoo_datasets::masks::Mask;
use splatzoo_rasterizer::Camera;
use splatzoo_train::TrainError;
use splatzoo_train::avatar::{mpjpe_mm, track_joints};
use splatzoo_train::harness::{ScoreSum, Scores};
use splatzoo_train::host_f32;
use splatzoo_train::loss::{masked_psnr, masked_ssim, psnr, scalar, ssim};
use splatzoo_train::lpips::Lpips;

/// How the human region is scored (written into `metrics.json`).
pub const HUMAN_REGION: &str = "drivestudio's human_psnr: per image, MSE over the mask pixels → PSNR, averaged over images with a non-empty mask; SSIM map averaged over the mask";

/// Scores of one view set.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct SetScores {
    pub full: Scores,
    /// Over the dataset's coarse mask (every person, accessories included; the untracked
    /// pedestrian too, whom only the static background can show).
    pub human_coarse: Scores,
    /// Over the coarse mask of the tracked pedestrians (`∪_h M_coarse^h`).
    pub human_coarse_tracked: Scores,
    /// Over the tracked pedestrians' true body pixels and every true accessory pixel (absent
    /// where the capture has no ground truth: data on disk).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub human_true: Option<Scores>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub accessory_true: Option<Scores>,
    /// `Σ A_h` over true accessory pixels / their count (human nodes' alpha where an accessory is).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub leakage: Option<f64>,
    /// IoU of `A_h > 0.5` with the true human mask (pooled over the images).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub human_iou: Option<f64>,
    pub images: usize,
}

/// A mask as a 0/1 image `[H, W]`.
pub(crate) fn mask_tensor(m: &Mask, device: &Device) -> Tensor<2> {
    Tensor::from_data(
        TensorData::new(
            m.data.iter().map(|&b| f32::from(b)).collect::<Vec<_>>(),
            [m.height, m.width],
        ),
        device,
    )
}

impl ApfTrainer {
    /// The scene at `frame` for `camera` from the current networks (no autodiff), every
    /// tracked person's residual on once S2 has started.
    pub fn compose_at(&self, nets: &ApfNetworks, frame: usize, camera: &Camera) -> Composed {
        let stage = self.stage(self.step);
        let visible = vec![true; self.capture.people.len()];
        let guided = self.guided(nets, frame, &visible, stage);
        self.scene.compose(
            &FrameInputs {
                camera,
                frame,
                time: frame as f64 / self.capture.fps,
                guided: &guided,
                nets,
                stage,
                duration: self.duration(),
                in_step: false,
            },
            &self.config,
        )
    }

    /// Colour render of composed splats (no autodiff) at the current SH degree.
    pub fn render_splats(
        &self,
        splats: &splatzoo_rasterizer::Splats,
        camera: Camera,
    ) -> Result<splatzoo_rasterizer::Render, TrainError> {
        self.raster(splats, camera, false, false)
    }

    /// The composed frame of view `index` rendered now (no autodiff), with the human nodes'
    /// alpha from the node-type pass.
    pub fn render_view(
        &self,
        index: usize,
    ) -> Result<(splatzoo_rasterizer::Render, Tensor<2>), TrainError> {
        let view = &self.capture.views[index];
        let composed = self.compose_at(&self.nets.valid(), view.frame, &view.camera);
        let render = self.raster(&composed.splats, view.camera, false, false)?;
        let features = self.raster(&Self::node_features(&composed), view.camera, true, false)?;
        let [h, w, _] = features.color.dims();
        let human_alpha = features.color.slice([0..h, 0..w, 0..1]).reshape([h, w]);
        Ok((render, human_alpha))
    }

    /// Scores of the views `indices`.
    pub fn score_set(
        &self,
        indices: &[usize],
        lpips: Option<&Lpips>,
    ) -> Result<SetScores, TrainError> {
        let device = self.background.device();
        let (mut full, mut coarse, mut tracked, mut human, mut accessory) = (
            ScoreSum::default(),
            ScoreSum::default(),
            ScoreSum::default(),
            ScoreSum::default(),
            ScoreSum::default(),
        );
        let (mut leak, mut leak_n) = (0.0f64, 0.0f64);
        // Whether any view has true human / accessory pixels (synthetic data only).
        let mut truth = (false, false);
        let (mut inter, mut union) = (0usize, 0usize);
        for &i in indices {
            let view = &self.capture.views[i];
            let (render, human_alpha) = self.render_view(i)?;
            let image = render.color.clamp(0.0, 1.0);
            let target = view.image.clone();
            let perceptual = lpips.map(|l| scalar(l.distance(image.clone(), target.clone())));
            full.add(
                psnr(image.clone(), target.clone()),
                scalar(ssim(image.clone(), target.clone())),
                perceptual,
            );
            let region = |sum: &mut ScoreSum, m: &Mask| {
                if m.area() > 0 {
                    let t = mask_tensor(m, &device);
                    sum.add(
                        masked_psnr(image.clone(), target.clone(), t.clone()),
                        scalar(masked_ssim(image.clone(), target.clone(), t)),
                        None,
                    );
                }
            };
            region(&mut coarse, &view.coarse);
            let tracked_coarse = view.people.iter().fold(
                Mask::empty(view.coarse.width, view.coarse.height),
                |m, p| m.or(&p.coarse),
            );
            region(&mut tracked, &tracked_coarse);
            if let Some(m) = &view.true_human {
                region(&mut human, m);
                truth.0 |= m.area() > 0;
            }
            if let Some(m) = &view.true_accessory {
                region(&mut accessory, m);
                truth.1 |= m.area() > 0;
            }
            let alpha = host_f32(&human_alpha);
            if let Some(m) = &view.true_accessory {
                for (a, &on) in alpha.iter().zip(&m.data) {
                    if on {
                        leak += f64::from(*a);
                        leak_n += 1.0;
                    }
                }
            }
            if let Some(m) = &view.true_human {
                for (a, &on) in alpha.iter().zip(&m.data) {
                    let predicted = *a > 0.5;
                    inter += usize::from(predicted && on);
                    union += usize::from(predicted || on);
                }
            }
        }
        Ok(SetScores {
            full: full.mean(),
            human_coarse: coarse.mean(),
            human_coarse_tracked: tracked.mean(),
            human_true: truth.0.then(|| human.mean()),
            accessory_true: truth.1.then(|| accessory.mean()),
            leakage: (leak_n > 0.0).then(|| leak / leak_n),
            human_iou: (union > 0).then(|| inter as f64 / union as f64),
            images: indices.len(),
        })
    }

    /// σ of every (person, frame) from the current networks (`None` before S2 or with the
    /// residual off).
    pub fn sigma_trace(&self) -> Option<Vec<Vec<f64>>> {
        let stage: Stage = self.stage(self.step);
        if !stage.residual {
            return None;
        }
        let nets = self.nets.valid();
        Some(
            (0..self.capture.people.len())
                .map(|h| {
                    (0..self.capture.frames)
                        .map(|t| {
                            let g = crate::guide::guide(&nets, &self.capture, &self.config, h, t);
                            f64::from(host_f32(&g.sigma)[0])
                        })
                        .collect()
                })
                .collect(),
        )
    }

    /// Mean per-joint position error (mm) of the refined track and of the prior against the
    /// truth, over every tracked person with a true track and every frame.
    pub fn pose_errors(&self) -> Option<(f64, f64)> {
        let device = self.background.device();
        let (mut refined, mut prior, mut frames) = (0.0, 0.0, 0usize);
        for (h, person) in self.capture.people.iter().enumerate() {
            let truth = track_joints(&self.model, person.truth.as_ref()?, &device);
            let node = &self.scene.humans[h].node;
            let rows = (0..self.capture.frames)
                .map(|t| node.joint_positions(t))
                .collect();
            let f = self.capture.frames as f64;
            refined += f * mpjpe_mm(Tensor::stack(rows, 0), truth.clone());
            prior += f * mpjpe_mm(track_joints(&self.model, &person.prior, &device), truth);
            frames += self.capture.frames;
        }
        (frames > 0).then(|| (refined / frames as f64, prior / frames as f64))
    }
}

/// Spearman's rank correlation of two equally long series (`None` when either is constant).
pub fn spearman(a: &[f64], b: &[f64]) -> Option<f64> {
    fn ranks(v: &[f64]) -> Vec<f64> {
        let mut order: Vec<usize> = (0..v.len()).collect();
        order.sort_by(|&i, &j| v[i].total_cmp(&v[j]));
        let mut r = vec![0.0; v.len()];
        let mut k = 0;
        while k < order.len() {
            let mut e = k;
            while e + 1 < order.len() && v[order[e + 1]] == v[order[k]] {
                e += 1;
            }
            let mean = 0.5 * (k + e) as f64;
            for &i in &order[k..=e] {
                r[i] = mean;
            }
            k = e + 1;
        }
        r
    }
    let (ra, rb) = (ranks(a), ranks(b));
    let n = a.len() as f64;
    let ma = ra.iter().sum::<f64>() / n;
    let mb = rb.iter().sum::<f64>() / n;
    let cov: f64 = ra.iter().zip(&rb).map(|(x, y)| (x - ma) * (y - mb)).sum();
    let va: f64 = ra.iter().map(|x| (x - ma).powi(2)).sum();
    let vb: f64 = rb.iter().map(|y| (y - mb).powi(2)).sum();
    (va > 0.0 && vb > 0.0).then(|| cov / (va * vb).sqrt())
}
