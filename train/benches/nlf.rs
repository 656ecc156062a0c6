//! NLF-GS speed: generation (three 256² input views → avatar: encoder, anchored query, fusion,
//! decoder) and driving (avatar + a new SMPL pose → a 256² image: skinning, re-anchoring,
//! rasterization) per backend, with Gaussians and bytes per avatar. Weights are random: speed
//! does not depend on them.
//!
//! ```sh
//! cargo bench --workspace --bench nlf                       # ResNet-18, flex ndarray wgpu
//! cargo bench --workspace --bench nlf -- 50 flex            # ResNet-50 on Flex only
//! ```

use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_models::anchor::MeshAnchors;
use splatzoo_models::body::builtin_body;
use splatzoo_models::body::lbs::{BodyTensors, PoseInput, pose};
use splatzoo_models::networks::nlf::{NlfConfig, NlfGs, NlfInputs};
use splatzoo_models::networks::query::Views;
use splatzoo_models::networks::resnet::Depth;
use splatzoo_rasterizer::{Camera, ColorMode, RasterSettings, rasterize};
use splatzoo_train::backend::Backend;
use std::time::Instant;

const SIZE: usize = 256;
const REPEATS: usize = 5;

/// Three cameras 2.2 m from `target` at 0°, 120°, 240° around y (OpenCV axes).
fn ring(target: [f32; 3]) -> Vec<Camera> {
    (0..3)
        .map(|i| {
            let a = i as f32 * 2.0 * std::f32::consts::PI / 3.0;
            let eye = [
                target[0] + 2.2 * a.sin(),
                target[1],
                target[2] + 2.2 * a.cos(),
            ];
            Camera::look_at(eye, target, [0.0, 1.0, 0.0], 45.0, SIZE as u32, SIZE as u32)
        })
        .collect()
}

fn views(cameras: &[Camera], device: &Device) -> (Views, Tensor<2>) {
    let k: Vec<f32> = cameras
        .iter()
        .flat_map(|c| [c.fx, c.fy, c.cx, c.cy])
        .collect();
    let m: Vec<f32> = cameras
        .iter()
        .flat_map(|c| c.world_to_camera.concat())
        .collect();
    let centres: Vec<f32> = cameras.iter().flat_map(|c| c.position()).collect();
    let n = cameras.len();
    (
        Views {
            intrinsics: Tensor::from_data(TensorData::new(k, [n, 4]), device),
            world_to_camera: Tensor::from_data(TensorData::new(m, [n, 3, 4]), device),
            size: [SIZE, SIZE],
        },
        Tensor::from_data(TensorData::new(centres, [n, 3]), device),
    )
}

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
    let n = body.template.len() / 3;
    let centre: [f32; 3] =
        std::array::from_fn(|k| (0..n).map(|i| body.template[3 * i + k]).sum::<f32>() / n as f32);
    let cameras = ring(centre);
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
        let vertices =
            Tensor::<3>::from_data(TensorData::new(body.template.clone(), [1, n, 3]), &device);
        let (views, centres) = views(&cameras, &device);
        let pixels: Vec<f32> = (0..3 * 3 * SIZE * SIZE)
            .map(|i| ((i * 7919) % 1000) as f32 / 1000.0)
            .collect();
        let images = Tensor::<4>::from_data(TensorData::new(pixels, [3, 3, SIZE, SIZE]), &device);
        let inputs = NlfInputs {
            images,
            views,
            camera_centres: centres,
            vertices,
            faces: &faces,
            anchors: &anchors,
            depth: None,
        };
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
            let splats = splatzoo_train::nlf_data::posed_splats(posed);
            let render = rasterize(
                &splats,
                background.clone(),
                &RasterSettings::new(cameras[0], ColorMode::Sh { degree: 0 }),
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
