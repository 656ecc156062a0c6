//! ResNet encoders and the fused feature pyramid: stage shapes for every depth, torchvision
//! weight loading (names, folded batch norm, unused classifier, bad files), the forward passes
//! of ResNet-18, -34 and -50 against a scalar f64 implementation of torchvision's definition,
//! the fused pyramid against an f64 implementation of its own, and the upsampling.
#![allow(clippy::needless_range_loop)] // the f64 references mirror the definitions index by index

use crate::common::{SplitMix, fresh_seed};
use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_models::networks::fpn::{ResNetFpn, Upsample, upsample};
use splatzoo_models::networks::resnet::{Depth, ResNet, imagenet_normalise};
use splatzoo_models::networks::weights::{WeightFile, module_tensors, write_safetensors};
use std::collections::BTreeMap;

/// Named tensors: shape and values.
type Named = BTreeMap<String, (Vec<usize>, Vec<f32>)>;

fn host(t: Tensor<4>) -> Vec<f32> {
    t.into_data()
        .convert::<f32>()
        .try_into_vec::<f32>()
        .unwrap()
}

/// A random `[1, 3, h, w]` image in [0, 1], with its values in f64.
fn random_image(rng: &mut SplitMix, h: usize, w: usize, device: &Device) -> (Vec<f64>, Tensor<4>) {
    let pixels: Vec<f64> = (0..3 * h * w).map(|_| rng.unit()).collect();
    let input = Tensor::<4>::from_data(
        TensorData::new(
            pixels.iter().map(|&v| v as f32).collect::<Vec<_>>(),
            [1, 3, h, w],
        ),
        device,
    );
    (pixels, input)
}

#[test]
fn every_depth_gives_four_stages_and_the_pyramid_one_map() {
    let device = Device::flex();
    let images = Tensor::<4>::ones([1, 3, 64, 48], &device) * 0.5;
    for depth in [Depth::R18, Depth::R34, Depth::R50] {
        let net = ResNet::new(depth, &device);
        let stages = net.forward(images.clone());
        let c = depth.channels();
        let sizes = [[16, 12], [8, 6], [4, 3], [2, 2]];
        for k in 0..4 {
            assert_eq!(
                stages[k].dims(),
                [1, c[k], sizes[k][0], sizes[k][1]],
                "{depth:?} C{}",
                k + 2
            );
        }
    }
    let fpn = ResNetFpn::new(Depth::R18, 32, Upsample::Bilinear, &device);
    let fused = fpn.forward(images);
    assert_eq!(fused.dims(), [1, 128, 16, 12]);
    assert!(host(fused).iter().all(|v| v.is_finite()));
}

/// Random tensors under torchvision names.
struct Fixture<'a> {
    tensors: BTreeMap<String, (Vec<usize>, Vec<f32>)>,
    rng: &'a mut SplitMix,
}

impl Fixture<'_> {
    fn put(&mut self, name: String, shape: Vec<usize>, scale: f64, offset: f64) {
        let n = shape.iter().product();
        let v = (0..n)
            .map(|_| (offset + scale * (self.rng.unit() - 0.5)) as f32)
            .collect();
        self.tensors.insert(name, (shape, v));
    }

    fn conv(&mut self, name: &str, o: usize, i: usize, k: usize) {
        let fan = (i * k * k) as f64;
        self.put(
            format!("{name}.weight"),
            vec![o, i, k, k],
            2.0 * (3.0 / fan).sqrt(),
            0.0,
        );
    }

    /// Batch-norm tensors with statistics far from (0, 1).
    fn bn(&mut self, name: &str, c: usize) {
        self.bn_with_gamma(name, c, 1.0);
    }

    /// [`bn`](Self::bn) with the scales around `gamma`.
    fn bn_with_gamma(&mut self, name: &str, c: usize, gamma: f64) {
        self.put(format!("{name}.weight"), vec![c], 0.4, gamma);
        self.put(format!("{name}.bias"), vec![c], 0.2, 0.0);
        self.put(format!("{name}.running_mean"), vec![c], 0.4, 0.1);
        self.put(format!("{name}.running_var"), vec![c], 0.5, 1.2);
    }
}

/// torchvision ResNet-18 tensors, random, with its classifier.
fn resnet18_file(rng: &mut SplitMix) -> BTreeMap<String, (Vec<usize>, Vec<f32>)> {
    resnet_file(rng, [2, 2, 2, 2], false, 1.0)
}

