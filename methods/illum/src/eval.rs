//! Held-out scores (spec §5, HUGS' protocol the paper follows) and the renders behind them.
//!
//! - **Full image** and **human crop** (the person's mask bounding box in both images) PSNR,
//!   SSIM and LPIPS (LPIPS with user weights only) on the held-out frames.
//! - **Albedo**: PSNR of the rendered albedo map against the renderer's albedo buffer on the
//!   person's pixels, after the per-channel least-squares scale (albedo and light share a
//!   scale no image can fix).
//! - **Relit**: the held-out frames under the capture's other lights; each probe keeps what it
//!   learned and takes the analytic change of light at its position in the learned units,
//!   `p + g (T_new − T_train)`, with `g` the per-channel gain of the learned probes against
//!   the training light's analytic SH (albedo and light share a scale); the human crop is
//!   scored (the scene stays baked, as in the paper's application). A model
//!   without the light volume renders its fixed colours: the baseline relighting must beat.
//! - **Shadow region**: pixels the person does not cover whose true colour the person's cast
//!   shadow darkens by more than 15 % (`IllumFrame::shadow_ratio`); mean absolute sRGB error
//!   there, with the decoder's `ao` and with `ao ≡ 1`.
//! - **Novel poses**: the novel-pose clip (the same identity turning and waving) from its
//!   fixed camera, full image.
//! - **F_vis** on the held-out frames' poses: accuracy against 512 fresh ray-cast labels per
//!   frame, beside the majority rate (what a constant guess scores).
//! - **Probes**: the relative RMS error of the gain-corrected learned probe SH against the
//!   analytic SH of the training light, over the whole grid and over the probes shading can
//!   read (the corners of the cells the training poses' bodies occupy).
//!
//! Albedo, relit, shadow-region, novel-pose and probe scores need the synthetic capture's truth
//! ([`TruthScores`]); a capture on disk gets the image, human-crop and F_vis scores alone.

use crate::IllumError;
use crate::data::{CaptureTruth, IllumFrame, relighting};
use crate::human::pose_refined;
use crate::light_volume::LightVolume;
use crate::render::{HumanLayer, JointMaps, SceneLayer, render_joint};
use crate::steps::Nets;
use crate::trainer::{FramePose, IllumTrainer};
use burn::module::{Module, Param};
use burn::tensor::{Tensor, TensorData};
use serde::{Deserialize, Serialize};
use splatzoo_rasterizer::{Camera, ColorMode, RasterSettings, Splats};
use splatzoo_train::harness::read_back;
use splatzoo_train::host_f32;
use splatzoo_train::loss::{psnr, scalar, ssim};
use splatzoo_train::lpips::Lpips;
use splatzoo_train::scene::{FrameContext, FrameQuery, SceneNode};

/// Pixels whose true shadow ratio is below this count as the cast-shadow region.
pub const SHADOW_RATIO: f32 = 0.85;

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct IllumScores {
    pub frames: usize,
    pub psnr: f64,
    pub ssim: f64,
    pub lpips: Option<f64>,
    pub human_psnr: f64,
    pub human_ssim: f64,
    pub human_lpips: Option<f64>,
    /// F_vis's accuracy on held-out poses and the labels' majority rate (trained F_vis only).
    pub visibility_accuracy: Option<f64>,
    pub visibility_majority: Option<f64>,
    /// The scores only the synthetic capture's truth allows (flattened into the JSON: the
    /// keys are absent for a capture on disk).
    #[serde(flatten)]
    pub truth: Option<TruthScores>,
}

