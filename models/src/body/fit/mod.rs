//! An SMPLify-style body fit (Bogo et al. 2016, without its learned GMM pose prior): the shape
//! `β`, the axis-angle pose `θ` (root included) and the translation `t` of a body model from
//! 2-D keypoints seen by a calibrated pinhole camera, by minimising in Burn ops
//!
//! `Σ_k c_k ρ(‖π(X_k(β, θ, t)) − x_k‖²) / Σ_k c_k + λ_θ ‖θ_body‖² + λ_β ‖β‖² + λ_lim L_limit
//!  (+ λ_g (min_feet y − y_ground)²)`
//!
//! with `ρ(r²) = σ² r² / (σ² + r²)` (Geman–McClure, σ in pixels), `X_k` a joint or a surface
//! vertex of the posed body ([`KeypointTarget`]), `L_limit` the box limits of
//! [`super::priors`] (all 24 joints of SMPL-layout bodies; the 22 body joints of SMPL-H/X),
//! and an optional floor the feet rest on: one view fixes a body only up to a scale about the
//! camera (a taller body farther away), which the shape
//! prior settles near the mean body unless the floor is known. Stages, as SMPLify:
//! the root orientation and translation on the torso alone, from the depth the torso's pixel
//! length implies and from both facings (the better kept); then everything, with the pose
//! prior's weight annealed down. Adam runs on the host over the few parameters (85 for SMPL);
//! the body and its gradient are Burn's.
//!
//! The keypoints may be any of OpenPose's parts ([`PersonTargets`]: BODY_25, the hands, the
//! face), each point a joint or a surface landmark of the model being fitted.
//!
//! A video is fitted frame by frame ([`fit_sequence`]): the first frame in full, the others
//! from the previous frame's result with the shape held.

use super::lbs::{BodyTensors, PoseInput, pose};
use super::model::{BodyModel, BodyModelError};
use super::priors::{SMPL_ANGLE_LIMITS_DEG, angle_limit_loss};
use burn::tensor::{Device, Int, Tensor, TensorData};

mod camera;
mod keypoints;

pub use camera::PinholeCamera;
pub use keypoints::{
    Hand, KeypointTarget, Observation, PersonTargets, TORSO, body25_targets, face70_targets,
    foot_targets, hand21_targets, keypoint_observations,
};

/// The fit's knobs.
#[derive(Debug, Clone, PartialEq)]
pub struct FitConfig {
    /// Adam steps of the full stage (the orientation stage takes a fifth as many).
    pub iterations: usize,
    /// Adam's step size at the start of each stage, decaying to a tenth by its end.
    pub learning_rate: f64,
    /// σ of the Geman–McClure data term, pixels (SMPLify: 100).
    pub robust_sigma_px: f64,
    /// λ_θ at the start and end of the full stage (annealed geometrically), in px² per rad².
    pub pose_prior: [f64; 2],
    /// λ_β, px² per unit².
    pub shape_prior: f64,
    /// λ_lim, px² per rad².
    pub limit_weight: f64,
    /// λ_init, px² per rad²: `λ_init ‖θ − θ_init‖²` over the whole pose (root included) when
    /// the fit starts from `init` — a regressor's or tracker's estimate the keypoints refine
    /// (0: none, as SMPLify).
    pub init_pose_weight: f64,
    /// Fit the shape (false: hold `init`'s, or the mean body's).
    pub fit_shape: bool,
    /// A floor at this world height the lowest of `feet` rests on.
    pub ground: Option<f64>,
    pub feet: Vec<KeypointTarget>,
    /// λ_g, px² per m².
    pub ground_weight: f64,
    /// Keypoints below this confidence are ignored.
    pub min_confidence: f64,
}

impl Default for FitConfig {
    fn default() -> Self {
        Self {
            iterations: 400,
            learning_rate: 0.02,
            robust_sigma_px: 100.0,
            pose_prior: [100.0, 1.0],
            shape_prior: 20.0,
            limit_weight: 1000.0,
            init_pose_weight: 0.0,
            fit_shape: true,
            ground: None,
            feet: Vec::new(),
            ground_weight: 1e5,
            min_confidence: 0.05,
        }
    }
}