/// torchvision ResNet tensors, random, with a 10-class classifier: `blocks` blocks per stage,
/// basic (two 3×3) or bottlenecks (1×1, 3×3, 1×1 to 4× the width), a downsampling 1×1
/// convolution and batch norm where the stride or the channel count changes. The scales of each
/// block's last batch norm lie around `last_gamma` (below 1 keeps deep nets' activations
/// moderate).
fn resnet_file(rng: &mut SplitMix, blocks: [usize; 4], bottleneck: bool, last_gamma: f64) -> Named {
    let mut f = Fixture {
        tensors: BTreeMap::new(),
        rng,
    };
    f.conv("conv1", 64, 3, 7);
    f.bn("bn1", 64);
    let mut inputs = 64;
    for (stage, &count) in blocks.iter().enumerate() {
        let width = 64 << stage;
        let outputs = if bottleneck { 4 * width } else { width };
        for b in 0..count {
            let p = format!("layer{}.{b}", stage + 1);
            let stride = if b == 0 && stage > 0 { 2 } else { 1 };
            let block_inputs = if b == 0 { inputs } else { outputs };
            // (outputs, inputs, kernel) of conv1, conv2[, conv3].
            let convs: Vec<(usize, usize, usize)> = if bottleneck {
                vec![
                    (width, block_inputs, 1),
                    (width, width, 3),
                    (outputs, width, 1),
                ]
            } else {
                vec![(width, block_inputs, 3), (width, width, 3)]
            };
            for (k, &(o, i, size)) in convs.iter().enumerate() {
                f.conv(&format!("{p}.conv{}", k + 1), o, i, size);
                let gamma = if k + 1 == convs.len() {
                    last_gamma
                } else {
                    1.0
                };
                f.bn_with_gamma(&format!("{p}.bn{}", k + 1), o, gamma);
            }
            if stride != 1 || block_inputs != outputs {
                f.conv(&format!("{p}.downsample.0"), outputs, block_inputs, 1);
                f.bn(&format!("{p}.downsample.1"), outputs);
            }
        }
        inputs = outputs;
    }
    f.put("fc.weight".into(), vec![10, inputs], 0.1, 0.0);
    f.put("fc.bias".into(), vec![10], 0.1, 0.0);
    f.tensors
}

/// `[C, H, W]` maps in f64.
type Map = (Vec<f64>, usize, usize, usize);

fn conv_ref(x: &Map, w: &(Vec<usize>, Vec<f32>), stride: usize) -> Map {
    let (data, c, h, wd) = x;
    let (o, i, k) = (w.0[0], w.0[1], w.0[2]);
    assert_eq!(i, *c);
    let pad = k / 2;
    let oh = (h + 2 * pad - k) / stride + 1;
    let ow = (wd + 2 * pad - k) / stride + 1;
    let mut out = vec![0.0; o * oh * ow];
    for oc in 0..o {
        for y in 0..oh {
            for x0 in 0..ow {
                let mut acc = 0.0;
                for ic in 0..i {
                    for ky in 0..k {
                        for kx in 0..k {
                            let iy = (y * stride + ky) as i64 - pad as i64;
                            let ix = (x0 * stride + kx) as i64 - pad as i64;
                            if iy >= 0 && ix >= 0 && (iy as usize) < *h && (ix as usize) < *wd {
                                acc += w.1[((oc * i + ic) * k + ky) * k + kx] as f64
                                    * data[(ic * h + iy as usize) * wd + ix as usize];
                            }
                        }
                    }
                }
                out[(oc * oh + y) * ow + x0] = acc;
            }
        }
    }
    (out, o, oh, ow)
}

fn bn_ref(x: &mut Map, t: &BTreeMap<String, (Vec<usize>, Vec<f32>)>, name: &str, relu: bool) {
    let g = |s: &str| &t[&format!("{name}.{s}")].1;
    let (w, b, m, v) = (g("weight"), g("bias"), g("running_mean"), g("running_var"));
    let plane = x.2 * x.3;
    for c in 0..x.1 {
        for p in 0..plane {
            let y = &mut x.0[c * plane + p];
            *y = (*y - m[c] as f64) / (v[c] as f64 + 1e-5).sqrt() * w[c] as f64 + b[c] as f64;
            if relu {
                *y = y.max(0.0);
            }
        }
    }
}