/// Scores against what only the renderer knows.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TruthScores {
    /// Stage 2 with the light volume only.
    pub albedo_psnr: Option<f64>,
    /// Mean human-crop PSNR over the relit frames, and per light.
    pub relit_human_psnr: f64,
    pub relit: Vec<(String, f64)>,
    pub shadow_pixels: usize,
    pub shadow_error: f64,
    /// The same with `ao ≡ 1` (only with the decoder).
    pub shadow_error_without_ao: Option<f64>,
    pub novel_pose_psnr: f64,
    pub probe_relative_error: Option<f64>,
    /// The same over the probes shading can read (the corners of the cells a training pose's
    /// body occupies), each with its own gain, and how many they are: the rest of the grid
    /// gets no gradient but what the smoothness term (Eq. 13) carries.
    pub probe_relative_error_seen: Option<f64>,
    pub probes_seen: Option<usize>,
    /// Per SH band over the same probes: the learned and the gain-scaled analytic RMS, their
    /// relative error and their cosine (whether the band points as the light's). A Lambertian
    /// surface reads band l through the cosine lobe's `A_l / π` (1, 2/3, 1/4), so a band can
    /// be far off while shading barely sees it.
    pub probe_bands_seen: Option<Vec<crate::probe_scores::ProbeBand>>,
    /// The seen probes' relative error with each band weighted by `A_l / π`: the error in the
    /// irradiance a Lambertian surface receives.
    pub probe_irradiance_error_seen: Option<f64>,
}

/// `s` on the autodiff device without gradient tracking (renders for scores and exports
/// read the stage-2 pipeline, which runs on that device).
pub fn untracked(s: Splats) -> Splats {
    Splats {
        means: s.means.autodiff(),
        quats: s.quats.autodiff(),
        log_scales: s.log_scales.autodiff(),
        opacity_logits: s.opacity_logits.autodiff(),
        colors: s.colors.autodiff(),
    }
}

/// The person's mask bounding box `(rows, cols)`, `None` when the mask is empty.
pub fn person_box(frame: &IllumFrame) -> Option<(std::ops::Range<usize>, std::ops::Range<usize>)> {
    let [h, w, _] = frame.image.dims();
    let (mut r0, mut r1, mut c0, mut c1) = (h, 0, w, 0);
    for (i, &p) in frame.person.iter().enumerate() {
        if p {
            let (r, c) = (i / w, i % w);
            r0 = r0.min(r);
            r1 = r1.max(r + 1);
            c0 = c0.min(c);
            c1 = c1.max(c + 1);
        }
    }
    (r1 > r0 && c1 > c0).then_some((r0..r1, c0..c1))
}

/// Per-channel least-squares gains `g` minimising `Σ (g_c x − y)²` over pairs.
pub(crate) fn channel_gains(pairs: &[([f64; 3], [f64; 3])]) -> [f64; 3] {
    [0, 1, 2].map(|c| {
        let (xy, xx) = pairs.iter().fold((0.0, 0.0), |(xy, xx), (x, y)| {
            (xy + x[c] * y[c], xx + x[c] * x[c])
        });
        if xx > 1e-20 { xy / xx } else { 1.0 }
    })
}

impl IllumTrainer {
    /// Gradient-free copies of the networks (evaluation records no graph).
    pub fn frozen(
        &self,
    ) -> (
        LightVolume,
        crate::shadow::ShadowDecoder,
        splatzoo_models::networks::hash_mlp::HashMlp,
    ) {
        (
            self.volume.clone().no_grad(),
            self.decoder.clone().no_grad(),
            self.materials.clone().no_grad(),
        )
    }