/// A fitted body.
#[derive(Debug, Clone, PartialEq)]
pub struct BodyFit {
    pub betas: Vec<f64>,
    /// `[3 J]` axis-angle, joint 0 the root.
    pub pose: Vec<f64>,
    pub translation: [f64; 3],
    /// Root-mean-square reprojection error over the used keypoints, pixels.
    pub reprojection_rms_px: f64,
}

fn input_error(problem: impl Into<String>) -> BodyModelError {
    BodyModelError::File {
        file: "body fit".into(),
        problem: problem.into(),
    }
}

/// Parameters flattened as `[pose (3J) | betas (S) | translation (3)]`.
struct Layout {
    joints: usize,
    shapes: usize,
}

impl Layout {
    fn len(&self) -> usize {
        3 * self.joints + self.shapes + 3
    }
    fn pose(&self) -> std::ops::Range<usize> {
        0..3 * self.joints
    }
    fn betas(&self) -> std::ops::Range<usize> {
        3 * self.joints..3 * self.joints + self.shapes
    }
    fn translation(&self) -> std::ops::Range<usize> {
        let s = 3 * self.joints + self.shapes;
        s..s + 3
    }
}

/// The differentiable objective over one parameter vector.
struct Objective<'a> {
    body: BodyTensors,
    layout: Layout,
    camera: &'a PinholeCamera,
    observations: Vec<Observation>,
    config: &'a FitConfig,
    device: Device,
    /// Joints the angle limits hold (the first this many of SMPL's table; 0: none).
    limited_joints: usize,
    /// `[1, 3J]` the starting pose `λ_init` pulls towards, where the fit has one.
    init_pose: Option<Tensor<2>>,
}