fn maxpool_ref(x: &Map) -> Map {
    let (data, c, h, w) = x;
    let (oh, ow) = ((h + 2 - 3) / 2 + 1, (w + 2 - 3) / 2 + 1);
    let mut out = vec![f64::NEG_INFINITY; c * oh * ow];
    for ch in 0..*c {
        for y in 0..oh {
            for x0 in 0..ow {
                for ky in 0..3 {
                    for kx in 0..3 {
                        let (iy, ix) = ((2 * y + ky) as i64 - 1, (2 * x0 + kx) as i64 - 1);
                        if iy >= 0 && ix >= 0 && (iy as usize) < *h && (ix as usize) < *w {
                            let o = &mut out[(ch * oh + y) * ow + x0];
                            *o = o.max(data[(ch * h + iy as usize) * w + ix as usize]);
                        }
                    }
                }
            }
        }
    }
    (out, *c, oh, ow)
}

/// torchvision's ResNet-18 forward (eval mode) in f64: returns C2–C5.
fn resnet18_ref(image: &Map, t: &BTreeMap<String, (Vec<usize>, Vec<f32>)>) -> Vec<Map> {
    resnet_ref(image, t, [2, 2, 2, 2], false)
}

/// torchvision's ResNet forward (eval mode) in f64 with `blocks` basic blocks or bottlenecks
/// per stage: returns C2–C5. Bottlenecks stride in their 3×3 convolution (torchvision's v1.5).
fn resnet_ref(image: &Map, t: &Named, blocks: [usize; 4], bottleneck: bool) -> Vec<Map> {
    let norm_mean = [0.485, 0.456, 0.406];
    let norm_std = [0.229, 0.224, 0.225];
    let plane = image.2 * image.3;
    let mut x = image.clone();
    for c in 0..3 {
        for p in 0..plane {
            x.0[c * plane + p] = (x.0[c * plane + p] - norm_mean[c]) / norm_std[c];
        }
    }
    let mut x = conv_ref(&x, &t["conv1.weight"], 2);
    bn_ref(&mut x, t, "bn1", true);
    let mut x = maxpool_ref(&x);
    let mut stages = Vec::new();
    for (stage, &count) in blocks.iter().enumerate() {
        for b in 0..count {
            let p = format!("layer{}.{b}", stage + 1);
            let stride = if b == 0 && stage > 0 { 2 } else { 1 };
            let strides = if bottleneck {
                vec![1, stride, 1]
            } else {
                vec![stride, 1]
            };
            let mut y = x.clone();
            for (k, &s) in strides.iter().enumerate() {
                y = conv_ref(&y, &t[&format!("{p}.conv{}.weight", k + 1)], s);
                bn_ref(
                    &mut y,
                    t,
                    &format!("{p}.bn{}", k + 1),
                    k + 1 < strides.len(),
                );
            }
            let identity = if t.contains_key(&format!("{p}.downsample.0.weight")) {
                let mut d = conv_ref(&x, &t[&format!("{p}.downsample.0.weight")], stride);
                bn_ref(&mut d, t, &format!("{p}.downsample.1"), false);
                d
            } else {
                x.clone()
            };
            assert_eq!(
                identity.0.len(),
                y.0.len(),
                "{p}: identity and residual shapes"
            );
            for (v, i) in y.0.iter_mut().zip(&identity.0) {
                *v = (*v + i).max(0.0);
            }
            x = y;
        }
        stages.push(x.clone());
    }
    stages
}

/// A network's `[1, C, H, W]` output against an f64 map: shape, and the worst error within
/// 1e-4 of the map's largest magnitude.
fn assert_matches(got: Tensor<4>, want: &Map, what: &str) {
    assert_eq!(got.dims(), [1, want.1, want.2, want.3], "{what}");
    let got = host(got);
    let scale = want.0.iter().map(|v| v.abs()).fold(0.0, f64::max).max(1e-6);
    let worst = got
        .iter()
        .zip(&want.0)
        .map(|(a, b)| (*a as f64 - b).abs())
        .fold(0.0, f64::max);
    assert!(worst < 1e-4 * scale, "{what}: worst {worst} of {scale}");
}

