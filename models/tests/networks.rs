//! ResNet encoders and the fused feature pyramid: stage shapes for every depth, torchvision
//! weight loading (names, folded batch norm, unused classifier, bad files), ResNet-18's forward
//! pass against a scalar f64 implementation of torchvision's definition, and the upsampling.

use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_models::networks::fpn::{ResNetFpn, Upsample, upsample};
use splatzoo_models::networks::resnet::{Depth, ResNet};
use splatzoo_models::networks::weights::{WeightFile, write_safetensors};
use std::collections::BTreeMap;

struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn host(t: Tensor<4>) -> Vec<f32> {
    t.into_data()
        .convert::<f32>()
        .try_into_vec::<f32>()
        .unwrap()
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
    rng: &'a mut Rng,
}

impl Fixture<'_> {
    fn put(&mut self, name: String, shape: Vec<usize>, scale: f64, offset: f64) {
        let n = shape.iter().product();
        let v = (0..n)
            .map(|_| (offset + scale * (self.rng.next() - 0.5)) as f32)
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
        self.put(format!("{name}.weight"), vec![c], 0.4, 1.0);
        self.put(format!("{name}.bias"), vec![c], 0.2, 0.0);
        self.put(format!("{name}.running_mean"), vec![c], 0.4, 0.1);
        self.put(format!("{name}.running_var"), vec![c], 0.5, 1.2);
    }
}

/// torchvision ResNet-18 tensors, random, with its classifier.
fn resnet18_file(rng: &mut Rng) -> BTreeMap<String, (Vec<usize>, Vec<f32>)> {
    let mut f = Fixture {
        tensors: BTreeMap::new(),
        rng,
    };
    f.conv("conv1", 64, 3, 7);
    f.bn("bn1", 64);
    let mut inputs = 64;
    for stage in 0..4 {
        let width = 64 << stage;
        for b in 0..2 {
            let p = format!("layer{}.{b}", stage + 1);
            f.conv(
                &format!("{p}.conv1"),
                width,
                if b == 0 { inputs } else { width },
                3,
            );
            f.bn(&format!("{p}.bn1"), width);
            f.conv(&format!("{p}.conv2"), width, width, 3);
            f.bn(&format!("{p}.bn2"), width);
            if b == 0 && stage > 0 {
                f.conv(&format!("{p}.downsample.0"), width, inputs, 1);
                f.bn(&format!("{p}.downsample.1"), width);
            }
        }
        inputs = width;
    }
    f.put("fc.weight".into(), vec![10, 512], 0.1, 0.0);
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
    for stage in 0..4 {
        for b in 0..2 {
            let p = format!("layer{}.{b}", stage + 1);
            let stride = if b == 0 && stage > 0 { 2 } else { 1 };
            let mut y = conv_ref(&x, &t[&format!("{p}.conv1.weight")], stride);
            bn_ref(&mut y, t, &format!("{p}.bn1"), true);
            let mut y = conv_ref(&y, &t[&format!("{p}.conv2.weight")], 1);
            bn_ref(&mut y, t, &format!("{p}.bn2"), false);
            let identity = if t.contains_key(&format!("{p}.downsample.0.weight")) {
                let mut d = conv_ref(&x, &t[&format!("{p}.downsample.0.weight")], stride);
                bn_ref(&mut d, t, &format!("{p}.downsample.1"), false);
                d
            } else {
                x.clone()
            };
            for (v, i) in y.0.iter_mut().zip(&identity.0) {
                *v = (*v + i).max(0.0);
            }
            x = y;
        }
        stages.push(x.clone());
    }
    stages
}

#[test]
fn torchvision_resnet18_weights_load_and_match_the_f64_definition() {
    let device = Device::flex();
    let dir = tempfile::tempdir().unwrap();
    let mut rng = Rng(7);
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
    let pixels: Vec<f64> = (0..3 * h * w).map(|_| rng.next()).collect();
    let input = Tensor::<4>::from_data(
        TensorData::new(
            pixels.iter().map(|&v| v as f32).collect::<Vec<_>>(),
            [1, 3, h, w],
        ),
        &device,
    );
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