impl Objective<'_> {
    /// The targets' world points `[K, 3]` for parameters `[1, N]`.
    fn points(&self, params: &Tensor<2>, targets: &[KeypointTarget]) -> Tensor<2> {
        let l = &self.layout;
        let pose_t = params.clone().slice([0..1, l.pose()]);
        let betas = params.clone().slice([0..1, l.betas()]);
        let translation = params.clone().slice([0..1, l.translation()]);
        let posed = pose(
            &self.body,
            &PoseInput::from_axis_angle(betas, pose_t, translation),
        );
        let [_, j, _] = posed.joints.dims();
        let [_, v, _] = posed.vertices.dims();
        // One gather of three rows from `[joints ‖ vertices]` per target, blended by weights
        // (a joint or a vertex: its row once, weight 1).
        let (mut ids, mut blend) = (Vec::new(), Vec::new());
        for t in targets {
            let (rows, w) = match *t {
                KeypointTarget::Joint(k) => ([k; 3], [1.0, 0.0, 0.0]),
                KeypointTarget::Vertex(k) => ([j + k; 3], [1.0, 0.0, 0.0]),
                KeypointTarget::Surface { vertices, weights } => (vertices.map(|k| j + k), weights),
            };
            ids.extend(rows.map(|r| r as i64));
            blend.extend(w);
        }
        let n = targets.len();
        let ids = Tensor::<1, Int>::from_data(TensorData::new(ids, [3 * n]), &self.device);
        let blend = Tensor::<2>::from_data(TensorData::new(blend, [3 * n, 1]), &self.device);
        let rows = Tensor::cat(
            vec![posed.joints.reshape([j, 3]), posed.vertices.reshape([v, 3])],
            0,
        )
        .select(0, ids)
            * blend;
        rows.reshape([n, 3, 3]).sum_dim(1).reshape([n, 3])
    }

    /// The pixel coordinates `[K, 2]` of world points `[K, 3]`.
    fn project(&self, points: Tensor<2>) -> Tensor<2> {
        let [k, _] = points.dims();
        let m = &self.camera.world_to_camera;
        let rotation: Vec<f32> = (0..3)
            .flat_map(|c| (0..3).map(move |r| m[r][c] as f32))
            .collect();
        let rotation = Tensor::<2>::from_data(TensorData::new(rotation, [3, 3]), &self.device);
        let shift: Vec<f32> = (0..3).map(|r| m[r][3] as f32).collect();
        let shift = Tensor::<2>::from_data(TensorData::new(shift, [1, 3]), &self.device);
        let cam = points.matmul(rotation) + shift; // rows: R p + t
        let z = cam.clone().slice([0..k, 2..3]).clamp_min(1e-3);
        let focal = Tensor::<2>::from_data(
            TensorData::new(vec![self.camera.fx as f32, self.camera.fy as f32], [1, 2]),
            &self.device,
        );
        let centre = Tensor::<2>::from_data(
            TensorData::new(vec![self.camera.cx as f32, self.camera.cy as f32], [1, 2]),
            &self.device,
        );
        cam.slice([0..k, 0..2]) / z * focal + centre
    }

    /// The objective at `params` (`[1, N]`, autodiff) with pose-prior weight `lambda_pose`,
    /// using the observations `used` (indices).
    fn loss(&self, params: Tensor<2>, lambda_pose: f64, used: &[usize]) -> Tensor<1> {
        let targets: Vec<KeypointTarget> =
            used.iter().map(|&i| self.observations[i].target).collect();
        let pixels = self.project(self.points(&params, &targets));
        let k = used.len();
        let observed: Vec<f32> = used
            .iter()
            .flat_map(|&i| self.observations[i].pixel.map(|p| p as f32))
            .collect();
        let observed = Tensor::<2>::from_data(TensorData::new(observed, [k, 2]), &self.device);
        let weights: Vec<f32> = used
            .iter()
            .map(|&i| self.observations[i].confidence as f32)
            .collect();
        let total: f32 = weights.iter().sum();
        let weights = Tensor::<1>::from_data(TensorData::new(weights, [k]), &self.device);
        let r2 = (pixels - observed).powi_scalar(2).sum_dim(1).reshape([k]);
        let s2 = self.config.robust_sigma_px.powi(2);
        let robust = r2.clone().mul_scalar(s2) / r2.add_scalar(s2);
        let mut loss = (robust * weights).sum().div_scalar(total.max(1e-6));
        let l = &self.layout;
        let body_pose = params.clone().slice([0..1, 3..3 * l.joints]);
        loss = loss
            + body_pose
                .clone()
                .powi_scalar(2)
                .sum()
                .mul_scalar(lambda_pose);
        if self.config.fit_shape && l.shapes > 0 {
            let betas = params.clone().slice([0..1, l.betas()]);
            loss = loss
                + betas
                    .powi_scalar(2)
                    .sum()
                    .mul_scalar(self.config.shape_prior);
        }
        if let Some(init) = &self.init_pose {
            let full = params.clone().slice([0..1, l.pose()]);
            loss = loss
                + (full - init.clone())
                    .powi_scalar(2)
                    .sum()
                    .mul_scalar(self.config.init_pose_weight);
        }
        if self.limited_joints > 0 {
            let k = self.limited_joints;
            let start = l.pose().start;
            let limited = params.clone().slice([0..1, start..start + 3 * k]);
            loss = loss
                + angle_limit_loss(limited, &SMPL_ANGLE_LIMITS_DEG[..k])
                    .mul_scalar(self.config.limit_weight);
        }
        if let (Some(ground), false) = (self.config.ground, self.config.feet.is_empty()) {
            let feet = self.points(&params, &self.config.feet);
            let n = self.config.feet.len();
            let lowest = feet.slice([0..n, 1..2]).min();
            loss = loss
                + lowest
                    .sub_scalar(ground)
                    .powi_scalar(2)
                    .mul_scalar(self.config.ground_weight);
        }
        loss
    }
}

/// Host Adam over a parameter vector, with a mask of the entries that move.
struct Adam {
    m: Vec<f64>,
    v: Vec<f64>,
    step: i32,
}

impl Adam {
    fn new(n: usize) -> Self {
        Self {
            m: vec![0.0; n],
            v: vec![0.0; n],
            step: 0,
        }
    }