/// Adds a per-channel bias.
fn add_bias(x: &mut Map, b: &[f32]) {
    let plane = x.2 * x.3;
    for c in 0..x.1 {
        for p in 0..plane {
            x.0[c * plane + p] += b[c] as f64;
        }
    }
}

/// `[C, h, w]` → `[C, oh, ow]`: bilinear with pixel centres at +0.5 (align_corners = false),
/// source coordinates clamped to the border; or nearest, source `⌊i · h / oh⌋`.
fn upsample_ref(x: &Map, oh: usize, ow: usize, bilinear: bool) -> Map {
    let (data, c, h, w) = x;
    let (c, h, w) = (*c, *h, *w);
    let at = |ch: usize, y: usize, x0: usize| data[(ch * h + y) * w + x0];
    let mut out = Vec::with_capacity(c * oh * ow);
    for ch in 0..c {
        for i in 0..oh {
            for j in 0..ow {
                let v = if bilinear {
                    let sy =
                        ((i as f64 + 0.5) * h as f64 / oh as f64 - 0.5).clamp(0.0, (h - 1) as f64);
                    let sx =
                        ((j as f64 + 0.5) * w as f64 / ow as f64 - 0.5).clamp(0.0, (w - 1) as f64);
                    let (y0, x0) = (sy.floor() as usize, sx.floor() as usize);
                    let (y1, x1) = ((y0 + 1).min(h - 1), (x0 + 1).min(w - 1));
                    let (fy, fx) = (sy - y0 as f64, sx - x0 as f64);
                    (1.0 - fy) * ((1.0 - fx) * at(ch, y0, x0) + fx * at(ch, y0, x1))
                        + fy * ((1.0 - fx) * at(ch, y1, x0) + fx * at(ch, y1, x1))
                } else {
                    at(ch, i * h / oh, j * w / ow)
                };
                out.push(v);
            }
        }
    }
    (out, c, oh, ow)
}

/// The fused pyramid as `fpn.rs` defines it, in f64, from C2–C5 and the pyramid's parameters
/// (`lateral.{l}.*`, `output.{l}.*` as `module_tensors` names them): lateral 1×1 convolutions
/// (with bias) bring each C to the pyramid's width; top-down, each merged level is the lateral
/// plus the coarser merged level upsampled (nearest) to its size; 3×3 convolutions (with bias)
/// smooth the merged levels into P2–P5; P3–P5 are upsampled to P2's size (`bilinear` or
/// nearest) and concatenated after P2 along the channels.
fn fpn_ref(c: &[Map], t: &Named, bilinear: bool) -> Map {
    let get = move |name: String| {
        t.get(&name)
            .unwrap_or_else(|| panic!("no {name} among {:?}", t.keys().collect::<Vec<_>>()))
    };
    let mut p: Vec<Map> = Vec::with_capacity(4);
    let mut top: Option<Map> = None;
    for level in (0..4).rev() {
        let mut merged = conv_ref(&c[level], get(format!("lateral.{level}.weight")), 1);
        add_bias(&mut merged, &get(format!("lateral.{level}.bias")).1);
        if let Some(coarse) = &top {
            let up = upsample_ref(coarse, merged.2, merged.3, false);
            for (m, u) in merged.0.iter_mut().zip(&up.0) {
                *m += u;
            }
        }
        let mut smooth = conv_ref(&merged, get(format!("output.{level}.weight")), 1);
        add_bias(&mut smooth, &get(format!("output.{level}.bias")).1);
        p.push(smooth);
        top = Some(merged);
    }
    p.reverse(); // P2 … P5
    let (h, w) = (p[0].2, p[0].3);
    let mut fused = Vec::new();
    let mut channels = 0;
    for (k, level) in p.iter().enumerate() {
        let level = if k == 0 {
            level.clone()
        } else {
            upsample_ref(level, h, w, bilinear)
        };
        channels += level.1;
        fused.extend(level.0);
    }
    (fused, channels, h, w)
}

