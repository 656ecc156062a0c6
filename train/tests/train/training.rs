//! The training machinery beyond single losses: configuration files and overrides, checkpoint
//! files and their errors, bit-exact resume, density control (ADC and MCMC), scene graphs,
//! and LPIPS against a scalar f64 implementation of its definition.

use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_datasets::synth::rng::Rng;
use splatzoo_rasterizer::{Camera, ColorMode, RasterSettings, rasterize};
use splatzoo_train::checkpoint::Checkpoint;
use splatzoo_train::config;
use splatzoo_train::densify::{
    DensifyConfig, DensityStats, Strategy, adaptive_density_control, mcmc_relocate, relocation,
};
use splatzoo_train::gaussians::GaussianSet;
use splatzoo_train::harness::Method;
use splatzoo_train::lpips::{Backbone, Lpips};
use splatzoo_train::optimizer::{GaussianOptimizer, LearningRates};
use splatzoo_train::scene::{FrameContext, FrameQuery, NodeOutput, SceneGraph, SceneNode};
use splatzoo_train::static_scene::{StaticConfig, StaticTrainer};

fn random_set(n: usize, rng: &mut Rng, device: &Device) -> GaussianSet {
    let positions: Vec<[f32; 3]> = (0..n)
        .map(|_| {
            [
                rng.range(-1.0, 1.0) as f32,
                rng.range(-1.0, 1.0) as f32,
                rng.range(-1.0, 1.0) as f32,
            ]
        })
        .collect();
    let colours: Vec<[f32; 3]> = (0..n)
        .map(|_| [rng.next() as f32, rng.next() as f32, rng.next() as f32])
        .collect();
    let sigmas: Vec<f32> = (0..n).map(|_| rng.range(0.02, 0.2) as f32).collect();
    let mut set = GaussianSet::from_points(&positions, &colours, &sigmas, device);
    let logits: Vec<f32> = (0..n).map(|_| rng.range(-3.0, 3.0) as f32).collect();
    set.opacity_logits = Tensor::from_data(TensorData::new(logits, [n]), device);
    let quats: Vec<f32> = (0..4 * n).map(|_| rng.normal() as f32).collect();
    set.quats = Tensor::from_data(TensorData::new(quats, [n, 4]), device);
    set
}

use splatzoo_train::host_f32 as host;

#[test]
fn configuration_files_and_overrides_layer_over_the_defaults() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("run.toml");
    std::fs::write(&file, "iterations = 77\n[densify]\nstrategy = \"mcmc\"\n").unwrap();
    let sets = [
        "densify.grad_threshold=0.0004".to_string(),
        "data.path=some/folder".to_string(),
    ];
    let c: StaticConfig = config::load(&StaticConfig::default(), Some(&file), &sets).unwrap();
    assert_eq!(c.iterations, 77);
    assert_eq!(c.densify.strategy, Strategy::Mcmc);
    assert_eq!(c.densify.grad_threshold, 0.0004);
    assert_eq!(
        c.data.path.as_deref(),
        Some(std::path::Path::new("some/folder"))
    );
    // Untouched keys keep their defaults, and the TOML text reads back to the same value.
    assert_eq!(c.rates, LearningRates::default());
    let again: StaticConfig = toml::from_str(&config::to_toml(&c)).unwrap();
    assert_eq!(again, c);
    // Unknown keys, wrong types and malformed arguments are refused, naming what was wrong.
    std::fs::write(&file, "[densify]\ngrad_treshold = 1\n").unwrap();
    let e = config::load::<StaticConfig>(&StaticConfig::default(), Some(&file), &[])
        .unwrap_err()
        .to_string();
    assert!(e.contains("grad_treshold") && e.contains("run.toml"), "{e}");
    let e = config::load::<StaticConfig>(
        &StaticConfig::default(),
        None,
        &["iterations=\"many\"".into()],
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("iterations"), "{e}");
    let e = config::load::<StaticConfig>(&StaticConfig::default(), None, &["iterations".into()])
        .unwrap_err()
        .to_string();
    assert!(e.contains("key=value"), "{e}");
}

