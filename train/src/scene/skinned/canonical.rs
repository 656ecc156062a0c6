//! The canonical avatar: Gaussians placed on the body surface in a chosen canonical pose, with
//! per-Gaussian skinning weights and the body's joint regressor carried onto them. Every row
//! keeps its anchor (face and barycentric weights) so weights and regressor can be recomputed
//! when density control copies rows.

use crate::gaussians::GaussianSet;
use burn::tensor::{Device, Tensor, TensorData};
use serde::{Deserialize, Serialize};
use splatzoo_models::anchor::MeshAnchors;
use splatzoo_models::body::BodyModel;
use std::f64::consts::PI;

/// Where the canonical Gaussians start on the body surface.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Placement {
    /// One per template vertex (GauHuman, 3DGS-Avatar).
    Vertices,
    /// `per_face` at fixed barycentric points of every face (NLF-GS's anchors).
    PerFace,
    /// `surface_samples` area-uniform random points (AAGaussian, GART).
    Surface,
}

/// The pose the canonical Gaussians are defined in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CanonicalPose {
    /// The model's rest pose (arms out).
    TPose,
    /// Arms lowered 45° at the shoulders.
    APose,
    /// Legs spread 30° at the hips, against inner-thigh artefacts (InstantAvatar's and
    /// drivestudio's "Da-pose").
    DaPose,
}

/// How each Gaussian's skinning weights come from the mesh.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SkinningSource {
    /// The anchor face's vertex weights blended by the barycentric weights.
    Barycentric,
    /// The weights of the anchor face's vertex nearest the Gaussian (largest barycentric).
    NearestVertex,
}

impl CanonicalPose {
    /// The pose as SMPL-layout axis-angles `[3 J]` (the first 22 joints share SMPL's order in
    /// SMPL, SMPL-H, SMPL-X and the built-in body).
    pub fn axis_angles(self, joints: usize) -> Vec<f64> {
        let mut pose = vec![0.0; 3 * joints];
        let mut set = |joint: usize, axis: usize, angle: f64| {
            if joint < joints {
                pose[3 * joint + axis] = angle;
            }
        };
        match self {
            CanonicalPose::TPose => {}
            CanonicalPose::APose => {
                // Left shoulder (16) lies along +x, right (17) along −x; about +z, a negative
                // angle lowers the left arm and a positive one the right.
                set(16, 2, -PI / 4.0);
                set(17, 2, PI / 4.0);
            }
            CanonicalPose::DaPose => {
                set(1, 2, PI / 6.0);
                set(2, 2, -PI / 6.0);
            }
        }
        pose
    }
}

/// Per-row skinning weights `[G, J]` (row-major) from the anchors.
pub fn skinning_weights(
    model: &BodyModel,
    anchors: &MeshAnchors,
    source: SkinningSource,
) -> Vec<f32> {
    let j = model.joint_count();
    let mut out = vec![0.0f32; anchors.len() * j];
    for (g, (&face, bary)) in anchors
        .face_from_gaussian
        .iter()
        .zip(&anchors.barycentric)
        .enumerate()
    {
        let corners = &model.faces[3 * face as usize..3 * face as usize + 3];
        let row = &mut out[g * j..(g + 1) * j];
        let nearest = (0..3)
            .max_by(|&a, &b| bary[a].total_cmp(&bary[b]))
            .expect("three corners");
        for (c, &v) in corners.iter().enumerate() {
            let share = match source {
                SkinningSource::Barycentric => bary[c],
                SkinningSource::NearestVertex => f32::from(c == nearest),
            };
            let weights = &model.skin_weights[v as usize * j..(v as usize + 1) * j];
            for (o, &w) in row.iter_mut().zip(weights) {
                *o += share * w;
            }
        }
        let total: f32 = row.iter().sum();
        if total > 0.0 {
            row.iter_mut().for_each(|w| *w /= total);
        }
    }
    out
}

