//! ONNX export of NLF-GS for inference, as two graphs with the geometric query between them:
//!
//! 1. `encoder.onnx`: `[V, 3, H, W]` images in [0, 1] → `[V, 4C, H/4, W/4]` fused ResNet-FPN
//!    features (Eq. 8 of NLF-GS). `V` is a dynamic axis; `H` and `W` are fixed at export.
//! 2. the query, not exported: anchor the Gaussians on the posed body mesh (Eq. 1), project
//!    them into each view (Eq. 2), sample the feature maps bilinearly (Eq. 3) and fuse across
//!    views with the geometry-aware weights (Eq. 4). It needs floor, integer indices and
//!    comparisons, which burn-onnx 0.22 does not lower, and it is cheap arithmetic on the
//!    mesh; [`NlfGs::query`] is the reference, and the `README.md` written beside the graphs
//!    spells out its conventions.
//! 3. `decoder.onnx`: `[G, 4C (+ 3)]` fused features → `[G, 14]` attributes (offset 3,
//!    quaternion 4, log-scale 3, opacity logit 1, colour 3;
//!    [`crate::decoder::Attributes::packed`]). `G` is fixed at export
//!    (burn-onnx rejects slicing a tensor with a dynamic axis, and the decoder slices its head).
//!
//! Every graph input and output is named for what it is ([`ENCODER_IO`], [`DECODER_IO`]:
//! `images` → `features`, `fused_features` → `attributes`). Beside each graph,
//! `<graph>.vectors.safetensors` holds test vectors keyed by those names (`images.k`,
//! `features.k`, …): inputs and Burn's outputs, which any runtime can be checked against. `anchors.safetensors`
//! holds the Gaussians' faces and barycentric weights, so the query can be rebuilt elsewhere.
//! The ONNX bytes are written atomically. [`verify`] runs each graph on its vectors in tract (a
//! pure-Rust ONNX runtime), so every export is checked against Burn before it is reported;
//! naming, writing and checking graphs are the engine's ([`splatzoo_train::onnx`]).

use crate::NlfError;
use crate::decoder::Decoder;
use crate::network::{NlfConfig, NlfGs};
use burn::tensor::Tensor;
use burn_onnx::export::{AxisSpec, InputSpec, OnnxExporter};
use splatzoo_models::anchor::MeshAnchors;
use splatzoo_models::networks::fpn::ResNetFpn;
use splatzoo_train::checkpoint::Checkpoint;
use splatzoo_train::onnx::write_graph;
use std::path::{Path, PathBuf};

/// The encoder graph's input and output names.
pub const ENCODER_IO: (&str, &str) = ("images", "features");
/// The decoder graph's input and output names.
pub const DECODER_IO: (&str, &str) = ("fused_features", "attributes");

/// Sample inputs for the export and its test vectors, on a non-autodiff device.
pub struct OnnxSamples {
    /// Each `[V, 3, H, W]` in [0, 1]; all the same `H`, `W`. At least two, differing in `V`
    /// (the encoder's dynamic axis is validated on them).
    pub images: Vec<Tensor<4>>,
    /// Each `[G, NlfConfig::decoder_inputs()]`, as [`NlfGs::query`] gives them.
    pub fused: Vec<Tensor<2>>,
}

/// The files [`export`] wrote.
#[derive(Debug, Clone)]
pub struct OnnxFiles {
    pub encoder: PathBuf,
    pub encoder_vectors: PathBuf,
    pub decoder: PathBuf,
    pub decoder_vectors: PathBuf,
    pub anchors: PathBuf,
    pub readme: PathBuf,
}