    fn update(&mut self, params: &mut [f64], grad: &[f32], rate: f64, free: &[bool]) {
        self.step += 1;
        let (b1, b2) = (0.9f64, 0.999f64);
        for i in 0..params.len() {
            if !free[i] {
                continue;
            }
            let g = f64::from(grad[i]);
            self.m[i] = b1 * self.m[i] + (1.0 - b1) * g;
            self.v[i] = b2 * self.v[i] + (1.0 - b2) * g * g;
            let mh = self.m[i] / (1.0 - b1.powi(self.step));
            let vh = self.v[i] / (1.0 - b2.powi(self.step));
            params[i] -= rate * mh / (vh.sqrt() + 1e-8);
        }
    }
}

fn host(t: &Tensor<2>) -> Vec<f32> {
    t.to_data()
        .convert::<f32>()
        .try_into_vec::<f32>()
        .expect("converted to f32")
}

impl Objective<'_> {
    /// `steps` Adam steps from `params` over the `free` entries; returns the final loss.
    fn descend(
        &self,
        params: &mut [f64],
        free: &[bool],
        steps: usize,
        lambda_pose: [f64; 2],
        used: &[usize],
    ) -> f64 {
        let ad = self.device.clone();
        let mut adam = Adam::new(params.len());
        let mut last = f64::INFINITY;
        for s in 0..steps {
            let f = s as f64 / steps.max(2).saturating_sub(1) as f64;
            let lambda = lambda_pose[0] * (lambda_pose[1] / lambda_pose[0]).powf(f);
            let values: Vec<f32> = params.iter().map(|&p| p as f32).collect();
            let n = values.len();
            let leaf = Tensor::<2>::from_data(TensorData::new(values, [1, n]), &ad).require_grad();
            let loss = self.loss(leaf.clone(), lambda, used);
            last = f64::from(host(&loss.clone().reshape([1, 1]))[0]);
            let grads = loss.backward();
            let Some(grad) = leaf.grad(&grads) else {
                break;
            };
            let grad = host(&grad);
            if grad.iter().any(|g| !g.is_finite()) {
                break;
            }
            // The step size decays geometrically to a tenth over the stage.
            let rate = self.config.learning_rate * 0.1f64.powf(f);
            adam.update(params, &grad, rate, free);
        }
        last
    }

    fn reprojection_rms(&self, params: &[f64], used: &[usize]) -> f64 {
        let values: Vec<f32> = params.iter().map(|&p| p as f32).collect();
        let n = values.len();
        let p = Tensor::<2>::from_data(TensorData::new(values, [1, n]), &self.device);
        let targets: Vec<KeypointTarget> =
            used.iter().map(|&i| self.observations[i].target).collect();
        let pixels = host(&self.project(self.points(&p, &targets)));
        let sum: f64 = used
            .iter()
            .enumerate()
            .map(|(k, &i)| {
                let o = self.observations[i].pixel;
                (f64::from(pixels[2 * k]) - o[0]).powi(2)
                    + (f64::from(pixels[2 * k + 1]) - o[1]).powi(2)
            })
            .sum();
        (sum / used.len().max(1) as f64).sqrt()
    }
}