    /// The scene and the human of `pose` from `camera`, without gradients.
    pub fn render_view(
        &self,
        nets: Nets,
        camera: &Camera,
        pose: &FramePose,
        with_ao: bool,
    ) -> Result<JointMaps, IllumError> {
        let settings = RasterSettings::new(*camera, ColorMode::Features);
        let query = FrameQuery {
            camera,
            frame: 0,
            time: 0.0,
        };
        let context = FrameContext { outputs: &[] };
        let scene = untracked(self.scene.render(&query, &context).splats);
        let (human, channels) = match &self.stage2 {
            Some(stage2) => {
                let canonical = untracked(stage2.human.render(&query, &context).splats);
                self.stage2_human(
                    nets,
                    &canonical,
                    pose,
                    camera,
                    self.config.stage2.sampling(false),
                    None,
                )
            }
            None => {
                let body = self.body.clone().no_grad();
                let v = self.mesh.vertex_count();
                let offsets = body.offsets(&self.body_queries);
                let placed = pose_refined(&pose.posed, offsets).reshape([v, 3]);
                let splats =
                    body.face_splats(&self.mesh, placed, body.vertex_colours(&self.body_queries));
                let f = splats.len();
                let zeros = |c: usize| Tensor::<2>::zeros([f, c], &self.autodiff);
                let colour = splats.colors.clone().reshape([f, 3]);
                (splats, [colour, zeros(2), zeros(3), zeros(3)])
            }
        };
        let human_points: Vec<[f64; 3]> = host_f32(&human.means)
            .chunks(3)
            .map(|p| [p[0], p[1], p[2]].map(f64::from))
            .collect();
        let ao = if with_ao {
            self.scene_ao(nets, &scene.means, &human_points)?.0
        } else {
            None
        };
        let [colour, material, albedo, normals] = channels;
        render_joint(
            Some(SceneLayer {
                splats: &scene,
                degree: self.scene_degree(self.step),
                ao,
            }),
            Some(HumanLayer {
                splats: &human,
                colour,
                material,
                albedo,
                normals,
            }),
            &settings,
            self.capture.background,
        )
    }

    /// A copy of the volume whose probes change by `gain ×` the analytic change from the
    /// training light to `lighting`.
    fn relit_volume(
        truth: &CaptureTruth,
        volume: &LightVolume,
        lighting: &splatzoo_datasets::render::Lighting,
        gain: [f64; 3],
    ) -> LightVolume {
        let grid = *volume.grid();
        let [p, k, _] = volume.sh.val().dims();
        let mut values = host_f32(&volume.sh.val());
        for i in 0..p {
            let position = grid.position(i);
            let (new, old) = (lighting.radiance_sh(position), truth.probe_truth(position));
            for j in 0..k.min(9) {
                for c in 0..3 {
                    values[(i * k + j) * 3 + c] += (gain[c] * (new[j][c] - old[j][c])) as f32;
                }
            }
        }
        let mut relit = volume.clone();
        relit.sh = Param::from_tensor(Tensor::from_data(
            TensorData::new(values, [p, k, 3]),
            &volume.sh.val().device(),
        ));
        relit
    }

    /// The held-out frames [`Self::evaluate`] scores, rendered and read back, unscored; returns
    /// how many.
    pub fn render_held_out(&self) -> Result<usize, IllumError> {
        let (volume, decoder, materials) = self.frozen();
        let nets = Nets {
            volume: &volume,
            decoder: &decoder,
            materials: &materials,
        };
        let tests: Vec<&IllumFrame> = self
            .capture
            .test_frames()
            .step_by(self.config.eval_stride)
            .collect();
        for frame in &tests {
            let pose = self.frame_pose(frame.frame, true);
            read_back(&self.render_view(nets, &frame.camera, &pose, true)?.colour);
        }
        Ok(tests.len())
    }

    /// Scene Gaussians plus the human's (its freed Gaussians in stage 2, one per mesh face in
    /// stage 1).
    pub fn gaussians(&self) -> usize {
        let human = match &self.stage2 {
            Some(stage2) => stage2.human.gaussians(),
            None => self.mesh.model.face_count(),
        };
        self.scene.gaussians() + human
    }

