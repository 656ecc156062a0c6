//! Posing a body model with a pose sequence, for inspection: posed vertices per frame (through
//! the differentiable LBS of `splatzoo-models`, batched), and a contact-sheet preview rendered
//! with the mesh renderer, coloured by skinning weights so a broken rig shows at a glance.

use crate::image_io::hsv;
use crate::pose_sequence::PoseSequence;
use crate::render::{Albedo, Lighting, MeshInstance, RenderSettings, render};
use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_models::body::BodyModel;
use splatzoo_models::body::lbs::{self, BodyTensors, PoseInput};
use splatzoo_rasterizer::Camera;

/// Frames posed per LBS call.
const BATCH: usize = 32;

/// One posed frame: what rendering a body and its rigidly attached accessories needs.
#[derive(Debug, Clone, PartialEq)]
pub struct PosedFrame {
    /// World-space vertices.
    pub vertices: Vec<[f32; 3]>,
    /// World-space joint positions.
    pub joints: Vec<[f32; 3]>,
    /// World-space joint orientations (row-major 3×3).
    pub joint_rotations: Vec<[[f32; 3]; 3]>,
}

/// World-space vertices of every frame of `seq` (already fitted to `model` with
/// [`PoseSequence::for_model`]).
pub fn pose_frames(model: &BodyModel, seq: &PoseSequence, device: &Device) -> Vec<Vec<[f32; 3]>> {
    pose_frames_with_joints(model, seq, device)
        .into_iter()
        .map(|f| f.vertices)
        .collect()
}

fn floats<const D: usize>(t: Tensor<D>) -> Vec<f32> {
    t.into_data()
        .convert::<f32>()
        .try_into_vec::<f32>()
        .expect("f32 tensor")
}

/// Vertices, joints and joint orientations of every frame of `seq` (fitted to `model`).
pub fn pose_frames_with_joints(
    model: &BodyModel,
    seq: &PoseSequence,
    device: &Device,
) -> Vec<PosedFrame> {
    assert_eq!(
        seq.joints,
        model.joint_count(),
        "fit the sequence to the model first"
    );
    let tensors = BodyTensors::new(model, device);
    let v = model.vertex_count();
    let j = model.joint_count();
    let mut out = Vec::with_capacity(seq.frames());
    for start in (0..seq.frames()).step_by(BATCH) {
        let end = (start + BATCH).min(seq.frames());
        let b = end - start;
        let j3 = 3 * seq.joints;
        let s = seq.shape_count.max(1);
        let mut betas = vec![0.0f32; b * s];
        for f in 0..b {
            for k in 0..seq.shape_count {
                betas[f * s + k] = seq.frame_betas(start + f)[k] as f32;
            }
        }
        let pose: Vec<f32> = seq.poses[start * j3..end * j3]
            .iter()
            .map(|&x| x as f32)
            .collect();
        let trans: Vec<f32> = seq.translations[start * 3..end * 3]
            .iter()
            .map(|&x| x as f32)
            .collect();
        let betas = if seq.shape_count == 0 || model.shape_count() == 0 {
            Tensor::<2>::zeros([b, 0], device)
        } else {
            Tensor::<2>::from_data(TensorData::new(betas, [b, s]), device)
        };
        let input = PoseInput::from_axis_angle(
            betas,
            Tensor::<2>::from_data(TensorData::new(pose, [b, j3]), device),
            Tensor::<2>::from_data(TensorData::new(trans, [b, 3]), device),
        );
        let posed = lbs::pose(&tensors, &input);
        let vertices = floats(posed.vertices);
        let joints = floats(posed.joints);
        let rotations = floats(posed.joint_rotations);
        let triples = |x: &[f32]| x.chunks(3).map(|p| [p[0], p[1], p[2]]).collect::<Vec<_>>();
        for f in 0..b {
            out.push(PosedFrame {
                vertices: triples(&vertices[f * v * 3..(f + 1) * v * 3]),
                joints: triples(&joints[f * j * 3..(f + 1) * j * 3]),
                joint_rotations: rotations[f * j * 9..(f + 1) * j * 9]
                    .chunks(9)
                    .map(|m| [[m[0], m[1], m[2]], [m[3], m[4], m[5]], [m[6], m[7], m[8]]])
                    .collect(),
            });
        }
    }
    out
}

/// A colour per joint, spread around the hue circle by the golden ratio.
fn joint_colour(j: usize) -> [f32; 3] {
    hsv(j as f64 * 0.618_034, 0.82, 0.85)
}

/// Per-vertex colours blending each joint's colour by the skinning weights.
pub fn weight_colours(model: &BodyModel) -> Vec<[f32; 3]> {
    let j = model.joint_count();
    model
        .skin_weights
        .chunks(j)
        .map(|w| {
            let mut c = [0.0f32; 3];
            for (k, &wk) in w.iter().enumerate() {
                let jc = joint_colour(k);
                for i in 0..3 {
                    c[i] += wk * jc[i];
                }
            }
            c
        })
        .collect()
}

/// A `[rows × cols]` sheet of `cell`-pixel renders: the chosen frames left to right, seen from
/// the front (+z) in the first row and from the body's left (+x) in the second. Returns
/// (width, height, linear RGB pixels).
pub fn contact_sheet(
    frames: &[&[[f32; 3]]],
    faces: &[[u32; 3]],
    colours: &[[f32; 3]],
    cell: usize,
) -> (usize, usize, Vec<[f32; 3]>) {
    let cols = frames.len().max(1);
    let (width, height) = (cols * cell, 2 * cell);
    let mut sheet = vec![[1.0f32; 3]; width * height];
    let lighting = Lighting::default();
    let settings = RenderSettings {
        background: [1.0; 3],
        supersample: 2,
    };
    for (c, vertices) in frames.iter().enumerate() {
        let mut lo = [f32::INFINITY; 3];
        let mut hi = [f32::NEG_INFINITY; 3];
        for p in vertices.iter() {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let centre = [
            0.5 * (lo[0] + hi[0]),
            0.5 * (lo[1] + hi[1]),
            0.5 * (lo[2] + hi[2]),
        ];
        // Fit the box: the larger of its side extents must fill ~85% of the field of view.
        let fov = 40.0f32;
        let half = 0.5
            * (hi[0] - lo[0])
                .max(hi[1] - lo[1])
                .max(hi[2] - lo[2])
                .max(1e-3);
        let distance = half / (0.5 * fov.to_radians()).tan() / 0.85 + half;
        for (r, dir) in [[0.0, 0.0, 1.0f32], [1.0, 0.0, 0.0]].iter().enumerate() {
            let eye = [
                centre[0] + dir[0] * distance,
                centre[1] + dir[1] * distance,
                centre[2] + dir[2] * distance,
            ];
            let camera =
                Camera::look_at(eye, centre, [0.0, 1.0, 0.0], fov, cell as u32, cell as u32);
            let mesh = MeshInstance {
                positions: vertices,
                faces,
                albedo: Albedo::PerVertex(colours),
                label: 1,
                smooth: true,
            };
            let image = render(&[mesh], &camera, &lighting, &settings);
            for y in 0..cell {
                for x in 0..cell {
                    sheet[(r * cell + y) * width + c * cell + x] = image.color[y * cell + x];
                }
            }
        }
    }
    (width, height, sheet)
}
