//! Extremes (spec §8, check 14) across the pipeline: no human Gaussians, probe SH of 1e15, a
//! human far outside the light volume, grazing and back-facing views, a zero-area face on the
//! body, and a human behind the camera; whole training steps into stage 2 at the smallest
//! sizes: finite values and gradients, or a clear error, never a panic or a NaN.

use crate::values;
use burn::module::Param;
use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_illum::config::IllumConfig;
use splatzoo_illum::human::{BodyMesh, RefinedBody, Stage1Config};
use splatzoo_illum::light_volume::{LightVolume, ProbeGrid};
use splatzoo_illum::lighting::{LitGaussians, Material, SamplingConfig, shade_gaussians};
use splatzoo_illum::method::Illum;
use splatzoo_illum::pbr::Shading;
use splatzoo_illum::render::{HumanLayer, render_joint};
use splatzoo_illum::sampling::HemisphereRule;
use splatzoo_models::body::builtin_body;
use splatzoo_models::networks::hash_grid::HashGridConfig;
use splatzoo_models::networks::hash_mlp::HashMlpConfig;
use splatzoo_rasterizer::{Camera, ColorMode, RasterSettings};
use splatzoo_train::harness::extremes::{StepOutcome, after_steps, assert_stable};

fn finite(v: &[f32]) -> bool {
    v.iter().all(|x| x.is_finite())
}

fn volume(device: &Device) -> LightVolume {
    let grid = ProbeGrid::covering([-1.0; 3], [1.0; 3], 0.2, 0.5, 32).unwrap();
    LightVolume::new(grid, 2, 4, 5, device).unwrap()
}

fn lit(
    points: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
    camera: [f64; 3],
    device: &Device,
) -> LitGaussians {
    let n = points.len();
    let rows = |v: Vec<[f32; 3]>| {
        Tensor::<2>::from_data(
            TensorData::new(v.into_iter().flatten().collect::<Vec<_>>(), [n, 3]),
            device,
        )
    };
    LitGaussians {
        points: rows(points),
        normals: rows(normals),
        material: Material {
            albedo: Tensor::<2>::full([n, 3], 0.5, device),
            metallic: Tensor::<2>::full([n, 1], 0.3, device),
            roughness: Tensor::<2>::full([n, 1], 0.04, device),
        },
        camera_centre: camera,
        azimuth_offsets: None,
    }
}

const SAMPLING: SamplingConfig = SamplingConfig {
    count: 8,
    rule: HemisphereRule::Midpoint,
};

#[test]
fn no_human_gaussians_shade_to_an_empty_colour_table() {
    let device = Device::flex();
    let colour = shade_gaussians(
        &volume(&device),
        lit(vec![], vec![], [0.0, 0.0, 3.0], &device),
        SAMPLING,
        |_| None,
        &Shading::default(),
    );
    assert_eq!(colour.dims(), [0, 3]);
}

#[test]
fn huge_probes_far_points_and_grazing_views_stay_finite_with_finite_gradients() {
    let device = Device::flex().autodiff();
    let mut light = volume(&device);
    let huge = (light.sh.val() * 1e15).into_data();
    light.sh = Param::from_tensor(Tensor::<3>::from_data(huge, &device));
    let points = vec![
        [0.0, 0.0, 0.0],
        [1e6, -1e6, 1e6], // far outside the grid: clamped to a corner probe
        [0.2, 0.1, 0.0],
        [0.0, 0.5, 0.0],
    ];
    let normals = vec![
        [0.0, 0.0, 1.0],
        [0.0, 1.0, 0.0],
        [1.0, 0.0, 0.0],  // the camera on +z: a grazing view
        [0.0, 0.0, -1.0], // back-facing: flipped to the camera
    ];
    let mut gaussians = lit(points, normals, [0.0, 0.0, 3.0], &device);
    gaussians.material.albedo = gaussians.material.albedo.require_grad();
    gaussians.material.roughness = gaussians.material.roughness.require_grad();
    let albedo = gaussians.material.albedo.clone();
    let roughness = gaussians.material.roughness.clone();
    let colour = shade_gaussians(&light, gaussians, SAMPLING, |_| None, &Shading::default());
    let shaded = values(colour.clone());
    assert!(finite(&shaded), "{shaded:?}");
    let grads = (colour * 1e-20).sum().backward();
    for (name, g) in [
        ("albedo", albedo.grad(&grads)),
        ("roughness", roughness.grad(&grads)),
    ] {
        let g = values(g.unwrap_or_else(|| panic!("no {name} gradient")));
        assert!(finite(&g), "{name}: {g:?}");
    }
    let probes = values(light.sh.val().grad(&grads).expect("a probe gradient"));
    assert!(finite(&probes));
}

