//! The NLF-GS generator end to end on a small mesh: shapes, driving (a moved mesh moves and turns
//! the Gaussians with it), fusion variants, and gradients reaching the input images through the
//! encoder.

use burn::module::Module;
use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_models::anchor::MeshAnchors;
use splatzoo_nlf_gs::network::{NlfConfig, NlfGs, NlfInputs};
use splatzoo_nlf_gs::query::{Fusion, Views};

fn host<const D: usize>(t: Tensor<D>) -> Vec<f32> {
    t.into_data()
        .convert::<f32>()
        .try_into_vec::<f32>()
        .unwrap()
}

/// An octahedron of radius 0.5 at the origin (outward winding).
fn octahedron() -> (Vec<f32>, Vec<u32>) {
    let v = vec![
        0.5, 0.0, 0.0, -0.5, 0.0, 0.0, 0.0, 0.5, 0.0, 0.0, -0.5, 0.0, 0.0, 0.0, 0.5, 0.0, 0.0, -0.5,
    ];
    let f = vec![
        0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5,
    ];
    (v, f)
}

/// Three cameras 2 m away at 0°, 120°, 240° around y, looking at the origin.
fn ring(device: &Device) -> (Views, Tensor<2>) {
    let (mut k, mut m, mut c) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..3 {
        let a = (i as f32) * 2.0 * std::f32::consts::PI / 3.0;
        let centre = [2.0 * a.sin(), 0.0, -2.0 * a.cos()];
        // Forward = −centre / 2, right = up × … (OpenCV, y down).
        let f = [-a.sin(), 0.0, a.cos()];
        let r = [a.cos(), 0.0, a.sin()];
        let d = [0.0, 1.0, 0.0];
        for row in [r, d, f] {
            m.extend(row);
            m.push(-(0..3).map(|j| row[j] * centre[j]).sum::<f32>());
        }
        k.extend([40.0, 40.0, 16.0, 16.0]);
        c.extend(centre);
    }
    let views = Views {
        intrinsics: Tensor::from_data(TensorData::new(k, [3, 4]), device),
        world_to_camera: Tensor::from_data(TensorData::new(m, [3, 3, 4]), device),
        size: [32, 32],
    };
    (views, Tensor::from_data(TensorData::new(c, [3, 3]), device))
}

#[test]
fn the_generator_makes_a_drivable_avatar() {
    let device = Device::flex();
    let config = NlfConfig {
        fpn_channels: 8,
        hidden: vec![16],
        ..Default::default()
    };
    let model = NlfGs::new(&config, &device);
    let (v, faces) = octahedron();
    let anchors = MeshAnchors::per_face(faces.len() / 3, config.gaussians_per_face);
    let vertices = Tensor::<3>::from_data(TensorData::new(v.clone(), [1, 6, 3]), &device);
    let (views, centres) = ring(&device);
    let pixels: Vec<f32> = (0..3 * 3 * 32 * 32)
        .map(|i| ((i * 37) % 101) as f32 / 100.0)
        .collect();
    let images = Tensor::<4>::from_data(TensorData::new(pixels, [3, 3, 32, 32]), &device);
    let inputs = NlfInputs {
        images: images.clone(),
        views: views.clone(),
        camera_centres: centres.clone(),
        vertices: vertices.clone(),
        faces: &faces,
        anchors: &anchors,
        depth: None,
    };
    let avatar = model.generate(&inputs, Fusion::Orientation, 0.02);
    let g = 8 * 4;
    let posed = avatar.drive(vertices.clone(), &faces, &anchors);
    assert_eq!(posed.means.dims(), [g, 3]);
    assert_eq!(posed.sh_dc.dims(), [g, 1, 3]);
    assert!(
        host(posed.means.clone())
            .iter()
            .all(|x| x.is_finite() && x.abs() < 0.6)
    );
    // Driving follows the mesh: translated and turned 90° about y, the Gaussians move the same.
    let turned: Vec<f32> = v
        .chunks(3)
        .flat_map(|p| [p[2] + 1.0, p[1] - 0.5, -p[0] + 2.0])
        .collect();
    let moved = avatar.drive(
        Tensor::from_data(TensorData::new(turned, [1, 6, 3]), &device),
        &faces,
        &anchors,
    );
    let (a, b) = (host(posed.means), host(moved.means));
    for (p, q) in a.chunks(3).zip(b.chunks(3)) {
        let want = [p[2] + 1.0, p[1] - 0.5, -p[0] + 2.0];
        assert!(
            (0..3).all(|k| (q[k] - want[k]).abs() < 1e-4),
            "{p:?} → {q:?}"
        );
    }
    // Rotations turn with the mesh: the quaternions differ by the 90° turn about y.
    let (qa, qb) = (host(posed.quats), host(moved.quats));
    let turn = [
        std::f32::consts::FRAC_1_SQRT_2,
        0.0,
        std::f32::consts::FRAC_1_SQRT_2,
        0.0,
    ];
    for (p, q) in qa.chunks(4).zip(qb.chunks(4)) {
        // turn ⊗ p
        let (w1, x1, y1, z1) = (turn[0], turn[1], turn[2], turn[3]);
        let (w2, x2, y2, z2) = (p[0], p[1], p[2], p[3]);
        let r = [
            w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
            w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        ];
        let dot: f32 = r.iter().zip(q).map(|(a, b)| a * b).sum();
        assert!(dot.abs() > 0.9999, "{r:?} vs {q:?}");
    }
    // Fusion matters: plain averaging gives a different avatar.
    let average = model.generate(&inputs, Fusion::Average, 0.02);
    assert_ne!(
        host(average.attributes.rgb.clone()),
        host(avatar.attributes.rgb.clone())
    );
    // Gradients reach the images through encoder, sampling, fusion and decoder.
    let leaf = images.autodiff().require_grad();
    let model = model.train();
    let inputs = NlfInputs {
        images: leaf.clone(),
        views: Views {
            intrinsics: views.intrinsics.clone().autodiff(),
            world_to_camera: views.world_to_camera.clone().autodiff(),
            size: views.size,
        },
        camera_centres: centres.autodiff(),
        vertices: vertices.clone().autodiff(),
        faces: &faces,
        anchors: &anchors,
        depth: None,
    };
    let avatar = model.generate(&inputs, Fusion::Orientation, 0.02);
    let grads = (avatar.attributes.rgb.sum() + avatar.attributes.offset.sum()).backward();
    let g = host(leaf.grad(&grads).unwrap());
    assert!(g.iter().all(|v| v.is_finite()) && g.iter().any(|v| *v != 0.0));
    // … and every parameter of the trainable model receives one.
    let mut count = Count {
        grads: &grads,
        with: 0,
        without: 0,
    };
    model.visit(&mut count);
    assert!(
        count.with > 40 && count.without == 0,
        "{} with, {} without",
        count.with,
        count.without
    );
}