/// Fits `model` to `observations` seen by `camera`, starting from `init` (a previous frame)
/// or from the torso's implied depth; `device` is a plain device (autodiff is added here).
/// `torso` names the keypoints of the orientation stage (observation targets; SMPLify uses
/// shoulders and hips).
pub fn fit_body(
    model: &BodyModel,
    observations: &[Observation],
    camera: &PinholeCamera,
    torso: &[KeypointTarget],
    config: &FitConfig,
    init: Option<&BodyFit>,
    device: &Device,
) -> Result<BodyFit, BodyModelError> {
    let (j, v, s) = (
        model.joint_count(),
        model.vertex_count(),
        model.shape_count(),
    );
    for o in observations {
        let fits = match o.target {
            KeypointTarget::Joint(k) => k < j,
            KeypointTarget::Vertex(k) => k < v,
            KeypointTarget::Surface { vertices, weights } => {
                vertices.iter().all(|&k| k < v) && weights.iter().all(|w| w.is_finite())
            }
        };
        if !fits {
            return Err(input_error(format!(
                "keypoint target {:?} is outside the body ({j} joints, {v} vertices)",
                o.target
            )));
        }
        if !(o.pixel.iter().all(|p| p.is_finite()) && o.confidence.is_finite()) {
            return Err(input_error(format!(
                "keypoint {:?} is not finite",
                o.target
            )));
        }
    }
    let used: Vec<usize> = (0..observations.len())
        .filter(|&i| observations[i].confidence >= config.min_confidence)
        .collect();
    if used.len() < 4 {
        return Err(input_error(format!(
            "{} confident keypoints (≥ {}); a fit needs at least 4",
            used.len(),
            config.min_confidence
        )));
    }
    let ad = device.clone().autodiff();
    let objective = Objective {
        body: BodyTensors::new(model, &ad),
        layout: Layout {
            joints: j,
            shapes: s,
        },
        camera,
        observations: observations.to_vec(),
        config,
        // SMPL's 24 joints, or the 22 body joints SMPL-H and SMPL-X share with it (their 23rd
        // on is a jaw, eyes or fingers, which the table does not cover).
        limited_joints: match j {
            24 => 24,
            j if j > 24 => 22,
            _ => 0,
        },
        init_pose: init.filter(|_| config.init_pose_weight > 0.0).map(|start| {
            let values: Vec<f32> = start.pose.iter().map(|&v| v as f32).collect();
            Tensor::<2>::from_data(TensorData::new(values, [1, 3 * j]), &ad)
        }),
        device: ad,
    };
    let l = &objective.layout;
    let mut params = vec![0.0f64; l.len()];
    let free_all: Vec<bool> = (0..l.len())
        .map(|i| config.fit_shape || !l.betas().contains(&i))
        .collect();
    let full_steps = config.iterations;
    if let Some(start) = init {
        params[l.pose()].copy_from_slice(&start.pose);
        params[l.betas()].copy_from_slice(&start.betas);
        params[l.translation()].copy_from_slice(&start.translation);
        objective.descend(
            &mut params,
            &free_all,
            full_steps,
            [config.pose_prior[1]; 2],
            &used,
        );
    } else {
        let torso_used: Vec<usize> = used
            .iter()
            .copied()
            .filter(|&i| torso.contains(&observations[i].target))
            .collect();
        let orient_used = if torso_used.len() >= 3 {
            torso_used
        } else {
            used.clone()
        };
        let free_root: Vec<bool> = (0..l.len())
            .map(|i| i < 3 || l.translation().contains(&i))
            .collect();
        let mut best: Option<(f64, Vec<f64>)> = None;
        for facing in initial_orientations(&objective, &orient_used, model)? {
            let mut candidate = facing;
            let loss = objective.descend(
                &mut candidate,
                &free_root,
                (full_steps / 5).max(10),
                [config.pose_prior[0]; 2],
                &orient_used,
            );
            if best.as_ref().is_none_or(|(b, _)| loss < *b) {
                best = Some((loss, candidate));
            }
        }
        params = best.expect("two facings were tried").1;
        // The pose first, on the mean shape; then the shape with it.
        let free_pose: Vec<bool> = (0..l.len()).map(|i| !l.betas().contains(&i)).collect();
        objective.descend(
            &mut params,
            &free_pose,
            full_steps / 2,
            config.pose_prior,
            &used,
        );
        objective.descend(
            &mut params,
            &free_all,
            full_steps,
            [config.pose_prior[1]; 2],
            &used,
        );
    }
    if params.iter().any(|p| !p.is_finite()) {
        return Err(input_error("the fit diverged (non-finite parameters)"));
    }
    Ok(BodyFit {
        reprojection_rms_px: objective.reprojection_rms(&params, &used),
        betas: params[l.betas()].to_vec(),
        pose: params[l.pose()].to_vec(),
        translation: [0, 1, 2].map(|k| params[l.translation().start + k]),
    })
}