#[test]
fn checkpoints_round_trip_exactly_and_bad_files_are_named() {
    let device = Device::flex();
    let dir = tempfile::tempdir().unwrap();
    let set = random_set(40, &mut Rng(1), &device);
    let mut c = Checkpoint::default();
    set.save(&mut c, "splats");
    c.put_meta("step", 12);
    let path = dir.path().join("c.safetensors");
    c.write(&path).unwrap();
    let back = Checkpoint::read(&path).unwrap();
    assert_eq!(back.tensors, c.tensors);
    assert_eq!(back.meta_parsed::<usize>("step").unwrap(), 12);
    let loaded = GaussianSet::load(&back, "splats", &device).unwrap();
    assert_eq!(loaded.to_rows(), set.to_rows());
    // No temporary file is left beside it.
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    // Truncated file.
    let bytes = std::fs::read(&path).unwrap();
    std::fs::write(&path, &bytes[..bytes.len() / 2]).unwrap();
    let e = Checkpoint::read(&path).unwrap_err().to_string();
    assert!(e.contains("c.safetensors"), "{e}");
    // Wrong shape: the tensor, its shape and the expected one are named.
    let mut wrong = c.clone();
    wrong.tensors.get_mut("splats.quats").unwrap().0 = vec![40, 2, 2];
    let e = GaussianSet::load(&wrong, "splats", &device)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("splats.quats") && e.contains("[40, 2, 2]") && e.contains("[40, 4]"),
        "{e}"
    );
    // NaN is refused, not loaded.
    let mut nan = c.clone();
    nan.tensors.get_mut("splats.means").unwrap().1[5] = f32::NAN;
    let e = GaussianSet::load(&nan, "splats", &device)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("splats.means") && e.contains("non-finite"),
        "{e}"
    );
}

fn small_config(strategy: Strategy) -> StaticConfig {
    let mut c = StaticConfig {
        iterations: 40,
        sh_degree_every: 10,
        ..Default::default()
    };
    c.data.size = 24;
    c.data.init_stride = 3;
    c.densify.strategy = strategy;
    c.densify.start = 4;
    c.densify.every = 8;
    c.densify.stop = 36;
    c.densify.opacity_reset_every = 24;
    c.densify.grad_threshold = 0.00005;
    c
}

#[test]
fn a_resumed_run_continues_bit_exactly() {
    let device = Device::flex();
    let dir = tempfile::tempdir().unwrap();
    for strategy in [Strategy::Adc, Strategy::Mcmc] {
        let config = small_config(strategy);
        let mut straight = StaticTrainer::new(config.clone(), &device).unwrap();
        let initial = straight.graph.gaussians();
        let mut densified = false;
        for _ in 0..config.iterations {
            densified |= straight.step().unwrap().note.is_some();
        }
        assert!(densified, "{strategy:?}: density control ran");
        assert_ne!(
            straight.graph.gaussians(),
            initial,
            "{strategy:?}: the count changed"
        );
        let mut first = StaticTrainer::new(config.clone(), &device).unwrap();
        for _ in 0..config.iterations / 2 + 3 {
            first.step().unwrap();
        }
        let path = dir.path().join("resume.safetensors");
        splatzoo_train::harness::full_checkpoint(&first, &config, &Default::default())
            .write(&path)
            .unwrap();
        drop(first);
        let saved = Checkpoint::read(&path).unwrap();
        let restored = splatzoo_train::harness::checkpoint_config::<StaticTrainer>(&saved).unwrap();
        assert_eq!(restored, config);
        let mut second = StaticTrainer::resume(restored, &saved, &device).unwrap();
        while second.step < config.iterations {
            second.step().unwrap();
        }
        assert_eq!(
            second.gaussian_set().to_rows(),
            straight.gaussian_set().to_rows(),
            "{strategy:?}"
        );
    }
}

