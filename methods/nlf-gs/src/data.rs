//! NLF-GS training data from the synthetic generator: one subject per seed (an identity of the
//! multi-view studio preset, first frame), seen by a six-camera ring (every 60°, 2 m, −8°, aimed
//! at the body's middle). Views 0°, 120°, 240° are the inputs; 60°, 180°, 300° the targets, as
//! in the protocol. Each subject carries its posed body mesh and, per input view, the
//! body's depth (for the occlusion test of Eq. 4).

use crate::network::NlfInputs;
use crate::query::Views;
use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_datasets::image_io::linear_to_srgb;
use splatzoo_datasets::synth::rig::CameraTrack;
use splatzoo_datasets::synth::scene::body_label;
use splatzoo_datasets::synth::{Preset, SceneConfig};
use splatzoo_models::anchor::MeshAnchors;
use splatzoo_rasterizer::Camera;

/// Ring positions of the inputs and the targets (of six, 60° apart).
pub const INPUTS: [usize; 3] = [0, 2, 4];
pub const TARGETS: [usize; 3] = [1, 3, 5];

pub struct NlfView {
    pub camera: Camera,
    /// `[H, W, 3]` sRGB in [0, 1] over the studio background.
    pub image: Tensor<3>,
    /// `[H, W]` 1 on the body.
    pub mask: Tensor<2>,
}

pub struct NlfSubject {
    pub seed: u64,
    pub inputs: Vec<NlfView>,
    pub targets: Vec<NlfView>,
    /// `[1, Nv, 3]` the posed body.
    pub vertices: Tensor<3>,
    /// `[3, H, W]` body depth per input view (camera z; ∞ off the body).
    pub input_depth: Tensor<3>,
    /// sRGB background.
    pub background: [f32; 3],
    /// The identity's shape coefficients (for posing the same body anew).
    pub betas: Vec<f64>,
    /// The body's `trans` in this frame.
    pub translation: [f64; 3],
}

/// `camera` turned by `angle` about the vertical axis through the origin.
fn turned(camera: &Camera, angle: f64) -> Camera {
    let (s, c) = (angle.sin() as f32, angle.cos() as f32);
    // R' = R · R_y(angle)ᵀ, t' = t.
    let ry_t = [[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]];
    let mut out = *camera;
    for (row, source) in out.world_to_camera.iter_mut().zip(&camera.world_to_camera) {
        for (j, entry) in row.iter_mut().take(3).enumerate() {
            *entry = (0..3).map(|k| source[k] * ry_t[k][j]).sum();
        }
    }
    out
}

impl NlfSubject {
    /// Builds subject `seed` at `size`² pixels.
    pub fn synthetic(seed: u64, size: u32, device: &Device) -> Self {
        let mut scene = SceneConfig {
            width: size,
            height: size,
            frames: Some(1),
            ..SceneConfig::new(Preset::Multiview, seed)
        }
        .build(device);
        let first = scene.tracks[0].cameras[0];
        scene.tracks = (0..6)
            .map(|k| CameraTrack {
                name: format!("ring60_{k}"),
                cameras: vec![turned(&first, k as f64 * std::f64::consts::FRAC_PI_3)],
            })
            .collect();
        let truths = scene.render_frame(0);
        let body = body_label(0);
        let view = |k: usize| {
            let r = &truths[k].render;
            let srgb: Vec<f32> = r.color.iter().flat_map(|c| c.map(linear_to_srgb)).collect();
            let mask: Vec<f32> = r.label.iter().map(|&l| (l == body) as u8 as f32).collect();
            NlfView {
                camera: truths[k].camera,
                image: Tensor::from_data(TensorData::new(srgb, [r.height, r.width, 3]), device),
                mask: Tensor::from_data(TensorData::new(mask, [r.height, r.width]), device),
            }
        };
        let depth: Vec<f32> = INPUTS
            .iter()
            .flat_map(|&k| {
                let r = &truths[k].render;
                r.depth
                    .iter()
                    .zip(&r.label)
                    .map(|(&d, &l)| if l == body { d } else { f32::INFINITY })
                    .collect::<Vec<_>>()
            })
            .collect();
        let vertices: Vec<f32> = scene.people[0].frames[0]
            .vertices
            .iter()
            .flatten()
            .copied()
            .collect();
        let n = vertices.len() / 3;
        let s = size as usize;
        Self {
            seed,
            inputs: INPUTS.iter().map(|&k| view(k)).collect(),
            targets: TARGETS.iter().map(|&k| view(k)).collect(),
            vertices: Tensor::from_data(TensorData::new(vertices, [1, n, 3]), device),
            input_depth: Tensor::from_data(TensorData::new(depth, [3, s, s]), device),
            background: scene.environment.background.map(linear_to_srgb),
            betas: scene.people[0].motion.frame_betas(0).to_vec(),
            translation: scene.people[0].motion.translation(0),
        }
    }

    /// The background colour as a `[3]` tensor on the subject's device.
    pub fn background_tensor(&self) -> Tensor<1> {
        Tensor::<1>::from_floats(self.background.as_slice(), &self.vertices.device())
    }

    /// The generator's inputs: the three input views with the posed mesh and its depth maps.
    pub fn nlf_inputs<'a>(&self, faces: &'a [u32], anchors: &'a MeshAnchors) -> NlfInputs<'a> {
        let (images, views, camera_centres) = self.input_tensors();
        NlfInputs {
            images,
            views,
            camera_centres,
            vertices: self.vertices.clone(),
            faces,
            anchors,
            depth: Some(self.input_depth.clone()),
        }
    }

    /// The input images `[3, 3, H, W]`, their cameras as tensors and the camera centres.
    pub fn input_tensors(&self) -> (Tensor<4>, Views, Tensor<2>) {
        let device = self.vertices.device();
        let images: Vec<Tensor<4>> = self
            .inputs
            .iter()
            .map(|v| v.image.clone().permute([2, 0, 1]).unsqueeze_dim::<4>(0))
            .collect();
        let cams: Vec<Camera> = self.inputs.iter().map(|v| v.camera).collect();
        let k: Vec<f32> = cams.iter().flat_map(|c| [c.fx, c.fy, c.cx, c.cy]).collect();
        let m: Vec<f32> = cams
            .iter()
            .flat_map(|c| c.world_to_camera.concat())
            .collect();
        let centres: Vec<f32> = cams.iter().flat_map(|c| c.position()).collect();
        let size = [cams[0].width as usize, cams[0].height as usize];
        (
            Tensor::cat(images, 0),
            Views {
                intrinsics: Tensor::from_data(TensorData::new(k, [3, 4]), &device),
                world_to_camera: Tensor::from_data(TensorData::new(m, [3, 3, 4]), &device),
                size,
            },
            Tensor::from_data(TensorData::new(centres, [3, 3]), &device),
        )
    }
}

/// A posed avatar as the rasterizer's splats (degree-0 SH colour).
pub fn posed_splats(p: crate::network::PosedGaussians) -> splatzoo_rasterizer::Splats {
    splatzoo_rasterizer::Splats {
        means: p.means,
        quats: p.quats,
        log_scales: p.log_scales,
        opacity_logits: p.opacity_logits,
        colors: p.sh_dc,
    }
}
