//! The "mean colour of its projections" baseline of the `train-nlf` issue: every anchored
//! Gaussian (no offset, on its face's frame) takes the occlusion-weighted mean of the input
//! images at its projections (Eq. 2–4 of NLF-GS with the images themselves as feature maps),
//! full opacity, and an isotropic scale from the mesh's mean spacing of Gaussians.

use crate::data::NlfSubject;
use crate::network::PosedGaussians;
use crate::query::{Fusion, project, sample_and_fuse, weights};
use burn::tensor::Tensor;
use splatzoo_models::anchor::{MeshAnchors, anchored_positions};
use splatzoo_models::rotation::matrix_to_quaternion;

use splatzoo_rasterizer::sh::SH_C0;

pub fn mean_colour_avatar(
    subject: &NlfSubject,
    faces: &[u32],
    anchors: &MeshAnchors,
) -> PosedGaussians {
    let g = anchors.len();
    let device = subject.vertices.device();
    let (centres, frames) = anchored_positions(
        subject.vertices.clone(),
        faces,
        anchors,
        Tensor::zeros([1, g, 3], &device),
    );
    let centres = centres.reshape([g, 3]);
    let normals = frames
        .clone()
        .slice([0..1, 0..g, 0..3, 2..3])
        .reshape([g, 3]);
    let (images, views, camera_centres) = subject.input_tensors();
    let projection = project(centres.clone(), &views);
    let w = weights(
        Fusion::Occlusion,
        centres.clone(),
        normals,
        camera_centres,
        &projection,
        Some(subject.input_depth.clone()),
        0.02,
    );
    let rgb = sample_and_fuse(images, &projection, w, views.size);
    // Spacing: √(surface area / G), from the posed mesh.
    let v: Vec<f32> = splatzoo_train::host_f32(&subject.vertices);
    let area: f32 = faces
        .chunks(3)
        .map(|f| {
            let p = |i: u32| {
                [
                    v[3 * i as usize],
                    v[3 * i as usize + 1],
                    v[3 * i as usize + 2],
                ]
            };
            let (a, b, c) = (p(f[0]), p(f[1]), p(f[2]));
            let e1 = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
            let e2 = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
            let x = [
                e1[1] * e2[2] - e1[2] * e2[1],
                e1[2] * e2[0] - e1[0] * e2[2],
                e1[0] * e2[1] - e1[1] * e2[0],
            ];
            0.5 * (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt()
        })
        .sum();
    let sigma = 0.5 * (area / g as f32).sqrt();
    PosedGaussians {
        means: centres,
        quats: matrix_to_quaternion(frames.reshape([g, 3, 3])),
        log_scales: Tensor::full([g, 3], sigma.ln(), &device),
        opacity_logits: Tensor::full([g], 4.0, &device),
        sh_dc: ((rgb - 0.5) / SH_C0).reshape([g, 1, 3]),
    }
}