/// A set whose statistics make row 0 clone (small, high gradient), row 1 split (large, high
/// gradient), row 2 vanish (transparent), and row 3 stay.
#[test]
fn adaptive_density_control_clones_splits_and_prunes_with_the_optimiser_state() {
    let device = Device::flex();
    let positions = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
    ];
    let colours = [[0.5; 3]; 4];
    let sigmas = [0.001, 0.3, 0.01, 0.01];
    let mut set = GaussianSet::from_points(&positions, &colours, &sigmas, &device);
    set.opacity_logits = Tensor::from_floats([0.0, 0.0, -8.0, 0.0], &device);
    let mut optimizer = GaussianOptimizer::new(&set, LearningRates::default(), 1.0);
    // Give every row a moment so that kept rows can be told from new ones.
    let leaves = set.leaves();
    let grads = (leaves.means.clone().sum()
        + leaves.opacity_logits.clone().sum()
        + leaves.quats.clone().sum()
        + leaves.log_scales.clone().sum()
        + leaves.sh_dc.clone().sum()
        + leaves.sh_rest.clone().sum())
    .backward();
    let mut stepped = set.clone();
    optimizer.step(&mut stepped, &leaves, &grads, 0.0);
    let mut stats = DensityStats::new(4, &device);
    stats.grad_sum = Tensor::from_floats([0.003, 0.003, 0.003, 0.00001], &device);
    stats.count = Tensor::from_floats([2.0, 2.0, 2.0, 2.0], &device);
    let config = DensifyConfig::default();
    let mut rng = Rng(5);
    let mut old_from_new = Vec::new();
    let report = adaptive_density_control(
        &config,
        &mut set,
        &mut optimizer,
        &mut stats,
        1.0,
        false,
        &mut rng,
        &mut old_from_new,
    );
    assert_eq!(
        (report.cloned, report.split, report.pruned),
        (1, 1, 1),
        "{report:?}"
    );
    // Kept: rows 0 and 3; added: the clone of 0, then two children of 1.
    assert_eq!(set.len(), 5);
    assert_eq!(old_from_new, [0, 3, 0, 1, 1], "the lineage of every row");
    let rows = set.to_rows();
    assert_eq!(rows.mean(0), [0.0, 0.0, 0.0]);
    assert_eq!(rows.mean(1), [0.0, 0.0, 1.0]);
    assert_eq!(rows.mean(2), [0.0, 0.0, 0.0]);
    for child in [3, 4] {
        let d: f32 = (0..3)
            .map(|k| (rows.mean(child)[k] - [1.0, 0.0, 0.0][k]).powi(2))
            .sum::<f32>()
            .sqrt();
        assert!(d < 5.0 * 0.3, "child {child} at distance {d}");
        for s in rows.scale(child) {
            assert!((s - 0.3 / 1.6).abs() < 1e-5, "child scale {s}");
        }
    }
    assert_eq!(host(&stats.count), vec![0.0; 5], "statistics restart");
    // The optimiser follows: kept rows keep their moments, new rows start at zero. Its state
    // is visible through a checkpoint.
    let mut c = Checkpoint::default();
    optimizer.save(&mut c, "o");
    let moments = &c.tensors["o.means.exp_avg"].1;
    assert!(moments[..6].iter().all(|&m| m != 0.0), "{moments:?}");
    assert!(moments[6..].iter().all(|&m| m == 0.0), "{moments:?}");
}