/// The body's joint regressor carried onto the Gaussians, `[J, G]` (row-major): each vertex's
/// regressor weight is shared among the Gaussians anchored near it in proportion to their
/// barycentric weight on it, and each joint's row is renormalised to sum to 1. Joints then
/// come from deformed Gaussians as they come from posed vertices.
pub fn joint_regressor(model: &BodyModel, anchors: &MeshAnchors) -> Vec<f32> {
    let (j, v, g) = (model.joint_count(), model.vertex_count(), anchors.len());
    let mut vertex_share = vec![0.0f64; v];
    for (&face, bary) in anchors.face_from_gaussian.iter().zip(&anchors.barycentric) {
        for c in 0..3 {
            vertex_share[model.faces[3 * face as usize + c] as usize] += bary[c] as f64;
        }
    }
    let mut out = vec![0.0f64; j * g];
    for (gi, (&face, bary)) in anchors
        .face_from_gaussian
        .iter()
        .zip(&anchors.barycentric)
        .enumerate()
    {
        for (c, &weight) in bary.iter().enumerate() {
            let vertex = model.faces[3 * face as usize + c] as usize;
            if vertex_share[vertex] <= 0.0 {
                continue;
            }
            let share = weight as f64 / vertex_share[vertex];
            for joint in 0..j {
                out[joint * g + gi] += model.joint_regressor[joint * v + vertex] as f64 * share;
            }
        }
    }
    for joint in 0..j {
        let row = &mut out[joint * g..(joint + 1) * g];
        let total: f64 = row.iter().sum();
        if total.abs() > 1e-12 {
            row.iter_mut().for_each(|w| *w /= total);
        }
    }
    out.into_iter().map(|w| w as f32).collect()
}

/// One anchor per vertex: a face containing it, with that corner's weight 1.
pub fn vertex_anchors(model: &BodyModel) -> MeshAnchors {
    let v = model.vertex_count();
    let mut slot: Vec<Option<(u32, usize)>> = vec![None; v];
    for (f, corners) in model.faces.chunks(3).enumerate() {
        for (c, &vertex) in corners.iter().enumerate() {
            slot[vertex as usize].get_or_insert((f as u32, c));
        }
    }
    let mut anchors = MeshAnchors {
        face_from_gaussian: Vec::with_capacity(v),
        barycentric: Vec::with_capacity(v),
    };
    // Vertices on no face carry no surface and are skipped.
    for (face, corner) in slot.into_iter().flatten() {
        let mut bary = [0.0; 3];
        bary[corner] = 1.0;
        anchors.face_from_gaussian.push(face);
        anchors.barycentric.push(bary);
    }
    anchors
}

/// Points of `anchors` on a mesh `[V, 3]` (flat).
pub fn anchor_points(vertices: &[f32], faces: &[u32], anchors: &MeshAnchors) -> Vec<[f32; 3]> {
    anchors
        .face_from_gaussian
        .iter()
        .zip(&anchors.barycentric)
        .map(|(&f, bary)| {
            let corner = |c: usize| faces[3 * f as usize + c] as usize;
            std::array::from_fn(|a| (0..3).map(|c| bary[c] * vertices[3 * corner(c) + a]).sum())
        })
        .collect()
}

/// The initial standard deviation of `count` Gaussians spread over a mesh: `½ √(area / count)`,
/// clamped to [1 mm, 5 cm].
pub fn initial_sigma(vertices: &[f32], faces: &[u32], count: usize) -> f32 {
    let area: f64 = (0..faces.len() / 3)
        .map(|f| face_area(vertices, faces, f))
        .sum();
    (0.5 * (area / count.max(1) as f64).sqrt()).clamp(0.001, 0.05) as f32
}

fn face_area(vertices: &[f32], faces: &[u32], f: usize) -> f64 {
    let p = |c: usize| -> [f64; 3] {
        let v = faces[3 * f + c] as usize;
        [0, 1, 2].map(|a| vertices[3 * v + a] as f64)
    };
    let (a, b, c) = (p(0), p(1), p(2));
    let e1 = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let e2 = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
    let cross = [
        e1[1] * e2[2] - e1[2] * e2[1],
        e1[2] * e2[0] - e1[0] * e2[2],
        e1[0] * e2[1] - e1[1] * e2[0],
    ];
    0.5 * (cross[0].powi(2) + cross[1].powi(2) + cross[2].powi(2)).sqrt()
}

/// The canonical Gaussians at `anchors` on the canonical mesh `vertices` (flat `[V, 3]`):
/// grey, opacity 0.1, isotropic scales from the local face area.
pub fn canonical_set(
    vertices: &[f32],
    faces: &[u32],
    anchors: &MeshAnchors,
    device: &Device,
) -> GaussianSet {
    let points = anchor_points(vertices, faces, anchors);
    let sigmas = vec![initial_sigma(vertices, faces, points.len()); points.len()];
    let colours = vec![[0.5f32; 3]; points.len()];
    GaussianSet::from_points(&points, &colours, &sigmas, device)
}

/// Flat row-major values as a `[rows, cols]` tensor.
pub fn matrix(values: Vec<f32>, rows: usize, cols: usize, device: &Device) -> Tensor<2> {
    Tensor::from_data(TensorData::new(values, [rows, cols]), device)
}
