//! The stand-ins for what the paper's off-the-shelf tools give (spec §2's table), made from
//! the renderer's ground truth: a segmenter's masks (jittered boundaries), SfM cameras (turned
//! and moved), a tracker's camera-space body fit, Sapiens-like normal maps (rotated, blurred),
//! floor masks; and the scene's change of units.

use burn::tensor::{Device, Tensor, TensorData};
use glam::{DMat3, DQuat, DVec3};
use splatzoo_datasets::masks::Mask;
use splatzoo_datasets::pose_sequence::PoseSequence;
use splatzoo_datasets::synth::ViewTruth;
use splatzoo_datasets::synth::rng::Rng;
use splatzoo_models::body::BodyModel;
use splatzoo_rasterizer::Camera;

/// `[H, W]` 0/1 of a mask.
pub fn mask_tensor(mask: &Mask, device: &Device) -> Tensor<2> {
    let values: Vec<f32> = mask.data.iter().map(|&m| f32::from(u8::from(m))).collect();
    Tensor::from_data(TensorData::new(values, [mask.height, mask.width]), device)
}

/// A mask grown or shrunk by up to `jitter` pixels (a segmenter's boundary error).
pub fn jittered(mask: Mask, jitter: usize, rng: &mut Rng) -> Mask {
    let r = (rng.range(0.0, jitter as f64 + 1.0) as usize).min(jitter);
    if r == 0 {
        mask
    } else if rng.range(0.0, 1.0) < 0.5 {
        mask.dilate(r)
    } else {
        mask.erode(r)
    }
}

/// `camera` with its world scaled by `scale` (centre and translation; rotation unchanged).
pub fn scaled_camera(camera: &Camera, scale: f64) -> Camera {
    let mut scaled = *camera;
    for row in &mut scaled.world_to_camera {
        row[3] = (f64::from(row[3]) * scale) as f32;
    }
    scaled
}

fn rotation_of(camera: &Camera) -> DMat3 {
    let m = camera.world_to_camera;
    DMat3::from_cols_array_2d(&[0, 1, 2].map(|j| [0, 1, 2].map(|i| f64::from(m[i][j]))))
}

/// A random unit vector.
fn direction(rng: &mut Rng) -> DVec3 {
    loop {
        let v = DVec3::new(rng.normal(), rng.normal(), rng.normal());
        if v.length() > 1e-6 {
            return v.normalize();
        }
    }
}

/// `camera` after an SfM error: its orientation turned by `degrees` about a random axis, its
/// centre moved by `distance` in a random direction.
pub fn perturbed(camera: &Camera, degrees: f64, distance: f64, rng: &mut Rng) -> Camera {
    let world_to_camera = rotation_of(camera);
    let centre = DVec3::from(camera.position().map(f64::from));
    let turn = DMat3::from_quat(DQuat::from_axis_angle(direction(rng), degrees.to_radians()));
    // Camera-to-world R' = turn · Rᵀ_cw; world-to-camera is its transpose.
    let camera_to_world = turn * world_to_camera.transpose();
    let centre = centre + direction(rng) * distance;
    let rotation = camera_to_world.transpose();
    let t = -(rotation * centre);
    let mut out = *camera;
    for i in 0..3 {
        for j in 0..3 {
            out.world_to_camera[i][j] = rotation.col(j)[i] as f32;
        }
        out.world_to_camera[i][3] = t[i] as f32;
    }
    out
}

/// The pelvis joint at rest for shape `betas`: `J₀ = Σ_v R₀ᵥ (T_v + Σ_s S_vs β_s)`.
pub fn rest_pelvis(model: &BodyModel, betas: &[f64]) -> DVec3 {
    let v = model.vertex_count();
    let s = model.shape_count();
    let mut j0 = DVec3::ZERO;
    for k in 0..v {
        let w = f64::from(model.joint_regressor[k]);
        if w == 0.0 {
            continue;
        }
        let mut p = [0.0; 3];
        for (c, value) in p.iter_mut().enumerate() {
            *value = f64::from(model.template[3 * k + c])
                + (0..s.min(betas.len()))
                    .map(|b| f64::from(model.shape_dirs[(3 * k + c) * s + b]) * betas[b])
                    .sum::<f64>();
        }
        j0 += w * DVec3::from(p);
    }
    j0
}

