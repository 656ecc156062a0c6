//! Stage A, the scene prior (§3.1 of Prior-4D): 3DGS on the scene-scan video alone, with the
//! monocular-depth term the paper borrows from "Kerbl et al. 2024" read as the INRIA
//! repository's depth option (spec §3): an L1 between the rendered inverse depth and the
//! monocular inverse depth mapped by a per-image affine `a D⁻¹ + b` (fitted by least squares to
//! sparse points — on the synthetic scan, 200 pixels of the true depth), its weight decaying
//! exponentially from `depth_start` to `depth_end`. Density control is the engine's ADC.

use crate::config::SceneStageConfig;
use crate::data::Prior4dCapture;
use crate::error::Prior4dError;
use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_datasets::synth::rng::Rng;
use splatzoo_rasterizer::{Camera, ColorMode, RasterSettings, Render, rasterize};
use splatzoo_train::gaussians::GaussianSet;
use splatzoo_train::harness::{EpochOrder, read_back};
use splatzoo_train::loss::{photometric, psnr, scalar, ssim};
use splatzoo_train::ply::read_ply;
use splatzoo_train::scene::{FrameContext, FrameQuery, GaussianNode, SceneNode, StepEnd};

/// The scene node's checkpoint prefix.
pub const SCENE: &str = "scene";

/// `a`, `b` minimising `Σ (a m + b − y)²` over pairs `(m, y)`; `(1, 0)` when degenerate.
pub fn fit_affine(pairs: &[(f64, f64)]) -> (f64, f64) {
    let n = pairs.len() as f64;
    if pairs.len() < 2 {
        return (1.0, 0.0);
    }
    let (sm, sy) = pairs
        .iter()
        .fold((0.0, 0.0), |(a, b), (m, y)| (a + m, b + y));
    let (mm, my) = (sm / n, sy / n);
    let (cov, var) = pairs.iter().fold((0.0, 0.0), |(c, v), (m, y)| {
        (c + (m - mm) * (y - my), v + (m - mm) * (m - mm))
    });
    if var <= 1e-12 {
        return (1.0, 0.0);
    }
    let a = cov / var;
    (a, my - a * mm)
}

/// 3DGS's scene extent: 1.1 × the largest distance of a camera from the cameras' centroid.
pub fn camera_extent(cameras: &[Camera]) -> f64 {
    let centres: Vec<[f64; 3]> = cameras
        .iter()
        .map(|c| c.position().map(f64::from))
        .collect();
    let n = centres.len().max(1) as f64;
    let mean = [0, 1, 2].map(|k| centres.iter().map(|c| c[k]).sum::<f64>() / n);
    1.1 * centres
        .iter()
        .map(|c| (0..3).map(|k| (c[k] - mean[k]).powi(2)).sum::<f64>().sqrt())
        .fold(0.0, f64::max)
}

/// `render` with the pixels of `person` (`[H, W]`, 0/1) taken from `image`: no loss and no
/// gradient there (the person in views from the acting video, [`crate::sources`]).
pub fn without_person(render: Tensor<3>, image: Tensor<3>, person: Tensor<2>) -> Tensor<3> {
    let [h, w] = person.dims();
    let m = person.reshape([h, w, 1]);
    render * m.clone().neg().add_scalar(1.0) + image * m
}

/// One scan view's depth target: the mapped monocular inverse depth `[H, W]` and where it is
/// valid (0/1).
struct DepthTarget {
    inverse_depth: Tensor<2>,
    valid: Tensor<2>,
}

pub struct SceneStage {
    pub node: GaussianNode,
    pub order: EpochOrder,
    /// Scan views trained on and held out.
    pub train: Vec<usize>,
    pub test: Vec<usize>,
    pub extent: f64,
    targets: Vec<DepthTarget>,
    background: Tensor<1>,
}

impl SceneStage {
    /// Gaussians from the scan's points; each view's affine map fitted to 200 true-depth pixels.
    pub fn new(
        capture: &Prior4dCapture,
        config: &SceneStageConfig,
        seed: u64,
        device: &Device,
    ) -> Result<Self, Prior4dError> {
        let set = match &config.initial_ply {
            Some(path) => {
                let what = format!("scene.initial_ply {}", path.display());
                let set = read_ply(path, device)
                    .map_err(|e| Prior4dError::input(what.clone(), e.to_string()))?;
                if set.is_empty() {
                    return Err(Prior4dError::input(what, "no Gaussians"));
                }
                set
            }
            None => {
                let p = &capture.scene_points;
                if p.is_empty() {
                    return Err(Prior4dError::input(
                        "scene scan",
                        "no points to start the scene prior from",
                    ));
                }
                GaussianSet::from_points(&p.positions, &p.colours, &p.sigmas, device)
            }
        };
        let cameras: Vec<Camera> = capture.scene_scan.iter().map(|v| v.camera).collect();
        let extent = camera_extent(&cameras);
        let node = GaussianNode::new(
            SCENE,
            set,
            config.rates,
            &config.densify,
            extent,
            seed ^ 0x5CE0_0001,
        );
        let (test, train): (Vec<usize>, Vec<usize>) = (0..capture.scene_scan.len())
            .partition(|k| k % config.holdout_every == config.holdout_every - 1);
        let mut rng = Rng(seed ^ 0x5CE0_0002);
        let targets = capture
            .scene_scan
            .iter()
            .map(|view| {
                let mono: Vec<f32> = splatzoo_train::host_f32(&view.mono_inverse_depth);
                let valid: Vec<usize> = (0..mono.len())
                    .filter(|&i| mono[i] > 0.0 && view.depth[i].is_finite() && view.depth[i] > 0.0)
                    .collect();
                let pairs: Vec<(f64, f64)> = (0..200.min(valid.len()))
                    .map(|_| {
                        let i = valid
                            [(rng.range(0.0, valid.len() as f64) as usize).min(valid.len() - 1)];
                        (f64::from(mono[i]), 1.0 / f64::from(view.depth[i]))
                    })
                    .collect();
                let (a, b) = fit_affine(&pairs);
                let [h, w] = view.mono_inverse_depth.dims();
                let mapped: Vec<f32> = mono
                    .iter()
                    .map(|&m| {
                        if m > 0.0 {
                            (a * f64::from(m) + b) as f32
                        } else {
                            0.0
                        }
                    })
                    .collect();
                let mask: Vec<f32> = mono.iter().map(|&m| f32::from(u8::from(m > 0.0))).collect();
                DepthTarget {
                    inverse_depth: Tensor::from_data(TensorData::new(mapped, [h, w]), device),
                    valid: Tensor::from_data(TensorData::new(mask, [h, w]), device),
                }
            })
            .collect();
        let background = Tensor::<1>::from_floats(capture.scene_background.as_slice(), device);
        Ok(Self {
            node,
            order: EpochOrder::new(seed ^ 0x5CE0_0003),
            train,
            test,
            extent,
            targets,
            background,
        })
    }