#[test]
fn torchvision_resnet18_weights_load_and_match_the_f64_definition() {
    let device = Device::flex();
    let dir = tempfile::tempdir().unwrap();
    let mut rng = SplitMix(7);
    let tensors = resnet18_file(&mut rng);
    let path = dir.path().join("resnet18.safetensors");
    write_safetensors(&path, &tensors).unwrap();
    let file = WeightFile::read(&path).unwrap();
    let mut net = ResNet::new(Depth::R18, &device);
    net.load(&file).unwrap();
    assert_eq!(
        file.untaken(),
        vec!["fc.bias".to_string(), "fc.weight".to_string()],
        "only the classifier is left"
    );
    let (h, w) = (40, 32);
    let (pixels, input) = random_image(&mut rng, h, w, &device);
    let got = net.forward(splatzoo_models::networks::resnet::imagenet_normalise(input));
    let want = resnet18_ref(&(pixels, 3, h, w), &tensors);
    for (k, (g, r)) in got.into_iter().zip(&want).enumerate() {
        assert_eq!(g.dims(), [1, r.1, r.2, r.3], "C{}", k + 2);
        let g = host(g);
        let scale = r.0.iter().map(|v| v.abs()).fold(0.0, f64::max).max(1e-6);
        let worst = g
            .iter()
            .zip(&r.0)
            .map(|(a, b)| (*a as f64 - b).abs())
            .fold(0.0, f64::max);
        assert!(worst < 1e-4 * scale, "C{}: worst {worst} of {scale}", k + 2);
    }
    // Bad files: a missing tensor and a misshapen one are named with the expected shape.
    let load_error = |broken: &BTreeMap<String, (Vec<usize>, Vec<f32>)>| {
        write_safetensors(&path, broken).unwrap();
        ResNet::new(Depth::R18, &device)
            .load(&WeightFile::read(&path).unwrap())
            .unwrap_err()
            .to_string()
    };
    let mut broken = tensors.clone();
    broken.remove("layer2.0.downsample.1.running_var");
    let e = load_error(&broken);
    assert!(
        e.contains("resnet18.safetensors")
            && e.contains("layer2.0.downsample.1.running_var")
            && e.contains("[128]"),
        "{e}"
    );
    let mut broken = tensors.clone();
    broken.get_mut("layer1.1.conv2.weight").unwrap().0 = vec![64, 64, 1, 9];
    let e = load_error(&broken);
    assert!(
        e.contains("layer1.1.conv2.weight")
            && e.contains("[64, 64, 1, 9]")
            && e.contains("[64, 64, 3, 3]"),
        "{e}"
    );
    // A ResNet-50 file does not fit ResNet-18.
    let e = ResNet::new(Depth::R50, &device)
        .load(&WeightFile::read(&path).unwrap())
        .unwrap_err()
        .to_string();
    assert!(e.contains("layer1.0"), "{e}");
}

#[test]
fn upsampling_keeps_constants_interpolates_ramps_and_passes_gradients() {
    let device = Device::flex();
    let c = Tensor::<4>::ones([1, 2, 3, 4], &device) * 0.7;
    for mode in [Upsample::Bilinear, Upsample::Nearest] {
        let up = upsample(c.clone(), [6, 8], mode);
        assert_eq!(up.dims(), [1, 2, 6, 8]);
        assert!(host(up).iter().all(|v| (v - 0.7).abs() < 1e-6), "{mode:?}");
    }
    // A horizontal ramp 0, 1, 2, 3 (pixel centres) upsampled 2×: output centres fall at
    // input coordinates (j + 0.5) / 2 − 0.5, clamped at the borders.
    let ramp = Tensor::<4>::from_data(
        TensorData::new(vec![0.0f32, 1.0, 2.0, 3.0], [1, 1, 1, 4]),
        &device,
    );
    let up = host(upsample(ramp.clone(), [1, 8], Upsample::Bilinear));
    for (j, v) in up.iter().enumerate() {
        let want = ((j as f32 + 0.5) / 2.0 - 0.5).clamp(0.0, 3.0);
        assert!((v - want).abs() < 1e-5, "{j}: {v} vs {want}");
    }
    let leaf = ramp.autodiff().require_grad();
    let grads = upsample(leaf.clone(), [1, 8], Upsample::Bilinear)
        .sum()
        .backward();
    let g = leaf.grad(&grads).unwrap();
    let total: f32 = host(g).iter().sum();
    assert!(
        (total - 8.0).abs() < 1e-4,
        "each output's weights sum to one: {total}"
    );
}