    /// Every score of the module docs; `lpips` when the user gave its weights.
    pub fn evaluate(&self, lpips: Option<&Lpips>) -> Result<IllumScores, IllumError> {
        let (volume, decoder, materials) = self.frozen();
        let nets = Nets {
            volume: &volume,
            decoder: &decoder,
            materials: &materials,
        };
        let stride = self.config.eval_stride;
        let tests: Vec<&IllumFrame> = self.capture.test_frames().step_by(stride).collect();
        let mut scores = IllumScores {
            frames: tests.len(),
            ..IllumScores::default()
        };
        let mut truth_scores = TruthScores::default();
        let pbr = self.stage2.is_some() && self.config.ablation.light_volume;
        let mut lp = (0.0, 0.0);
        let mut albedo_pairs = Vec::new();
        let (mut shadow_sum, mut shadow_open_sum) = (0.0, 0.0);
        for frame in &tests {
            let pose = self.frame_pose(frame.frame, true);
            let maps = self.render_view(nets, &frame.camera, &pose, true)?;
            let image = frame.image.clone().autodiff();
            let colour = frame.on_real_pixels(maps.colour.clone(), image.clone());
            scores.psnr += psnr(colour.clone(), image.clone());
            scores.ssim += scalar(ssim(colour.clone(), image.clone()));
            if let Some(l) = lpips {
                lp.0 += scalar(l.distance(colour.clone().inner(), frame.image.clone()));
            }
            if let Some((rows, cols)) = person_box(frame) {
                let crop = |t: Tensor<3>| t.slice([rows.clone(), cols.clone(), 0..3]);
                scores.human_psnr += psnr(crop(colour.clone()), crop(image.clone()));
                scores.human_ssim += scalar(ssim(crop(colour.clone()), crop(image.clone())));
                if let Some(l) = lpips {
                    lp.1 +=
                        scalar(l.distance(crop(colour.clone()).inner(), crop(frame.image.clone())));
                }
            }
            let (Some(ratio), Some(truth)) = (frame.shadow_ratio(), &frame.truth) else {
                continue;
            };
            let rendered = host_f32(&maps.colour);
            let observed = host_f32(&frame.image);
            let shadowed: Vec<usize> = (0..ratio.len())
                .filter(|&i| ratio[i].is_some_and(|r| r < SHADOW_RATIO))
                .collect();
            let error = |values: &[f32]| -> f64 {
                shadowed
                    .iter()
                    .flat_map(|&i| (0..3).map(move |c| 3 * i + c))
                    .map(|j| f64::from((values[j] - observed[j]).abs()))
                    .sum::<f64>()
            };
            truth_scores.shadow_pixels += shadowed.len();
            shadow_sum += error(&rendered);
            if self.config.ablation.shadow_decoder() {
                let open = self.render_view(nets, &frame.camera, &pose, false)?;
                shadow_open_sum += error(&host_f32(&open.colour));
            }
            if pbr {
                let albedo = host_f32(&maps.albedo);
                let alpha = host_f32(&maps.human_alpha);
                for (i, &person) in frame.person.iter().enumerate() {
                    if person && alpha[i] > 0.5 {
                        let x = [0, 1, 2].map(|c| f64::from(albedo[3 * i + c]));
                        let y = truth.albedo[i].map(f64::from);
                        albedo_pairs.push((x, y));
                    }
                }
            }
        }
        let n = tests.len().max(1) as f64;
        scores.psnr /= n;
        scores.ssim /= n;
        scores.human_psnr /= n;
        scores.human_ssim /= n;
        if lpips.is_some() {
            scores.lpips = Some(lp.0 / n);
            scores.human_lpips = Some(lp.1 / n);
        }
        if pbr && self.config.visibility.source == crate::visibility::VisibilitySource::Net {
            let (accuracy, majority) = self.visibility_scores(&tests);
            scores.visibility_accuracy = Some(accuracy);
            scores.visibility_majority = Some(majority);
        }
        let Some(truth) = &self.capture.truth else {
            return Ok(scores);
        };
        let pixels = (3 * truth_scores.shadow_pixels).max(1) as f64;
        truth_scores.shadow_error = shadow_sum / pixels;
        if self.config.ablation.shadow_decoder() {
            truth_scores.shadow_error_without_ao = Some(shadow_open_sum / pixels);
        }
        if pbr && !albedo_pairs.is_empty() {
            let gain = channel_gains(&albedo_pairs);
            let mse = albedo_pairs
                .iter()
                .map(|(x, y)| (0..3).map(|c| (gain[c] * x[c] - y[c]).powi(2)).sum::<f64>())
                .sum::<f64>()
                / (3 * albedo_pairs.len()) as f64;
            truth_scores.albedo_psnr = Some(-10.0 * mse.max(1e-20).log10());
        }
        let gain = self.probe_gain_against(truth, None);
        self.relit_scores(nets, truth, gain, &mut truth_scores)?;
        self.novel_pose_scores(nets, truth, &mut truth_scores)?;
        if pbr {
            self.probe_scores(truth, gain, &mut truth_scores);
        }
        scores.truth = Some(truth_scores);
        Ok(scores)
    }