    /// The SH degree trained at stage step `step`: rising from 0 on points, all of it from
    /// the start on a `.ply` (`initial_ply`), which carries every coefficient.
    pub fn sh_degree(config: &SceneStageConfig, step: usize) -> u32 {
        if config.initial_ply.is_some() {
            return config.sh_degree;
        }
        ((step / config.sh_degree_every.max(1)) as u32).min(config.sh_degree)
    }

    fn render(&self, camera: Camera, degree: u32, in_step: bool) -> Result<Render, Prior4dError> {
        let query = FrameQuery {
            camera: &camera,
            frame: 0,
            time: 0.0,
        };
        let splats = self
            .node
            .render(&query, &FrameContext { outputs: &[] })
            .splats;
        let background = if in_step {
            self.background.clone().autodiff()
        } else {
            self.background.clone()
        };
        let settings = RasterSettings::new(camera, ColorMode::Sh { degree });
        rasterize(&splats, background, &settings).map_err(|e| Prior4dError::Train(e.into()))
    }

    /// One optimiser step at stage step `step` of `config.steps`; returns the photometric loss.
    pub fn step(
        &mut self,
        capture: &Prior4dCapture,
        config: &SceneStageConfig,
        step: usize,
    ) -> Result<f64, Prior4dError> {
        let k = self.train[self.order.next(self.train.len())];
        let view = &capture.scene_scan[k];
        self.node.begin_step();
        let render = self.render(view.camera, Self::sh_degree(config, step), true)?;
        let image = view.image.clone().autodiff();
        let color = match &view.person {
            Some(person) => without_person(
                render.color.clone(),
                image.clone(),
                person.clone().autodiff(),
            ),
            None => render.color.clone(),
        };
        let photo = photometric(color, image, 0.2);
        let progress = step as f64 / config.steps.max(1) as f64;
        let weight = config.depth_start * (config.depth_end / config.depth_start).powf(progress);
        let mut loss = photo.clone();
        if weight > 0.0 {
            let target = &self.targets[k];
            let covered = render.alpha.clone().detach().greater_elem(0.5).float();
            let mask = covered * target.valid.clone().autodiff();
            let inverse = render.depth.clone().clamp_min(1e-3).recip();
            let l1 = ((inverse - target.inverse_depth.clone().autodiff()).abs() * mask.clone())
                .sum()
                / mask.sum().clamp_min(1.0);
            loss = loss + l1 * weight;
        }
        if let Some(r) = self.node.regulariser() {
            loss = loss + r;
        }
        let grads = loss.backward();
        let rows = 0..self.node.gaussians();
        self.node.end_step(&StepEnd {
            grads: &grads,
            renders: vec![(&render, rows)],
            step,
            progress,
        });
        Ok(scalar(photo.inner()))
    }

    /// Renders the held-out scan views (read back, unscored); returns how many.
    pub fn render_held_out(
        &self,
        capture: &Prior4dCapture,
        degree: u32,
    ) -> Result<usize, Prior4dError> {
        for &k in &self.test {
            read_back(
                &self
                    .render(capture.scene_scan[k].camera, degree, false)?
                    .color,
            );
        }
        Ok(self.test.len())
    }

    /// PSNR and SSIM over the held-out views at SH `degree` (a masked person's pixels taken
    /// from the image).
    pub fn evaluate(
        &self,
        capture: &Prior4dCapture,
        degree: u32,
    ) -> Result<(f64, f64), Prior4dError> {
        let mut sum = (0.0, 0.0);
        for &k in &self.test {
            let view = &capture.scene_scan[k];
            let mut image = self
                .render(view.camera, degree, false)?
                .color
                .clamp(0.0, 1.0);
            if let Some(person) = &view.person {
                image = without_person(image, view.image.clone(), person.clone());
            }
            sum.0 += psnr(image.clone(), view.image.clone());
            sum.1 += scalar(ssim(image, view.image.clone()));
        }
        let n = self.test.len().max(1) as f64;
        Ok((sum.0 / n, sum.1 / n))
    }
}