/// Counts parameters with and without a gradient.
struct Count<'a> {
    grads: &'a burn::tensor::Gradients,
    with: usize,
    without: usize,
}

impl burn::module::ModuleVisitor for Count<'_> {
    fn visit_float<const D: usize>(&mut self, param: &burn::module::Param<Tensor<D>>) {
        if param.val().grad(self.grads).is_some() {
            self.with += 1;
        } else {
            self.without += 1;
        }
    }
}

/// A network saved by path and loaded into a freshly initialised one generates the same avatar;
/// a file from another architecture is refused, naming the tensor.
#[test]
fn networks_save_and_load_by_parameter_path() {
    use splatzoo_models::networks::weights::{
        WeightFile, load_module, module_tensors, write_safetensors,
    };
    let device = Device::flex();
    let config = NlfConfig {
        fpn_channels: 8,
        hidden: vec![16],
        ..Default::default()
    };
    let model = NlfGs::new(&config, &device);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("nlf.safetensors");
    let tensors = module_tensors(&model);
    assert!(
        tensors.contains_key("decoder.head.weight"),
        "{:?}",
        tensors.keys().take(5).collect::<Vec<_>>()
    );
    write_safetensors(&path, &tensors).unwrap();
    let loaded = load_module(
        NlfGs::new(&config, &device),
        &WeightFile::read(&path).unwrap(),
    )
    .unwrap();
    let (v, faces) = octahedron();
    let anchors = MeshAnchors::per_face(faces.len() / 3, config.gaussians_per_face);
    let vertices = Tensor::<3>::from_data(TensorData::new(v, [1, 6, 3]), &device);
    let (views, centres) = ring(&device);
    let pixels: Vec<f32> = (0..3 * 3 * 32 * 32)
        .map(|i| ((i * 13) % 97) as f32 / 96.0)
        .collect();
    let inputs = NlfInputs {
        images: Tensor::from_data(TensorData::new(pixels, [3, 3, 32, 32]), &device),
        views,
        camera_centres: centres,
        vertices,
        faces: &faces,
        anchors: &anchors,
        depth: None,
    };
    let a = model
        .generate(&inputs, Fusion::Orientation, 0.02)
        .attributes;
    let b = loaded
        .generate(&inputs, Fusion::Orientation, 0.02)
        .attributes;
    assert_eq!(host(a.rgb), host(b.rgb));
    assert_eq!(host(a.offset), host(b.offset));
    let other = NlfConfig {
        fpn_channels: 16,
        ..config
    };
    let e = load_module(
        NlfGs::new(&other, &device),
        &WeightFile::read(&path).unwrap(),
    )
    .err()
    .unwrap()
    .to_string();
    assert!(
        e.contains("nlf.safetensors") && e.contains("encoder.") && e.contains("expected"),
        "{e}"
    );
}