/// A world-space body track expressed in each frame's camera frame: the root rotation becomes
/// `R_cw R_root` and the translation `R_cw (J₀ + t) + t_cw − J₀` so the posed body lands where
/// it was (SMPL rotates the root about the rest pelvis `J₀`).
pub fn to_camera_space(
    track: &PoseSequence,
    cameras: &[Camera],
    model: &BodyModel,
) -> PoseSequence {
    let mut out = track.clone();
    for (f, camera) in cameras.iter().enumerate().take(track.frames()) {
        let rcw = rotation_of(camera);
        let tcw = DVec3::from(camera.world_to_camera.map(|r| f64::from(r[3])));
        let j0 = rest_pelvis(model, track.frame_betas(f));
        let pose = track.pose(f);
        let root = DVec3::new(pose[0], pose[1], pose[2]);
        let root = if root.length() > 0.0 {
            DMat3::from_axis_angle(root.normalize(), root.length())
        } else {
            DMat3::IDENTITY
        };
        let (axis, angle) = DQuat::from_mat3(&(rcw * root)).to_axis_angle();
        let t = DVec3::from(track.translation(f));
        let translation = rcw * (j0 + t) + tcw - j0;
        let j = track.joints;
        out.poses[f * 3 * j..f * 3 * j + 3].copy_from_slice(&(axis * angle).to_array());
        out.translations[3 * f..3 * f + 3].copy_from_slice(&translation.to_array());
    }
    out
}

/// The given normal map of an acting view: true camera-frame normals on the person, turned by
/// one random rotation (`degrees` RMS) and box-blurred over the person's 3×3 neighbourhoods.
pub fn noisy_normals(view: &ViewTruth, mask: &[bool], degrees: f64, rng: &mut Rng) -> Vec<f32> {
    let (w, h) = (view.render.width, view.render.height);
    let rcw = rotation_of(&view.camera);
    let turn = DMat3::from_quat(DQuat::from_axis_angle(
        direction(rng),
        (degrees * rng.normal()).to_radians(),
    ));
    let camera_frame: Vec<DVec3> = view
        .render
        .normal
        .iter()
        .zip(mask)
        .map(|(n, &m)| {
            if m {
                turn * (rcw * DVec3::from(n.map(f64::from)))
            } else {
                DVec3::ZERO
            }
        })
        .collect();
    let mut out = vec![0.0f32; w * h * 3];
    for y in 0..h {
        for x in 0..w {
            let p = y * w + x;
            if !mask[p] {
                continue;
            }
            let mut sum = DVec3::ZERO;
            for (dx, dy) in (-1i64..=1).flat_map(|dy| (-1i64..=1).map(move |dx| (dx, dy))) {
                let (xx, yy) = (x as i64 + dx, y as i64 + dy);
                if xx >= 0 && yy >= 0 && (xx as usize) < w && (yy as usize) < h {
                    let q = yy as usize * w + xx as usize;
                    if mask[q] {
                        sum += camera_frame[q];
                    }
                }
            }
            let n = sum.normalize_or_zero();
            out[3 * p..3 * p + 3].copy_from_slice(&n.as_vec3().to_array());
        }
    }
    out
}

/// True camera-frame normals on the person, zero elsewhere.
pub fn true_normals(view: &ViewTruth, mask: &Mask) -> Vec<[f32; 3]> {
    let rcw = rotation_of(&view.camera);
    view.render
        .normal
        .iter()
        .zip(&mask.data)
        .map(|(n, &m)| {
            if m {
                (rcw * DVec3::from(n.map(f64::from))).as_vec3().to_array()
            } else {
                [0.0; 3]
            }
        })
        .collect()
}

/// Floor pixels: surroundings whose back-projected point is within 1 cm of y = 0.
pub fn floor_mask(view: &ViewTruth) -> Mask {
    let (w, h) = (view.render.width, view.render.height);
    let c = view.camera;
    let rcw = rotation_of(&c);
    let t = DVec3::from(c.world_to_camera.map(|r| f64::from(r[3])));
    let data = (0..w * h)
        .map(|p| {
            let d = f64::from(view.render.depth[p]);
            if !d.is_finite() || view.render.label[p] == 0 {
                return false;
            }
            let (x, y) = ((p % w) as f64 + 0.5, (p / w) as f64 + 0.5);
            let cam = DVec3::new(
                d * (x - f64::from(c.cx)) / f64::from(c.fx),
                d * (y - f64::from(c.cy)) / f64::from(c.fy),
                d,
            );
            let world = rcw.transpose() * (cam - t);
            world.y.abs() < 0.01
        })
        .collect();
    Mask::new(w, h, data)
}