    /// F_vis against fresh ray-cast labels of each frame's posed mesh: (accuracy, majority
    /// rate).
    fn visibility_scores(&self, frames: &[&IllumFrame]) -> (f64, f64) {
        let net = self.visibility.valid();
        let (mut right, mut open, mut total) = (0usize, 0usize, 0usize);
        for frame in frames {
            let pose = self.frame_pose(frame.frame, false);
            let labels = self.visibility_labels(&pose, 512, 0xE7A1 ^ frame.frame as u64);
            let count = labels.open.len();
            let flat =
                |v: &[[f64; 3]]| -> Vec<f32> { v.iter().flatten().map(|&x| x as f32).collect() };
            let points = Tensor::<2>::from_data(
                TensorData::new(flat(&labels.points), [count, 3]),
                &self.device,
            );
            let world = Tensor::<2>::from_data(
                TensorData::new(flat(&labels.directions), [count, 3]),
                &self.device,
            );
            let local = world.matmul(pose.root.clone()).reshape([count, 1, 3]);
            let predicted = host_f32(&net.forward(points, local, pose.pose_vector.clone()));
            for (p, &label) in predicted.iter().zip(&labels.open) {
                right += usize::from((*p > 0.5) == (label > 0.5));
                open += usize::from(label > 0.5);
            }
            total += count;
        }
        let total = total.max(1) as f64;
        let open = open as f64 / total;
        (right as f64 / total, open.max(1.0 - open))
    }

    fn relit_scores(
        &self,
        nets: Nets,
        truth: &CaptureTruth,
        gain: [f64; 3],
        scores: &mut TruthScores,
    ) -> Result<(), IllumError> {
        let lights = relighting(self.config.data.shadow_resolution);
        let mut all = (0.0, 0usize);
        for (name, lighting) in &lights {
            let relit = Self::relit_volume(truth, nets.volume, lighting, gain);
            let relit_nets = Nets {
                volume: &relit,
                ..nets
            };
            let frames: Vec<_> = truth
                .relit
                .iter()
                .filter(|r| r.light == *name)
                .step_by(self.config.eval_stride)
                .collect();
            let mut sum = (0.0, 0usize);
            for relit_frame in frames {
                let frame = &relit_frame.frame;
                let Some((rows, cols)) = person_box(frame) else {
                    continue;
                };
                let pose = self.frame_pose(frame.frame, true);
                let maps = self.render_view(relit_nets, &frame.camera, &pose, true)?;
                let crop = |t: Tensor<3>| t.slice([rows.clone(), cols.clone(), 0..3]);
                sum.0 += psnr(crop(maps.colour), crop(frame.image.clone().autodiff()));
                sum.1 += 1;
            }
            if sum.1 > 0 {
                scores
                    .relit
                    .push(((*name).to_owned(), sum.0 / sum.1 as f64));
                all.0 += sum.0;
                all.1 += sum.1;
            }
        }
        scores.relit_human_psnr = all.0 / all.1.max(1) as f64;
        Ok(())
    }

    fn novel_pose_scores(
        &self,
        nets: Nets,
        truth: &CaptureTruth,
        scores: &mut TruthScores,
    ) -> Result<(), IllumError> {
        let track = &truth.novel_person.motion;
        let mut sum = (0.0, 0usize);
        for frame in truth.novel_pose.iter().step_by(self.config.eval_stride) {
            let pose = self.pose_of(track, frame.frame, true);
            let maps = self.render_view(nets, &frame.camera, &pose, true)?;
            sum.0 += psnr(maps.colour, frame.image.clone().autodiff());
            sum.1 += 1;
        }
        scores.novel_pose_psnr = sum.0 / sum.1.max(1) as f64;
        Ok(())
    }
}
