//! NLF-GS speed: generation (three 256² input views → avatar: encoder, anchored query, fusion,
//! decoder) and driving (avatar + a new SMPL pose → a 256² image: skinning, re-anchoring,
//! rasterization) per backend, with Gaussians and bytes per avatar. Weights are random: speed
//! does not depend on them. The inputs are a synthetic identity's three views with its body
//! depth maps, so the full fusion runs its occlusion test; rendering those depth maps (the CPU
//! mesh renderer's job, before generation) is not timed.
//!
//! ```sh
//! cargo bench --workspace --bench nlf                       # ResNet-18, flex ndarray wgpu
//! cargo bench --workspace --bench nlf -- 50 flex            # ResNet-50 on Flex only
//! ```

use burn::tensor::{Tensor, TensorData};
use splatzoo_models::anchor::MeshAnchors;
use splatzoo_models::body::builtin_body;
use splatzoo_models::body::lbs::{BodyTensors, PoseInput, pose};
use splatzoo_models::networks::resnet::Depth;
use splatzoo_nlf_gs::data::NlfSubject;
use splatzoo_nlf_gs::network::{NlfConfig, NlfGs};
use splatzoo_rasterizer::{ColorMode, RasterSettings, rasterize};
use splatzoo_train::backend::Backend;
use std::time::Instant;

const SIZE: usize = 256;
const REPEATS: usize = 5;

fn sync(t: Tensor<2>) {
    let _ = t.slice([0..1, 0..1]).into_data();
}

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .collect();
    let depth = if args.iter().any(|a| a == "50") {
        Depth::R50
    } else if args.iter().any(|a| a == "34") {
        Depth::R34
    } else {
        Depth::R18
    };
    let chosen: Vec<Backend> = Backend::ALL
        .into_iter()
        .filter(|b| {
            !args
                .iter()
                .any(|a| Backend::ALL.iter().any(|x| x.name() == a))
                || args.iter().any(|a| a == b.name())
        })
        .collect();
    let body = &builtin_body().model;
    let faces = body.faces.clone();
    let config = NlfConfig {
        depth,
        ..Default::default()
    };
    let anchors = MeshAnchors::per_face(faces.len() / 3, config.gaussians_per_face);
    let g = anchors.len();
    println!(
        "NLF-GS, ResNet-{:?} FPN ({} channels/level), {} Gaussians ({} per face); 3 × {SIZE}² inputs, {SIZE}² renders; median of {REPEATS}",
        depth, config.fpn_channels, g, config.gaussians_per_face
    );
    println!(
        "| backend | generation (images → avatar) | driving (avatar + pose → image) | Gaussians | bytes per avatar |"
    );
    println!("|---|---|---|---|---|");
    for backend in chosen {
        let device = backend.device();
        let model = NlfGs::new(&config, &device);
        let tensors = BodyTensors::new(body, &device);
        let subject = NlfSubject::synthetic(10_000, SIZE as u32, &device);
        let inputs = subject.nlf_inputs(&faces, &anchors);
        let mut times = Vec::new();
        let mut avatar = None;
        for _ in 0..REPEATS + 1 {
            let start = Instant::now();
            let a = model.generate(&inputs, config.fusion, config.occlusion_tolerance);
            sync(a.attributes.rgb.clone());
            times.push(start.elapsed().as_secs_f64());
            avatar = Some(a);
        }
        times.remove(0); // warm-up
        times.sort_by(f64::total_cmp);
        let generation = times[times.len() / 2];
        let avatar = avatar.expect("generated");
        let background = Tensor::<1>::from_floats([1.0, 1.0, 1.0], &device);
        let mut times = Vec::new();
        for frame in 0..REPEATS + 1 {
            let start = Instant::now();
            let mut angles = vec![0.0f32; 72];
            angles[3 * 16 + 2] = -0.6 - 0.1 * frame as f32; // left shoulder
            angles[3 * 17 + 2] = 0.6; // right shoulder
            angles[3] = 0.3; // left hip (joint 1)
            let input = PoseInput::from_axis_angle(
                Tensor::zeros([1, 10], &device),
                Tensor::from_data(TensorData::new(angles, [1, 72]), &device),
                Tensor::zeros([1, 3], &device),
            );
            let posed = avatar.drive(pose(&tensors, &input).vertices, &faces, &anchors);
            let splats = splatzoo_nlf_gs::data::posed_splats(posed);
            let render = rasterize(
                &splats,
                background.clone(),
                &RasterSettings::new(subject.inputs[0].camera, ColorMode::Sh { degree: 0 }),
            )
            .expect("valid render");
            sync(render.alpha);
            times.push(start.elapsed().as_secs_f64());
        }
        times.remove(0);
        times.sort_by(f64::total_cmp);
        let driving = times[times.len() / 2];
        println!(
            "| {} | {:.2} fps ({:.0} ms) | {:.1} fps ({:.0} ms) | {g} | {:.1} MB |",
            backend.name(),
            1.0 / generation,
            generation * 1e3,
            1.0 / driving,
            driving * 1e3,
            (g * 14 * 4) as f64 / 1e6
        );
    }
}
