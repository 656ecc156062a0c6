//! Illum's networks and steps are backend-generic: from the same initial weights, three
//! gradient steps of stage 1 (hash fields, face Gaussians, the rasterizer, L1 + SSIM, L_mesh,
//! L_scale) and one Monte-Carlo shading of the stage-2 pipeline on NdArray and on wgpu
//! (lavapipe in CI) agree with Flex (139 dB and 58 dB measured; 36 dB asked).

use crate::values;
use burn::module::{Module, ModuleMapper, Param};
use burn::optim::{GradientsParams, SgdConfig};
use burn::tensor::{Tensor, TensorData};
use splatzoo_illum::human::{BodyMesh, RefinedBody, Stage1Config};
use splatzoo_illum::light_volume::{LightVolume, ProbeGrid};
use splatzoo_illum::lighting::{LitGaussians, Material, SamplingConfig, shade_gaussians};
use splatzoo_illum::pbr::Shading;
use splatzoo_illum::sampling::HemisphereRule;
use splatzoo_illum::stage1::{HumanView, Stage1Weights, stage1_terms};
use splatzoo_models::body::lbs::pose;
use splatzoo_models::body::{BodyTensors, PoseInput, builtin_body};
use splatzoo_models::laplacian::UniformLaplacian;
use splatzoo_models::networks::hash_grid::HashGridConfig;
use splatzoo_models::networks::hash_mlp::HashMlpConfig;
use splatzoo_models::networks::initialised;
use splatzoo_rasterizer::{Camera, ColorMode, RasterSettings};
use splatzoo_train::backend::Backend;

/// `module`'s values as fresh trainable leaves on `device`.
fn copied_to<M: Module>(module: M, device: &burn::tensor::Device) -> M {
    struct Copy<'a>(&'a burn::tensor::Device);
    impl ModuleMapper for Copy<'_> {
        fn map_float<const D: usize>(&mut self, param: Param<Tensor<D>>) -> Param<Tensor<D>> {
            let value = Tensor::<D>::from_data(param.val().to_data(), self.0);
            Param::from_tensor(value.require_grad())
        }
    }
    module.map(&mut Copy(device))
}

/// The stage-1 network both backends start from, initialised on the plain Flex device (Burn
/// draws layer weights lazily, from each backend's own generator, so each backend building
/// its own would start elsewhere).
fn start() -> RefinedBody {
    let mesh = BodyMesh::new(&builtin_body().model, 0).unwrap();
    let config = Stage1Config {
        subdivisions: 0,
        field: HashMlpConfig {
            grid: HashGridConfig {
                levels: 4,
                log2_table_size: 10,
                ..HashGridConfig::default()
            },
            hidden: 1,
            width: 16,
        },
        ..Stage1Config::default()
    };
    initialised(RefinedBody::new(&mesh, &config, 3, &Backend::Flex.device()))
}

/// The stage-1 render after three steps, and the shaded colours, on one backend.
fn run(backend: Backend, start: &RefinedBody) -> (Vec<f32>, Vec<f32>) {
    let device = backend.device().autodiff();
    let mesh = BodyMesh::new(&builtin_body().model, 0).unwrap();
    let mut body = copied_to(start.clone(), &device);
    let queries = mesh.queries(&body.offset, &device);
    let laplacian = UniformLaplacian::new(mesh.vertex_count(), &mesh.model.faces);
    let model = &mesh.model;
    let joints = model.joint_count();
    let posed = pose(
        &BodyTensors::new(model, &device),
        &PoseInput::from_axis_angle(
            Tensor::<2>::zeros([1, model.shape_count()], &device),
            Tensor::<2>::zeros([1, 3 * joints], &device),
            Tensor::<2>::zeros([1, 3], &device),
        ),
    );
    let camera = Camera::look_at([0.0, 0.0, 3.0], [0.0; 3], [0.0, -1.0, 0.0], 45.0, 32, 40);
    let settings = RasterSettings::new(camera, ColorMode::Features);
    // Plain gradient steps: Adam's first steps move every weight by ±lr whatever its
    // gradient's size, so a gradient that is zero up to rounding (this view is symmetric in x)
    // would move by ±lr on a sign that rounding picks, differently per backend.
    let mut optimiser = SgdConfig::new().init();
    let mut last = None;
    for _ in 0..3 {
        let terms = stage1_terms(
            &body,
            &mesh,
            &laplacian,
            &queries,
            &posed,
            HumanView {
                settings: &settings,
                image: Tensor::<3>::full([40, 32, 3], 0.7, &device),
                mask: Tensor::<2>::ones([40, 32], &device),
                background: [0.1, 0.2, 0.3],
            },
            &Stage1Weights::default(),
        )
        .unwrap();
        last = Some(values(terms.render.color.clone()));
        let grads = GradientsParams::from_grads(terms.total.backward(), &body);
        body = optimiser.step(0.5, body, grads);
    }

    let grid = ProbeGrid::covering([-1.0; 3], [1.0; 3], 0.2, 0.5, 32).unwrap();
    let volume = LightVolume::new(grid, 2, 4, 5, &device).unwrap();
    let rows = |v: Vec<f32>, n: usize| Tensor::<2>::from_data(TensorData::new(v, [n, 3]), &device);
    let shaded = shade_gaussians(
        &volume,
        LitGaussians {
            points: rows(vec![0.1, 0.2, 0.3, -0.5, 0.4, 0.0, 0.9, -0.9, 0.2], 3),
            normals: rows(vec![0.0, 0.0, 1.0, 0.6, 0.8, 0.0, -1.0, 0.0, 0.0], 3),
            material: Material {
                albedo: Tensor::<2>::full([3, 3], 0.5, &device),
                metallic: Tensor::<2>::full([3, 1], 0.2, &device),
                roughness: Tensor::<2>::full([3, 1], 0.4, &device),
            },
            camera_centre: [0.0, 0.0, 3.0],
            azimuth_offsets: None,
        },
        SamplingConfig {
            count: 16,
            rule: HemisphereRule::Midpoint,
        },
        |_| None,
        &Shading::default(),
    );
    (last.expect("three steps"), values(shaded))
}

/// `backend` against Flex from the same start: the PSNR of the stage-1 render after three
/// steps (asked > 36 dB) and the worst shading difference (asked < 1e-4).
fn matches_flex(backend: Backend) {
    let body = start();
    let (reference, shaded) = run(Backend::Flex, &body);
    let (image, other) = run(backend, &body);
    let mse = reference
        .iter()
        .zip(&image)
        .map(|(a, b)| f64::from(a - b).powi(2))
        .sum::<f64>()
        / reference.len() as f64;
    let psnr = -10.0 * mse.max(1e-20).log10();
    let worst = shaded
        .iter()
        .zip(&other)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    println!("{backend:?} vs flex after three steps: {psnr:.1} dB; shading {worst:.2e}");
    assert!(
        psnr > 36.0,
        "{backend:?} vs flex after three steps: {psnr:.1} dB"
    );
    assert!(worst < 1e-4, "{backend:?} vs flex shading: {worst}");
}

#[test]
fn illum_runs_alike_on_the_cpu_backends() {
    matches_flex(Backend::Ndarray);
}

#[test]
fn illum_runs_alike_on_wgpu() {
    matches_flex(Backend::Wgpu);
}