/// Two starting parameter vectors, the body facing the camera and facing away, each at the
/// depth where its rest torso (neck to pelvis) spans the observed torso's pixels.
fn initial_orientations(
    objective: &Objective<'_>,
    used: &[usize],
    model: &BodyModel,
) -> Result<Vec<Vec<f64>>, BodyModelError> {
    let l = &objective.layout;
    let camera = objective.camera;
    let zero = vec![0.0f64; l.len()];
    let rest = {
        let values = vec![0.0f32; l.len()];
        let p = Tensor::<2>::from_data(TensorData::new(values, [1, l.len()]), &objective.device);
        host(&objective.points(
            &p,
            &[KeypointTarget::Joint(0), KeypointTarget::Joint(neck(model))],
        ))
    };
    let pelvis_rest = [rest[0], rest[1], rest[2]].map(f64::from);
    let neck_rest = [rest[3], rest[4], rest[5]].map(f64::from);
    let torso_length = (0..3)
        .map(|k| (neck_rest[k] - pelvis_rest[k]).powi(2))
        .sum::<f64>()
        .sqrt();
    let pixel = |target: KeypointTarget| {
        used.iter()
            .map(|&i| objective.observations[i])
            .find(|o| o.target == target)
            .map(|o| o.pixel)
    };
    let centroid = {
        let mut c = [0.0; 2];
        for &i in used {
            c[0] += objective.observations[i].pixel[0] / used.len() as f64;
            c[1] += objective.observations[i].pixel[1] / used.len() as f64;
        }
        c
    };
    let hip = pixel(KeypointTarget::Joint(0)).unwrap_or(centroid);
    let depth = match pixel(KeypointTarget::Joint(neck(model))) {
        Some(n) => {
            let span = ((n[0] - hip[0]).powi(2) + (n[1] - hip[1]).powi(2))
                .sqrt()
                .max(1.0);
            camera.fx.max(camera.fy) * torso_length / span
        }
        None => 3.0,
    };
    let pelvis = camera.unproject(hip, depth);
    let to_camera = {
        let c = camera.centre();
        let d = [c[0] - pelvis[0], c[2] - pelvis[2]];
        d[0].atan2(d[1]) // about +y, taking the body's +z towards the camera
    };
    let mut starts = Vec::new();
    for yaw in [to_camera, to_camera + std::f64::consts::PI] {
        let mut p = zero.clone();
        p[1] = yaw;
        // With only the root turned, the pelvis sits at R·J₀ + t.
        let r = crate::rotation_scalar::axis_angle_matrix([0.0, yaw, 0.0]);
        let turned: [f64; 3] =
            std::array::from_fn(|a| (0..3).map(|b| r[a][b] * pelvis_rest[b]).sum());
        for k in 0..3 {
            p[l.translation().start + k] = pelvis[k] - turned[k];
        }
        starts.push(p);
    }
    Ok(starts)
}

/// The neck joint of a body: SMPL's 12, else the joint named "neck".
fn neck(model: &BodyModel) -> usize {
    model
        .joint_names
        .iter()
        .position(|n| n.eq_ignore_ascii_case("neck"))
        .unwrap_or(12.min(model.joint_count() - 1))
}

/// Fits each frame of a video: the first in full, each next one from the previous result
/// with the first frame's shape held.
pub fn fit_sequence(
    model: &BodyModel,
    frames: &[Vec<Observation>],
    camera: &PinholeCamera,
    torso: &[KeypointTarget],
    config: &FitConfig,
    device: &Device,
) -> Result<Vec<BodyFit>, BodyModelError> {
    let mut fits: Vec<BodyFit> = Vec::with_capacity(frames.len());
    let held = FitConfig {
        fit_shape: false,
        iterations: (config.iterations / 4).max(20),
        ..config.clone()
    };
    for (t, observations) in frames.iter().enumerate() {
        let fit = match fits.last() {
            None => fit_body(model, observations, camera, torso, config, None, device),
            Some(previous) => fit_body(
                model,
                observations,
                camera,
                torso,
                &held,
                Some(previous),
                device,
            ),
        }
        .map_err(|e| input_error(format!("frame {t}: {e}")))?;
        fits.push(fit);
    }
    Ok(fits)
}