#[test]
fn mcmc_relocation_preserves_opacity_and_moves_every_dead_gaussian() {
    // Eq. 9 of 3DGS-MCMC: one copy changes nothing; N copies composite to the original opacity.
    for o in [0.005, 0.1, 0.5, 0.9, 0.999] {
        let (same, factor) = relocation(o, 1);
        assert!(
            (same - o).abs() < 1e-12 && (factor - 1.0).abs() < 1e-9,
            "{o}: {same} {factor}"
        );
        for n in [2, 5, 17, 51] {
            let (each, factor) = relocation(o, n);
            let composite = 1.0 - (1.0 - each).powi(n as i32);
            assert!((composite - o).abs() < 1e-6, "o {o}, N {n}: {composite}");
            assert!(
                factor.is_finite() && factor > 0.0,
                "o {o}, N {n}: factor {factor}"
            );
        }
    }
    let device = Device::flex();
    let mut set = random_set(200, &mut Rng(8), &device);
    let mut logits = host(&set.opacity_logits);
    for l in logits.iter_mut().take(30) {
        *l = -9.0; // dead
    }
    set.opacity_logits = Tensor::from_data(TensorData::new(logits, [200]), &device);
    let mut optimizer = GaussianOptimizer::new(&set, LearningRates::default(), 1.0);
    let config = DensifyConfig {
        strategy: Strategy::Mcmc,
        max_gaussians: 205,
        ..Default::default()
    };
    let mut old_from_new = Vec::new();
    let report = mcmc_relocate(
        &config,
        &mut set,
        &mut optimizer,
        &mut Rng(9),
        &mut old_from_new,
    );
    assert_eq!((report.relocated, report.added), (30, 5));
    assert_eq!(old_from_new.len(), 205);
    let lineage_rows = set.to_rows();
    for (new, &old) in old_from_new.iter().enumerate() {
        assert!(old < 200, "row {new} from {old}");
        if (30..200).contains(&new) {
            assert_eq!(old, new, "a live row stays itself");
        } else {
            assert!(old >= 30, "row {new} copies a live row, not dead {old}");
            assert_eq!(
                lineage_rows.mean(new),
                lineage_rows.mean(old),
                "row {new} sits on {old}"
            );
        }
    }
    assert_eq!(set.len(), 205, "growth stops at the cap");
    let rows = set.to_rows();
    assert!(
        (0..205).all(|i| rows.opacity(i) as f64 > config.min_opacity),
        "no dead Gaussian left"
    );
    // Each relocated Gaussian sits exactly on a live one.
    for d in 0..30 {
        assert!(
            (30..200).any(|s| rows.mean(s) == rows.mean(d)),
            "row {d} moved onto a source"
        );
    }
}

fn camera(size: u32) -> Camera {
    Camera::look_at(
        [0.3, 0.4, -3.0],
        [0.0; 3],
        [0.0, 1.0, 0.0],
        60.0,
        size,
        size,
    )
}

