//! NLF-GS as one Burn module: a ResNet-FPN encoder over the input views, Gaussians anchored to
//! the body mesh (Eq. 1 of NLF-GS) queried in every view (Eq. 2–3), fused with geometry-aware
//! weights (Eq. 4), and decoded into pose-independent attributes ([`Avatar`]); driving the
//! avatar re-anchors the same Gaussians on a newly posed mesh, their offsets and rotations
//! following each face's frame.

use crate::decoder::{Attributes, Decoder};
use crate::query::{Fusion, Views, project, sample_and_fuse, weights};
use burn::module::Module;
use burn::tensor::{Device, Tensor};
use serde::{Deserialize, Serialize};
use splatzoo_models::anchor::{MeshAnchors, anchored_positions};
use splatzoo_models::networks::fpn::{ResNetFpn, Upsample};
use splatzoo_models::networks::resnet::Depth;
use splatzoo_models::rotation::{matrix_to_quaternion, quaternion_to_matrix};

/// Every architectural knob of NLF-GS.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NlfConfig {
    /// ResNet depth (the paper uses 50; 18 is the fast choice).
    pub depth: Depth,
    /// Channels per pyramid level (the fused map has four times as many).
    pub fpn_channels: usize,
    pub upsample: Upsample,
    /// Gaussians per mesh face (`K`; 4 in the paper).
    pub gaussians_per_face: usize,
    pub fusion: Fusion,
    /// Relative depth tolerance of the occlusion test.
    pub occlusion_tolerance: f64,
    /// Hidden widths of the decoder MLP.
    pub hidden: Vec<usize>,
    /// Also sample the input images' colour (bilinear, full resolution) and fuse it with the
    /// same weights, giving the decoder `4 · fpn_channels + 3` inputs. Not in the paper, so off
    /// by default: with Adam at ε = 1e-8 it made no difference at 300 steps (27.02 against
    /// 27.01 dB held out; README), though with ε = 1e-5 it had been worth 0.9 dB.
    pub image_colour: bool,
    /// Bounds of the decoded offset (metres, in the face frame) and scale (metres).
    pub max_offset: f64,
    pub max_scale: f64,
}

impl NlfConfig {
    /// Width of the fused feature the decoder reads.
    pub fn decoder_inputs(&self) -> usize {
        4 * self.fpn_channels + if self.image_colour { 3 } else { 0 }
    }
}

impl Default for NlfConfig {
    fn default() -> Self {
        Self {
            depth: Depth::R18,
            fpn_channels: 64,
            upsample: Upsample::Bilinear,
            gaussians_per_face: 4,
            fusion: Fusion::Full,
            occlusion_tolerance: 0.02,
            hidden: vec![128, 128],
            image_colour: false,
            max_offset: 0.03,
            max_scale: 0.03,
        }
    }
}

#[derive(Module, Debug)]
pub struct NlfGs {
    pub encoder: ResNetFpn,
    pub decoder: Decoder,
    #[module(skip)]
    image_colour: bool,
}

/// The input views of one subject and its posed body mesh in the same frame.
pub struct NlfInputs<'a> {
    /// `[V, 3, H, W]` images in [0, 1].
    pub images: Tensor<4>,
    pub views: Views,
    /// `[V, 3]` camera centres in the world.
    pub camera_centres: Tensor<2>,
    /// `[1, Nv, 3]` the body mesh posed as in the images.
    pub vertices: Tensor<3>,
    pub faces: &'a [u32],
    pub anchors: &'a MeshAnchors,
    /// `[V, H, W]` depth of the posed body per view (camera z; ∞ where empty), for the
    /// occlusion test.
    pub depth: Option<Tensor<3>>,
}

/// A generated avatar: per-Gaussian attributes relative to the mesh anchors.
#[derive(Debug, Clone)]
pub struct Avatar {
    pub attributes: Attributes,
}

/// An avatar placed on a posed mesh, ready for the rasterizer.
#[derive(Debug, Clone)]
pub struct PosedGaussians {
    /// `[G, 3]`
    pub means: Tensor<2>,
    /// `[G, 4]` world rotations (w, x, y, z).
    pub quats: Tensor<2>,
    /// `[G, 3]`
    pub log_scales: Tensor<2>,
    /// `[G]`
    pub opacity_logits: Tensor<1>,
    /// `[G, 1, 3]` SH DC.
    pub sh_dc: Tensor<3>,
}

impl NlfGs {
    pub fn new(config: &NlfConfig, device: &Device) -> Self {
        let encoder = ResNetFpn::new(config.depth, config.fpn_channels, config.upsample, device);
        let decoder = Decoder::new(
            config.decoder_inputs(),
            &config.hidden,
            config.max_offset,
            config.max_scale,
            device,
        );
        Self {
            encoder,
            decoder,
            image_colour: config.image_colour,
        }
    }

    /// Images → avatar (Eq. 1–4 and the decoder), with `fusion` weights.
    pub fn generate(&self, inputs: &NlfInputs, fusion: Fusion, tolerance: f64) -> Avatar {
        let features = self.encoder.forward(inputs.images.clone());
        Avatar {
            attributes: self
                .decoder
                .forward(self.query(features, inputs, fusion, tolerance)),
        }
    }

    /// The fused feature `[G, C]` of every anchored Gaussian (Eq. 1–4) from the encoder's
    /// `[V, C, h, w]` maps of `inputs.images` (and the images' own colour when
    /// [`NlfConfig::image_colour`] is set): the step between the two exported ONNX graphs.
    pub fn query(
        &self,
        features: Tensor<4>,
        inputs: &NlfInputs,
        fusion: Fusion,
        tolerance: f64,
    ) -> Tensor<2> {
        let g = inputs.anchors.len();
        let zeros = Tensor::<3>::zeros([1, g, 3], &inputs.vertices.device());
        let (centres, frames) =
            anchored_positions(inputs.vertices.clone(), inputs.faces, inputs.anchors, zeros);
        let centres = centres.reshape([g, 3]);
        // The face normal is the frame's third column.
        let normals = frames.slice([0..1, 0..g, 0..3, 2..3]).reshape([g, 3]);
        let projection = project(centres.clone(), &inputs.views);
        let w = weights(
            fusion,
            centres,
            normals,
            inputs.camera_centres.clone(),
            &projection,
            inputs.depth.clone(),
            tolerance,
        );
        let fused = sample_and_fuse(features, &projection, w.clone(), inputs.views.size);
        if self.image_colour {
            let colour = sample_and_fuse(inputs.images.clone(), &projection, w, inputs.views.size);
            Tensor::cat(vec![fused, colour], 1)
        } else {
            fused
        }
    }
}

impl Avatar {
    /// Places the avatar on `vertices` `[1, Nv, 3]` (any pose of the same mesh).
    pub fn drive(
        &self,
        vertices: Tensor<3>,
        faces: &[u32],
        anchors: &MeshAnchors,
    ) -> PosedGaussians {
        let a = &self.attributes;
        let g = anchors.len();
        let (means, frames) = anchored_positions(
            vertices,
            faces,
            anchors,
            a.offset.clone().reshape([1, g, 3]),
        );
        let local = quaternion_to_matrix(a.quats.clone());
        let world = frames.reshape([g, 3, 3]).matmul(local);
        PosedGaussians {
            means: means.reshape([g, 3]),
            quats: matrix_to_quaternion(world),
            log_scales: a.log_scales.clone(),
            opacity_logits: a.opacity_logits.clone(),
            sh_dc: a.sh_dc(),
        }
    }
}