/// Writes both graphs, their test vectors, the anchors and the README into `dir`.
pub fn export(
    model: &NlfGs,
    config: &NlfConfig,
    anchors: &MeshAnchors,
    samples: &OnnxSamples,
    dir: &Path,
) -> Result<OnnxFiles, NlfError> {
    let g = anchors.len();
    let fail = |problem: String| NlfError::onnx(dir, problem);
    let c = config.decoder_inputs();
    if samples.images.len() < 2 || samples.fused.is_empty() {
        return Err(fail(
            "the export needs two image batches and one fused-feature sample".into(),
        ));
    }
    let [v0, _, h, w] = samples.images[0].dims();
    let [v1, _, _, _] = samples.images[1].dims();
    if v0 == v1 {
        return Err(fail(format!(
            "the two image batches must differ in view count (both {v0})"
        )));
    }
    for (k, images) in samples.images.iter().enumerate() {
        let [_, channels, hk, wk] = images.dims();
        if channels != 3 || hk != h || wk != w {
            return Err(fail(format!(
                "images {k} are {:?}, expected [_, 3, {h}, {w}]",
                images.dims()
            )));
        }
    }
    for (k, fused) in samples.fused.iter().enumerate() {
        if fused.dims() != [g, c] {
            return Err(fail(format!(
                "fused features {k} are {:?}, expected [{g}, {c}]",
                fused.dims()
            )));
        }
    }
    std::fs::create_dir_all(dir).map_err(|e| fail(format!("cannot create ({e})")))?;
    let files = OnnxFiles {
        encoder: dir.join("encoder.onnx"),
        encoder_vectors: dir.join("encoder.vectors.safetensors"),
        decoder: dir.join("decoder.onnx"),
        decoder_vectors: dir.join("decoder.vectors.safetensors"),
        anchors: dir.join("anchors.safetensors"),
        readme: dir.join("README.md"),
    };
    let encoder = OnnxExporter::new()
        .export_dynamic(
            &model.encoder,
            samples.images[0].clone(),
            samples.images[1].clone(),
            &[InputSpec::new([
                AxisSpec::dynamic("views"),
                AxisSpec::Static,
                AxisSpec::Static,
                AxisSpec::Static,
            ])],
            |m: &ResNetFpn, x: Tensor<4>| m.forward_inference(x),
        )
        .map_err(|e| NlfError::onnx(&files.encoder, format!("exporting the encoder: {e}")))?;
    let (input, output) = ENCODER_IO;
    write_graph(encoder.as_bytes(), &[input], &[output], &files.encoder)?;
    let decoder = OnnxExporter::new()
        .export(
            &model.decoder,
            samples.fused[0].clone(),
            |m: &Decoder, x: Tensor<2>| m.forward(x).packed(),
        )
        .map_err(|e| NlfError::onnx(&files.decoder, format!("exporting the decoder: {e}")))?;
    let (input, output) = DECODER_IO;
    write_graph(decoder.as_bytes(), &[input], &[output], &files.decoder)?;

    let (input, output) = ENCODER_IO;
    let mut vectors = Checkpoint::default();
    for (k, images) in samples.images.iter().enumerate() {
        vectors.put(&format!("{input}.{k}"), images);
        vectors.put(
            &format!("{output}.{k}"),
            &model.encoder.forward_inference(images.clone()),
        );
    }
    vectors
        .write(&files.encoder_vectors)
        .map_err(splatzoo_train::TrainError::from)?;
    let (input, output) = DECODER_IO;
    let mut vectors = Checkpoint::default();
    for (k, fused) in samples.fused.iter().enumerate() {
        vectors.put(&format!("{input}.{k}"), fused);
        vectors.put(
            &format!("{output}.{k}"),
            &model.decoder.forward(fused.clone()).packed(),
        );
    }
    vectors
        .write(&files.decoder_vectors)
        .map_err(splatzoo_train::TrainError::from)?;

    let mut table = Checkpoint::default();
    table.tensors.insert(
        "face_from_gaussian".into(),
        (
            vec![g],
            anchors
                .face_from_gaussian
                .iter()
                .map(|&f| f as f32)
                .collect(),
        ),
    );
    table.tensors.insert(
        "barycentric".into(),
        (vec![g, 3], anchors.barycentric.concat()),
    );
    table
        .write(&files.anchors)
        .map_err(splatzoo_train::TrainError::from)?;
    write(&files.readme, readme(config, g, [w, h]).as_bytes())?;
    Ok(files)
}

fn write(path: &Path, bytes: &[u8]) -> Result<(), NlfError> {
    splatzoo_models::files::write_bytes(path, bytes)
        .map_err(|e| NlfError::onnx(path, format!("cannot write ({e})")))
}