/// ResNet-34 and ResNet-50 with random torchvision weights against the f64 definition: every
/// tensor of the file is taken but the classifier, and C2–C5 match.
fn check_resnet(depth: Depth, blocks: [usize; 4], bottleneck: bool, (h, w): (usize, usize)) {
    let device = Device::flex();
    let dir = tempfile::tempdir().unwrap();
    let seed = fresh_seed();
    let mut rng = SplitMix(seed);
    let tensors = resnet_file(&mut rng, blocks, bottleneck, 0.5);
    let path = dir.path().join("resnet.safetensors");
    write_safetensors(&path, &tensors).unwrap();
    let file = WeightFile::read(&path).unwrap();
    let mut net = ResNet::new(depth, &device);
    net.load(&file).unwrap();
    assert_eq!(
        file.untaken(),
        vec!["fc.bias".to_string(), "fc.weight".to_string()],
        "{depth:?}: only the classifier is left"
    );
    let (pixels, input) = random_image(&mut rng, h, w, &device);
    let got = net.forward(imagenet_normalise(input));
    let want = resnet_ref(&(pixels, 3, h, w), &tensors, blocks, bottleneck);
    for (k, (g, r)) in got.into_iter().zip(&want).enumerate() {
        assert_eq!(r.1, depth.channels()[k], "{depth:?} C{}", k + 2);
        assert_matches(g, r, &format!("{depth:?} C{} (seed {seed})", k + 2));
    }
}

#[test]
fn torchvision_resnet34_weights_load_and_match_the_f64_definition() {
    // Basic blocks, 3-4-6-3; odd sizes deeper down (48 → 12, 6, 3, 2 columns).
    check_resnet(Depth::R34, [3, 4, 6, 3], false, (32, 48));
}

#[test]
fn torchvision_resnet50_weights_load_and_match_the_f64_definition() {
    // Bottlenecks with the stride on the 3×3, 3-4-6-3; 40 → 10, 5, 3, 2 columns.
    check_resnet(Depth::R50, [3, 4, 6, 3], true, (32, 40));
}

/// The fused pyramid over a torchvision ResNet-18 against `fpn_ref`, the f64 implementation of
/// fpn.rs's definition, for both upsampling modes and both forward passes; level by level, so
/// that a small level cannot hide behind a large one.
#[test]
fn the_fused_pyramid_matches_its_f64_definition() {
    let device = Device::flex();
    let dir = tempfile::tempdir().unwrap();
    let seed = fresh_seed();
    let mut rng = SplitMix(seed);
    let tensors = resnet18_file(&mut rng);
    let path = dir.path().join("resnet18.safetensors");
    write_safetensors(&path, &tensors).unwrap();
    let file = WeightFile::read(&path).unwrap();
    // H ≠ W, multiples of 32: C2–C5 are 8×16, 4×8, 2×4 and 1×2.
    let (h, w) = (32, 64);
    let (pixels, input) = random_image(&mut rng, h, w, &device);
    let stages = resnet18_ref(&(pixels, 3, h, w), &tensors);
    let channels = 8;
    for mode in [Upsample::Bilinear, Upsample::Nearest] {
        let mut fpn = ResNetFpn::new(Depth::R18, channels, mode, &device);
        fpn.load_backbone(&file).unwrap();
        let want = fpn_ref(&stages, &module_tensors(&fpn), mode == Upsample::Bilinear);
        assert_eq!((want.1, want.2, want.3), (4 * channels, h / 4, w / 4));
        for (what, got) in [
            ("forward", fpn.forward(input.clone())),
            ("forward_inference", fpn.forward_inference(input.clone())),
        ] {
            assert_eq!(got.dims(), [1, want.1, want.2, want.3], "{mode:?} {what}");
            let got = host(got);
            let block = channels * want.2 * want.3;
            for k in 0..4 {
                let r = &want.0[k * block..(k + 1) * block];
                let g = &got[k * block..(k + 1) * block];
                let scale = r.iter().map(|v| v.abs()).fold(0.0, f64::max).max(1e-6);
                let worst = g
                    .iter()
                    .zip(r)
                    .map(|(a, b)| (*a as f64 - b).abs())
                    .fold(0.0, f64::max);
                assert!(
                    worst < 1e-4 * scale,
                    "{mode:?} {what} P{}: worst {worst} of {scale} (seed {seed})",
                    k + 2
                );
            }
        }
    }
}