#[test]
fn a_zero_area_face_gives_a_finite_gaussian_and_gradient() {
    let device = Device::flex().autodiff();
    let mut model = builtin_body().model.clone();
    // Collapse face 0 onto an edge: two of its corners become one vertex.
    model.faces[2] = model.faces[1];
    let mesh = BodyMesh::new(&model, 0).unwrap();
    assert!(mesh.inradius[0] > 0.0, "the in-circle radius is floored");
    let config = Stage1Config {
        subdivisions: 0,
        field: HashMlpConfig {
            grid: HashGridConfig {
                levels: 4,
                log2_table_size: 10,
                ..HashGridConfig::default()
            },
            hidden: 1,
            width: 8,
        },
        ..Stage1Config::default()
    };
    let body = RefinedBody::new(&mesh, &config, 1, &device);
    let queries = mesh.queries(&body.offset, &device);
    let posed = mesh.template(&device) + body.offsets(&queries);
    let splats = body.face_splats(&mesh, posed, body.vertex_colours(&queries));
    for t in [
        splats.means.clone(),
        splats.quats.clone(),
        splats.log_scales.clone(),
    ] {
        assert!(finite(&values(t)));
    }
    let grads = (splats.quats.sum() + splats.means.sum()).backward();
    let g = values(body.in_plane.val().grad(&grads).expect("in-plane gradient"));
    assert!(finite(&g));
}

#[test]
fn a_human_behind_the_camera_leaves_empty_maps() {
    let device = Device::flex();
    let camera = Camera::look_at([0.0, 0.0, -4.0], [0.0; 3], [0.0, -1.0, 0.0], 40.0, 16, 16);
    let settings = RasterSettings::new(camera, ColorMode::Features);
    let splats = splatzoo_rasterizer::Splats {
        means: Tensor::<2>::from_floats([[0.0, 0.0, -6.0]], &device),
        quats: Tensor::<2>::from_floats([[1.0, 0.0, 0.0, 0.0]], &device),
        log_scales: Tensor::<2>::full([1, 3], -1.0, &device),
        opacity_logits: Tensor::<1>::full([1], 5.0, &device),
        colors: Tensor::<3>::zeros([1, 1, 3], &device),
    };
    let maps = render_joint(
        None,
        Some(HumanLayer {
            splats: &splats,
            colour: Tensor::<2>::ones([1, 3], &device),
            material: Tensor::<2>::ones([1, 2], &device),
            albedo: Tensor::<2>::ones([1, 3], &device),
            normals: Tensor::<2>::ones([1, 3], &device),
        }),
        &settings,
        [0.2, 0.3, 0.4],
    )
    .unwrap();
    assert!(values(maps.human_alpha).iter().all(|&a| a == 0.0));
    let colour = values(maps.colour);
    assert!(colour.chunks(3).all(|c| c == [0.2, 0.3, 0.4]));
}

/// Stage 1 of the tiny capture, then the first stage-2 step, with `change` applied.
fn into_stage_2(what: &str, change: impl FnOnce(&mut IllumConfig)) -> StepOutcome {
    let mut config = crate::trainer::tiny();
    change(&mut config);
    let steps = config.stage1.steps + 1;
    assert_stable(what, after_steps::<Illum>(config, &Device::flex(), steps))
}

/// Whole steps into stage 2 through the engine's shared check: the smallest image the capture
/// takes (8×8; 1×1 is refused by name), the fewest frames (one trained, one held out), one
/// scene point, one hemisphere sample per shading point, a one-step stage 1. Each is a finite
/// step with finite state (light volume, networks, both Gaussian sets, optimiser moments).
#[test]
fn whole_steps_at_the_extremes_are_finite_or_refused_by_name() {
    type Change = fn(&mut IllumConfig);
    let cases: [(&str, Change); 5] = [
        ("8×8 image", |c| {
            c.data.width = 8;
            c.data.height = 8;
        }),
        ("two frames", |c| {
            c.data.frames = 2;
            c.data.test_every = 2;
        }),
        ("one scene point", |c| c.data.scene_points = 1),
        ("one hemisphere sample", |c| {
            c.stage2.samples = 1;
            c.stage2.eval_samples = 1;
        }),
        ("a one-step stage 1", |c| c.stage1.steps = 1),
    ];
    for (what, change) in cases {
        let outcome = into_stage_2(what, change);
        assert!(
            matches!(outcome, StepOutcome::Finite { .. }),
            "{what}: {outcome:?}"
        );
    }
    let pixel = into_stage_2("1×1 image", |c| {
        c.data.width = 1;
        c.data.height = 1;
    });
    match pixel {
        StepOutcome::Refused(message) => assert!(message.contains("data.width"), "{message}"),
        other => panic!("1×1 image: expected a refusal, got {other:?}"),
    }
}