/// A node that renders a fixed set.
struct Fixed(&'static str, GaussianSet);

impl SceneNode for Fixed {
    fn name(&self) -> &str {
        self.0
    }
    fn gaussians(&self) -> usize {
        self.1.len()
    }
    fn render(&self, _: &FrameQuery, _: &FrameContext) -> NodeOutput {
        NodeOutput::splats(self.1.splats())
    }
}

#[test]
fn a_scene_graph_renders_its_nodes_as_one_set() {
    let device = Device::flex();
    let mut rng = Rng(11);
    let a = random_set(60, &mut rng, &device);
    let mut b = random_set(40, &mut rng, &device);
    b.sh_rest = Tensor::from_data(
        TensorData::new(
            (0..40 * 45)
                .map(|_| rng.range(-0.3, 0.3) as f32)
                .collect::<Vec<_>>(),
            [40, 15, 3],
        ),
        &device,
    );
    let cam = camera(32);
    let settings = RasterSettings::new(cam, ColorMode::Sh { degree: 3 });
    let background = Tensor::<1>::from_floats([0.1, 0.2, 0.3], &device);
    let graph = SceneGraph::new()
        .with(Fixed("a", a.clone()))
        .with(Fixed("b", b.clone()));
    let query = FrameQuery {
        camera: &cam,
        frame: 0,
        time: 0.0,
    };
    let out = graph.render(&query, background.clone(), &settings).unwrap();
    assert_eq!(out.rows, vec![0..60, 60..100]);
    let whole = rasterize(&a.append(&b).splats(), background.clone(), &settings).unwrap();
    assert_eq!(host(&out.render.color), host(&whole.color));
    // A DC-only node is padded with zero coefficients: same image as its degree-3 form with
    // zero rest coefficients.
    struct DcOnly(GaussianSet);
    impl SceneNode for DcOnly {
        fn name(&self) -> &str {
            "dc"
        }
        fn gaussians(&self) -> usize {
            self.0.len()
        }
        fn render(&self, _: &FrameQuery, _: &FrameContext) -> NodeOutput {
            let mut s = self.0.splats();
            s.colors = self.0.sh_dc.clone();
            NodeOutput::splats(s)
        }
    }
    let graph = SceneGraph::new()
        .with(DcOnly(a.clone()))
        .with(Fixed("b", b.clone()));
    let padded = graph.render(&query, background.clone(), &settings).unwrap();
    let mut plain_a = a.clone();
    plain_a.sh_rest = plain_a.sh_rest.zeros_like();
    let reference = rasterize(&plain_a.append(&b).splats(), background, &settings).unwrap();
    assert_eq!(host(&padded.render.color), host(&reference.color));
}

// ---- LPIPS against a scalar f64 implementation of its definition ----

struct Conv {
    weight: Vec<f64>,
    bias: Vec<f64>,
    out: usize,
    inp: usize,
    k: usize,
}

/// `[C, H, W]` feature maps in f64.
type Map = (Vec<f64>, usize, usize, usize);

fn conv_ref(x: &Map, c: &Conv, stride: usize, pad: usize) -> Map {
    let (data, ch, h, w) = x;
    assert_eq!(*ch, c.inp);
    let oh = (h + 2 * pad - c.k) / stride + 1;
    let ow = (w + 2 * pad - c.k) / stride + 1;
    let mut out = vec![0.0; c.out * oh * ow];
    for o in 0..c.out {
        for y in 0..oh {
            for x0 in 0..ow {
                let mut acc = c.bias[o];
                for i in 0..c.inp {
                    for ky in 0..c.k {
                        for kx in 0..c.k {
                            let (iy, ix) = (
                                (y * stride + ky) as i64 - pad as i64,
                                (x0 * stride + kx) as i64 - pad as i64,
                            );
                            if iy >= 0 && ix >= 0 && (iy as usize) < *h && (ix as usize) < *w {
                                acc += c.weight[((o * c.inp + i) * c.k + ky) * c.k + kx]
                                    * data[(i * h + iy as usize) * w + ix as usize];
                            }
                        }
                    }
                }
                out[(o * oh + y) * ow + x0] = acc.max(0.0); // ReLU follows every conv
            }
        }
    }
    (out, c.out, oh, ow)
}

fn pool_ref(x: &Map, k: usize) -> Map {
    let (data, ch, h, w) = x;
    let (oh, ow) = ((h - k) / 2 + 1, (w - k) / 2 + 1);
    let mut out = vec![f64::NEG_INFINITY; ch * oh * ow];
    for c in 0..*ch {
        for y in 0..oh {
            for x0 in 0..ow {
                for ky in 0..k {
                    for kx in 0..k {
                        let v = data[(c * h + 2 * y + ky) * w + 2 * x0 + kx];
                        let o = &mut out[(c * oh + y) * ow + x0];
                        *o = o.max(v);
                    }
                }
            }
        }
    }
    (out, *ch, oh, ow)
}

fn lpips_ref(a: &[f64], b: &[f64], size: usize, convs: &[Conv], heads: &[Vec<f64>]) -> f64 {
    let prepare = |img: &[f64]| -> Map {
        let shift = [-0.030, -0.088, -0.188];
        let scale = [0.458, 0.448, 0.450];
        let mut out = vec![0.0; 3 * size * size];
        for c in 0..3 {
            for p in 0..size * size {
                out[c * size * size + p] = ((img[3 * p + c] * 2.0 - 1.0) - shift[c]) / scale[c];
            }
        }
        (out, 3, size, size)
    };
    let taps = |img: &[f64]| -> Vec<Map> {
        let x0 = prepare(img);
        let t1 = conv_ref(&x0, &convs[0], 4, 2);
        let t2 = conv_ref(&pool_ref(&t1, 3), &convs[1], 1, 2);
        let t3 = conv_ref(&pool_ref(&t2, 3), &convs[2], 1, 1);
        let t4 = conv_ref(&t3, &convs[3], 1, 1);
        let t5 = conv_ref(&t4, &convs[4], 1, 1);
        vec![t1, t2, t3, t4, t5]
    };
    let (fa, fb) = (taps(a), taps(b));
    let mut total = 0.0;
    for ((ma, mb), head) in fa.iter().zip(&fb).zip(heads) {
        let (c, h, w) = (ma.1, ma.2, ma.3);
        let mut layer = 0.0;
        for p in 0..h * w {
            let na = (0..c)
                .map(|k| ma.0[k * h * w + p].powi(2))
                .sum::<f64>()
                .sqrt()
                + 1e-10;
            let nb = (0..c)
                .map(|k| mb.0[k * h * w + p].powi(2))
                .sum::<f64>()
                .sqrt()
                + 1e-10;
            layer += (0..c)
                .map(|k| head[k] * (ma.0[k * h * w + p] / na - mb.0[k * h * w + p] / nb).powi(2))
                .sum::<f64>();
        }
        total += layer / (h * w) as f64;
    }
    total
}

#[test]
fn lpips_matches_its_definition_on_random_alexnet_weights() {
    let device = Device::flex();
    let dir = tempfile::tempdir().unwrap();
    let mut rng = Rng(21);
    // AlexNet's layout (torchvision indices, kernel sizes) with fewer channels, for speed.
    let shapes = [
        (0, 8, 3, 11),
        (3, 12, 8, 5),
        (6, 16, 12, 3),
        (8, 10, 16, 3),
        (10, 10, 10, 3),
    ];
    let mut file = Checkpoint::default();
    let mut convs = Vec::new();
    for &(index, out, inp, k) in &shapes {
        let fan_in = (inp * k * k) as f64;
        let weight: Vec<f64> = (0..out * inp * k * k)
            .map(|_| rng.normal() * (2.0 / fan_in).sqrt())
            .collect();
        let bias: Vec<f64> = (0..out).map(|_| rng.range(-0.1, 0.1)).collect();
        let t4 = Tensor::<4>::from_data(
            TensorData::new(
                weight.iter().map(|&v| v as f32).collect::<Vec<_>>(),
                [out, inp, k, k],
            ),
            &device,
        );
        file.put(&format!("features.{index}.weight"), &t4);
        file.put(
            &format!("features.{index}.bias"),
            &Tensor::<1>::from_data(
                TensorData::new(bias.iter().map(|&v| v as f32).collect::<Vec<_>>(), [out]),
                &device,
            ),
        );
        // Compare in f64 with the f32-rounded weights the network uses.
        let round = |v: &[f64]| v.iter().map(|&x| x as f32 as f64).collect();
        convs.push(Conv {
            weight: round(&weight),
            bias: round(&bias),
            out,
            inp,
            k,
        });
    }
    let mut heads = Vec::new();
    for (k, c) in convs.iter().enumerate() {
        let head: Vec<f64> = (0..c.out)
            .map(|_| rng.range(0.0, 1.0) as f32 as f64)
            .collect();
        file.put(
            &format!("lin{k}.model.1.weight"),
            &Tensor::<4>::from_data(
                TensorData::new(
                    head.iter().map(|&v| v as f32).collect::<Vec<_>>(),
                    [1, c.out, 1, 1],
                ),
                &device,
            ),
        );
        heads.push(head);
    }
    let path = dir.path().join("alex.safetensors");
    file.write(&path).unwrap();
    let lpips = Lpips::load(&path, &device).unwrap();
    assert_eq!(lpips.backbone, Backbone::Alex);
    assert!(lpips.learned_heads);
    let size = 64;
    let a: Vec<f64> = (0..size * size * 3)
        .map(|_| rng.next() as f32 as f64)
        .collect();
    let b: Vec<f64> = a
        .iter()
        .map(|&v| (v + 0.2 * rng.normal()).clamp(0.0, 1.0) as f32 as f64)
        .collect();
    let t = |v: &[f64]| {
        Tensor::<3>::from_data(
            TensorData::new(
                v.iter().map(|&x| x as f32).collect::<Vec<_>>(),
                [size, size, 3],
            ),
            &device,
        )
    };
    let got = host(&lpips.distance(t(&a), t(&b)))[0] as f64;
    let want = lpips_ref(&a, &b, size, &convs, &heads);
    assert!(
        (got - want).abs() < 1e-4 * want.max(1e-3),
        "LPIPS {got} vs f64 {want}"
    );
    assert_eq!(host(&lpips.distance(t(&a), t(&a)))[0], 0.0);
    let back = host(&lpips.distance(t(&b), t(&a)))[0] as f64;
    assert!((back - got).abs() < 1e-6 * got.max(1.0), "symmetric");
    // More noise, larger distance.
    let c: Vec<f64> = a
        .iter()
        .map(|&v| (v + 0.5 * rng.normal()).clamp(0.0, 1.0))
        .collect();
    assert!(host(&lpips.distance(t(&a), t(&c)))[0] as f64 > got);
    // Without heads every channel weighs 1/C; a file that is neither backbone is refused.
    file.tensors.retain(|name, _| !name.starts_with("lin"));
    file.write(&path).unwrap();
    assert!(!Lpips::load(&path, &device).unwrap().learned_heads);
    file.tensors.remove("features.10.weight");
    file.write(&path).unwrap();
    let e = Lpips::load(&path, &device).err().unwrap().to_string();
    assert!(
        e.contains("alex.safetensors") && e.contains("AlexNet"),
        "{e}"
    );
}

/// The loop is backend-generic: a few steps on NdArray and on wgpu (lavapipe without a GPU)
/// give the same held-out image as on Flex, up to float rounding amplified by Adam.
#[test]
fn training_agrees_across_backends() {
    use splatzoo_train::backend::Backend;
    let config = |backend| {
        let mut c = StaticConfig {
            backend,
            iterations: 6,
            ..Default::default()
        };
        c.data.size = 24;
        c.densify.strategy = Strategy::None;
        c
    };
    let image = |backend: Backend| {
        let device = backend.device();
        let mut trainer = StaticTrainer::new(config(backend), &device).unwrap();
        for _ in 0..6 {
            trainer.step().unwrap();
        }
        host(&trainer.render_test(0).unwrap().color)
    };
    let reference = image(Backend::Flex);
    for backend in [Backend::Ndarray, Backend::Wgpu] {
        let other = image(backend);
        let mse = reference
            .iter()
            .zip(&other)
            .map(|(a, b)| ((a - b) as f64).powi(2))
            .sum::<f64>()
            / reference.len() as f64;
        let psnr = -10.0 * mse.max(1e-20).log10();
        assert!(psnr > 45.0, "{backend:?} vs flex: {psnr:.1} dB");
    }
}

/// Adam over a module's parameters against Adam written out in f64 for `loss = (w·x + b − y)²`
/// with its analytic gradients; and moments saved to a checkpoint and loaded into a rebuilt
/// module continue exactly.
#[test]
fn module_adam_follows_adam_and_resumes_from_a_checkpoint() {
    use burn::module::Module;
    use burn::nn::{Linear, LinearConfig};
    use splatzoo_models::networks::weights::{WeightFile, load_module, module_tensors};
    use splatzoo_train::module_adam::{ModuleAdam, NETWORK_ADAM};

    let device = Device::flex();
    let (x, y) = ([0.7f32, -1.3], 0.4f32);
    let lr = 0.05;
    let step = |adam: &mut ModuleAdam, model: Linear| {
        let input = Tensor::<2>::from_data(TensorData::new(x.to_vec(), [1, 2]), &device).autodiff();
        let loss = (model.forward(input) - y as f64).powi_scalar(2).sum();
        let grads = loss.backward();
        adam.step(model, &grads, lr)
    };
    let params = |model: &Linear| -> Vec<f64> {
        let t = module_tensors(model);
        let mut v: Vec<f64> = t["weight"].1.iter().map(|&a| a as f64).collect();
        v.push(t["bias"].1[0] as f64);
        v
    };
    let mut model = LinearConfig::new(2, 1).init(&device).train();
    let mut adam = ModuleAdam::new(NETWORK_ADAM);
    // The reference: w0, w1, b with their moments.
    let mut p = params(&model);
    let (mut m, mut v) = ([0.0f64; 3], [0.0f64; 3]);
    for t in 1..=3 {
        let residual = p[0] * x[0] as f64 + p[1] * x[1] as f64 + p[2] - y as f64;
        let g = [
            2.0 * residual * x[0] as f64,
            2.0 * residual * x[1] as f64,
            2.0 * residual,
        ];
        for k in 0..3 {
            m[k] = 0.9 * m[k] + 0.1 * g[k];
            v[k] = 0.999 * v[k] + 0.001 * g[k] * g[k];
            let mh = m[k] / (1.0 - 0.9f64.powi(t));
            let vh = v[k] / (1.0 - 0.999f64.powi(t));
            p[k] -= lr * mh / (vh.sqrt() + 1e-8);
        }
        model = step(&mut adam, model);
        let got = params(&model);
        for k in 0..3 {
            assert!(
                (got[k] - p[k]).abs() < 1e-5,
                "step {t}, parameter {k}: {} vs {}",
                got[k],
                p[k]
            );
        }
    }
    // Save after 3 steps, rebuild, load, step: the same as stepping on.
    let mut checkpoint = Checkpoint {
        tensors: module_tensors(&model),
        ..Default::default()
    };
    adam.save(&model, &mut checkpoint);
    let continued = step(&mut adam, model);
    let file = WeightFile::new("memory", checkpoint.tensors.clone());
    let rebuilt = load_module(LinearConfig::new(2, 1).init(&device), &file)
        .unwrap()
        .train();
    let mut loaded = ModuleAdam::load(NETWORK_ADAM, &rebuilt, &checkpoint).unwrap();
    let resumed = step(&mut loaded, rebuilt);
    assert_eq!(module_tensors(&continued), module_tensors(&resumed));
    // A moment of the wrong shape is named.
    checkpoint
        .tensors
        .insert("optimizer.weight.exp_avg".into(), (vec![3], vec![0.0; 3]));
    let error = ModuleAdam::load(NETWORK_ADAM, &continued, &checkpoint).unwrap_err();
    assert!(
        error.to_string().contains("optimizer.weight.exp_avg"),
        "{error}"
    );
}

/// Zero learning rates freeze a group exactly (no NaN from the log-linear position schedule),
/// and a group whose leaf got no gradient keeps its values.
#[test]
fn zero_rates_and_unused_groups_leave_values_bit_identical() {
    let device = Device::flex();
    let mut rng = Rng(11);
    let set = random_set(16, &mut rng, &device);
    let frozen = LearningRates {
        means_start: 0.0,
        means_end: 0.0,
        quats: 0.0,
        log_scales: 0.0,
        opacity: 0.0,
        ..LearningRates::default()
    };
    let mut optimizer = GaussianOptimizer::new(&set, frozen, 2.0);
    assert_eq!(optimizer.means_rate(0.0), 0.0);
    assert_eq!(optimizer.means_rate(0.7), 0.0);
    let mut stepped = set.clone();
    for _ in 0..3 {
        let leaves = stepped.leaves();
        // Opacity unused: its leaf gets no gradient.
        let grads = (leaves.means.clone().sum()
            + leaves.quats.clone().sum()
            + leaves.log_scales.clone().sum()
            + leaves.sh_dc.clone().sum()
            + leaves.sh_rest.clone().sum())
        .backward();
        optimizer.step(&mut stepped, &leaves, &grads, 0.5);
    }
    let bits = |t: &Tensor<2>| t.clone().into_data().try_to_vec::<f32>().unwrap();
    assert_eq!(bits(&stepped.means), bits(&set.means));
    assert_eq!(bits(&stepped.quats), bits(&set.quats));
    assert_eq!(bits(&stepped.log_scales), bits(&set.log_scales));
    let opacity = |t: &Tensor<1>| t.clone().into_data().try_to_vec::<f32>().unwrap();
    assert_eq!(
        opacity(&stepped.opacity_logits),
        opacity(&set.opacity_logits)
    );
    let dc = |t: &Tensor<3>| t.clone().into_data().try_to_vec::<f32>().unwrap();
    assert_ne!(dc(&stepped.sh_dc), dc(&set.sh_dc), "colours still learn");
}