fn readme(config: &NlfConfig, g: usize, [w, h]: [usize; 2]) -> String {
    let c = 4 * config.fpn_channels;
    let inputs = config.decoder_inputs();
    let (fw, fh) = (w.div_ceil(4), h.div_ceil(4));
    format!(
        "# NLF-GS for inference: two ONNX graphs and the query between them

Written by splatzoo (opset 18). Configuration: ResNet {depth:?} (R18/R34/R50), {fc} channels per FPN level,
{k} Gaussians per body face ({g} in all), fusion `{fusion:?}` with occlusion tolerance {tol}.

## 1. `encoder.onnx`
Input `images` `[V, 3, {h}, {w}]`: the V input views, RGB in [0, 1] (sRGB values as stored in the
images, not ImageNet-normalised: the graph normalises). V is dynamic.
Output `features` `[V, {c}, {fh}, {fw}]`: P2–P5 of the FPN upsampled (bilinear, half-pixel) to stride 4
and concatenated.

## 2. The query (not a graph)
For each Gaussian i, with the body mesh posed as in the images (vertices in the world frame):
1. Anchor (Eq. 1): `x_i = Σ_j b_ij v_(face_i, j)`, face and barycentric weights from
   `anchors.safetensors` (`face_from_gaussian` `[{g}]`, `barycentric` `[{g}, 3]`). The face
   normal `n_i` is the unit normal of the triangle (v1 − v0) × (v2 − v0).
2. Project (Eq. 2): OpenCV camera, `[x_c] = R x_i + t`, `u = fx x_c/z_c + cx`,
   `v = fy y_c/z_c + cy`, pixel centres at +0.5 (the top-left pixel's centre is (0.5, 0.5)).
   A view counts only if `z_c > 1e-6` and `0 ≤ u < {w}`, `0 ≤ v < {h}`.
3. Sample (Eq. 3): bilinear, feature-map coordinate `u · {fw}/{w} − 0.5` (and likewise for v),
   zero outside the map (grid_sample with align_corners = false, zero padding).
4. Weigh (Eq. 4): orientation `max(0, n_i · d_v)` with `d_v` the unit vector from `x_i` to
   camera v's centre; occlusion 1 if `z_c ≤ D_v(⌊u⌋, ⌊v⌋) · (1 + {tol})` for a depth map `D_v`
   of the posed body (camera z, ∞ where empty), else 0. Which factors apply depends on the
   fusion variant (`{fusion:?}` here).
5. Fuse: `f_i = Σ_v w_iv q_iv / max(Σ_v w_iv, 1e-6)`.{colour}

## 3. `decoder.onnx`
Input `fused_features` `[{g}, {inputs}]`: the fused features. Output `attributes` `[{g}, 14]`: offset in the face frame (3, metres),
unit quaternion w x y z in the face frame (4), natural-log scale (3), opacity logit (1, apply a
sigmoid), colour in [0, 1] (3).

To place the avatar on any pose of the mesh, build each face's frame `F = [t b n]` (columns:
`t` = unit(v1 − v0), `n` = unit((v1 − v0) × (v2 − v0)), `b` = n × t); the Gaussian's centre is
`x_i + F · offset`, its rotation `F · R(q)`, its scale `exp(log-scale)`.

## Test vectors
`encoder.vectors.safetensors` holds inputs `images.k` and Burn's outputs `features.k`;
`decoder.vectors.safetensors` holds `fused_features.k` and `attributes.k`. Feed each input by
its name (onnxruntime: `session.run([\"features\"], {{\"images\": x}})`); a runtime should reproduce
the outputs to about 1e-4.
",
        depth = config.depth,
        fc = config.fpn_channels,
        k = config.gaussians_per_face,
        fusion = config.fusion,
        tol = config.occlusion_tolerance,
        colour = if config.image_colour {
            format!(
                "\n6. Append the input images' own colour, sampled the same way at full resolution \
                 (coordinate `u − 0.5`) and fused with the same weights: {c} + 3 = {inputs} \
                 values per Gaussian."
            )
        } else {
            String::new()
        },
    )
}

pub use splatzoo_train::onnx::{io_names, max_relative_difference, run_graph, verify};
