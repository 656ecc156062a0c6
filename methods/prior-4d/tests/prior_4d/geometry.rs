//! The locator and the renderer: σ-invariance of the avatar's image (App. A), camera refinement
//! against a direct render from the refined host camera and recovering a perturbed pose, and
//! rendered normals of a sphere against its analytic normals (Eq. 5).

use crate::{Rng, fresh_seed, values};
use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_models::normals::vertex_normals;
use splatzoo_models::rotation_scalar::axis_angle_matrix as rodrigues;
use splatzoo_prior_4d::camera::{RigidFrame, camera_at_origin, camera_to_world, splats_in_frame};
use splatzoo_prior_4d::locate::{place, solid_spheres};
use splatzoo_prior_4d::loss::normal_loss;
use splatzoo_prior_4d::render::{AvatarSplats, SceneSplats, render_layers};
use splatzoo_rasterizer::testing::{SceneSpec, random_scene};
use splatzoo_rasterizer::{Camera, ColorMode, RasterSettings, Splats, rasterize};

fn max_abs_diff(a: &[f32], b: &[f32]) -> f32 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max)
}

fn matmul(a: [[f64; 3]; 3], b: [[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let mut m = [[0.0; 3]; 3];
    for (i, row) in m.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    m
}

/// A host camera with `camera`'s intrinsics at camera-to-world pose (`rotation`, `centre`).
fn camera_at(camera: &Camera, rotation: [[f64; 3]; 3], centre: [f64; 3]) -> Camera {
    let mut world_to_camera = [[0.0f32; 4]; 3];
    for i in 0..3 {
        for j in 0..3 {
            world_to_camera[i][j] = rotation[j][i] as f32;
        }
        world_to_camera[i][3] = -(0..3).map(|k| rotation[k][i] * centre[k]).sum::<f64>() as f32;
    }
    Camera {
        world_to_camera,
        ..*camera
    }
}

/// Scaling the camera-space avatar and its radii by σ about the acting camera's centre leaves
/// its image there unchanged (σ and 2σ), so the photometric loss's gradient on s = ln σ
/// vanishes while a camera-space translation's does not.
#[test]
fn the_avatar_image_does_not_see_the_global_scale() {
    let seed = fresh_seed();
    let device = Device::flex().autodiff();
    let (host, settings) = random_scene(
        seed,
        &SceneSpec::new(300, 64, 48, ColorMode::Sh { degree: 0 }),
    );
    let (world, _) = host.tensors(&device);
    let acting = RigidFrame::of_camera(&settings.camera, &device);
    let camera_space = splats_in_frame(&world, &acting);
    let mut rng = Rng(seed);
    let sigma = rng.range(0.3, 3.0);
    let render_at = |s: Tensor<1>, shift: Tensor<2>| {
        let shifted = Splats {
            means: camera_space.means.clone() + shift,
            ..camera_space.clone()
        };
        let placed = place(shifted, s, &acting);
        let normals = Tensor::zeros([placed.len(), 3], &device);
        let avatar = AvatarSplats {
            splats: placed,
            normals,
        };
        render_layers(None, Some(&avatar), &acting, &settings, [0.1, 0.2, 0.3]).unwrap()
    };
    let log = |v: f64| Tensor::<1>::from_floats([v.ln() as f32], &device);
    let zero_shift = || Tensor::<2>::zeros([1, 3], &device);
    let once = values(render_at(log(sigma), zero_shift()).color);
    let twice = values(render_at(log(2.0 * sigma), zero_shift()).color);
    let diff = max_abs_diff(&once, &twice);
    assert!(diff <= 1e-4, "seed {seed}: σ and 2σ differ by {diff}");

    let target: Vec<f32> = (0..once.len())
        .map(|_| rng.range(0.0, 1.0) as f32)
        .collect();
    let target = Tensor::<3>::from_data(TensorData::new(target, [48, 64, 3]), &device);
    let s = log(sigma).require_grad();
    let shift = zero_shift().require_grad();
    let layers = render_at(s.clone(), shift.clone());
    let loss = (layers.color - target).abs().mean();
    let grads = loss.backward();
    let ds = values(s.grad(&grads).expect("s is reached"))
        .remove(0)
        .abs();
    let dshift: f32 = values(shift.grad(&grads).expect("shift"))
        .iter()
        .map(|v| v.abs())
        .sum();
    assert!(
        dshift > 1e-4,
        "seed {seed}: a translation must change the image ({dshift})"
    );
    assert!(
        ds < 1e-3 * dshift,
        "seed {seed}: dL/ds = {ds} against a translation's {dshift}"
    );
}

/// Rendering through a refined frame (splats moved, SH evaluated in the world) gives what the
/// op renders directly from the refined host camera, at SH degree 3.
#[test]
fn refined_camera_render_matches_a_direct_render() {
    let seed = fresh_seed();
    let mut rng = Rng(seed);
    let device = Device::flex();
    let (host, settings) = random_scene(
        seed,
        &SceneSpec::new(400, 64, 48, ColorMode::Sh { degree: 3 }),
    );
    let (world, background) = host.tensors(&device);
    let omega = [0.0; 3].map(|_| rng.range(-0.05, 0.05));
    let tau = [0.0; 3].map(|_| rng.range(-0.1, 0.1));
    let refined = RigidFrame::of_camera(&settings.camera, &device).refined(
        Tensor::<1>::from_floats(omega.map(|v| v as f32), &device),
        Tensor::<1>::from_floats(tau.map(|v| v as f32), &device),
    );
    let bg = values(background.clone());
    let scene = SceneSplats {
        splats: &world,
        degree: 3,
    };
    let ours = render_layers(
        Some(&scene),
        None,
        &refined,
        &settings,
        [bg[0], bg[1], bg[2]],
    )
    .unwrap();
    let (rotation, centre) = camera_to_world(&settings.camera);
    let rotation = matmul(rodrigues(omega), rotation);
    let centre = [0, 1, 2].map(|i| centre[i] + tau[i]);
    let direct = rasterize(
        &world,
        background,
        &RasterSettings {
            camera: camera_at(&settings.camera, rotation, centre),
            ..settings
        },
    )
    .unwrap();
    let diff = max_abs_diff(&values(ours.color), &values(direct.color));
    assert!(diff < 2e-4, "seed {seed}: refined render differs by {diff}");
    let normal = values(ours.normal);
    assert!(
        normal.iter().all(|v| *v == 0.0),
        "scene splats carry no normal"
    );
}

/// A camera perturbed by 1° and 2 cm, refined alone against the scene's pixels, comes back to
/// within 0.1° and 2 mm.
#[test]
fn camera_refinement_recovers_a_perturbed_pose() {
    let seed = fresh_seed();
    let mut rng = Rng(seed);
    let device = Device::flex();
    let mut spec = SceneSpec::new(3000, 96, 72, ColorMode::Sh { degree: 0 });
    spec.scale_range = (0.01, 0.05);
    spec.opacity_range = (0.5, 0.95);
    let (host, mut settings) = random_scene(seed, &spec);
    // Close enough that the cube's depth gives parallax (rotation and translation separate).
    settings.camera = Camera::look_at([0.3, -0.2, -2.2], [0.0; 3], [0.0, 1.0, 0.0], 70.0, 96, 72);
    let (world, background) = host.tensors(&device);
    let bg = values(background);
    let bg = [bg[0], bg[1], bg[2]];
    let truth = RigidFrame::of_camera(&settings.camera, &device);
    let scene = SceneSplats {
        splats: &world,
        degree: 0,
    };
    let target = render_layers(Some(&scene), None, &truth, &settings, bg)
        .unwrap()
        .color;
    // The perturbation: 1° about a random axis, 2 cm in a random direction.
    let unit = |rng: &mut Rng| {
        let v = [rng.gauss(), rng.gauss(), rng.gauss()];
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        v.map(|x| x / n)
    };
    let axis = unit(&mut rng);
    let dir = unit(&mut rng);
    let (rotation, centre) = camera_to_world(&settings.camera);
    let noisy_rotation = matmul(rodrigues(axis.map(|a| a * 1f64.to_radians())), rotation);
    let noisy_centre = [0, 1, 2].map(|i| centre[i] + 0.02 * dir[i]);
    let ad = device.clone().autodiff();
    let noisy = RigidFrame::from_host(noisy_rotation, noisy_centre, &ad);
    let world_ad = Splats {
        means: world.means.clone().autodiff(),
        quats: world.quats.clone().autodiff(),
        log_scales: world.log_scales.clone().autodiff(),
        opacity_logits: world.opacity_logits.clone().autodiff(),
        colors: world.colors.clone().autodiff(),
    };
    let target = target.autodiff();
    // Adam on (ω, τ).
    let mut params = [0.0f64; 6];
    let (mut m, mut v) = ([0.0f64; 6], [0.0f64; 6]);
    let rate = 2e-3;
    for step in 1..=400 {
        let omega =
            Tensor::<1>::from_floats([params[0] as f32, params[1] as f32, params[2] as f32], &ad)
                .require_grad();
        let tau =
            Tensor::<1>::from_floats([params[3] as f32, params[4] as f32, params[5] as f32], &ad)
                .require_grad();
        let view = noisy.refined(omega.clone(), tau.clone());
        let scene = SceneSplats {
            splats: &world_ad,
            degree: 0,
        };
        let image = render_layers(Some(&scene), None, &view, &settings, bg)
            .unwrap()
            .color;
        let loss = (image - target.clone()).powi_scalar(2).mean();
        let grads = loss.backward();
        let g: Vec<f32> = values(omega.grad(&grads).unwrap())
            .into_iter()
            .chain(values(tau.grad(&grads).unwrap()))
            .collect();
        let lr = match step {
            0..=250 => rate,
            251..=350 => rate * 0.1,
            _ => rate * 0.01,
        };
        for k in 0..6 {
            let gk = f64::from(g[k]);
            m[k] = 0.9 * m[k] + 0.1 * gk;
            v[k] = 0.999 * v[k] + 0.001 * gk * gk;
            let mh = m[k] / (1.0 - 0.9f64.powi(step));
            let vh = v[k] / (1.0 - 0.999f64.powi(step));
            params[k] -= lr * mh / (vh.sqrt() + 1e-12);
        }
    }
    let recovered_rotation = matmul(rodrigues([params[0], params[1], params[2]]), noisy_rotation);
    // Angle of R_recovered R_trueᵀ.
    let mut trace = 0.0;
    for i in 0..3 {
        for k in 0..3 {
            trace += recovered_rotation[i][k] * rotation[i][k];
        }
    }
    let angle = ((trace - 1.0) / 2.0).clamp(-1.0, 1.0).acos().to_degrees();
    let offset: f64 = (0..3)
        .map(|i| (noisy_centre[i] + params[3 + i] - centre[i]).powi(2))
        .sum::<f64>()
        .sqrt();
    assert!(angle < 0.1, "seed {seed}: {angle}° left");
    assert!(offset < 0.002, "seed {seed}: {offset} m left");
}

/// A UV sphere `[V, 3]` (poles excluded) and its outward triangles.
fn uv_sphere(rings: usize, segments: usize, radius: f64, centre: [f64; 3]) -> (Vec<f32>, Vec<u32>) {
    use std::f64::consts::PI;
    let mut vertices = Vec::new();
    for r in 0..rings {
        let theta = PI * (r as f64 + 0.5) / rings as f64;
        for s in 0..segments {
            let phi = 2.0 * PI * s as f64 / segments as f64;
            let p = [
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            ];
            vertices.extend((0..3).map(|k| (centre[k] + radius * p[k]) as f32));
        }
    }
    let mut faces = Vec::new();
    let at = |r: usize, s: usize| (r * segments + s % segments) as u32;
    for r in 0..rings - 1 {
        for s in 0..segments {
            let (a, b, c, d) = (at(r, s), at(r, s + 1), at(r + 1, s), at(r + 1, s + 1));
            faces.extend([a, b, c, b, d, c]);
        }
    }
    (vertices, faces)
}

/// Gaussians on a sphere's vertices, normals from `vertex_normals`, rendered at the camera's
/// origin: the blended normal map matches the analytic normals (mean < 2° on the covered
/// interior, facing the camera), and Eq. 6 on it reaches the vertices and not the colours.
#[test]
fn rendered_sphere_normals_match_analytic_normals() {
    let device = Device::flex().autodiff();
    let (r, centre) = (0.5, [0.0, 0.0, 2.5]);
    let (flat, faces) = uv_sphere(128, 256, r, centre);
    let n = flat.len() / 3;
    let vertices = Tensor::<2>::from_data(TensorData::new(flat, [n, 3]), &device).require_grad();
    let normals = vertex_normals(vertices.clone().reshape([1, n, 3]), &faces).reshape([n, 3]);
    let colors = Tensor::<3>::zeros([n, 1, 3], &device).require_grad();
    let raw = Splats {
        means: vertices.clone(),
        quats: Tensor::zeros([n, 4], &device),
        log_scales: Tensor::<2>::full([n, 3], (0.008f32).ln(), &device),
        opacity_logits: Tensor::zeros([n], &device),
        colors: colors.clone(),
    };
    let avatar = AvatarSplats {
        splats: solid_spheres(raw),
        normals,
    };
    let (w, h) = (160u32, 120u32);
    let camera = camera_at_origin(&Camera::look_at(
        [0.0, 0.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, -1.0, 0.0],
        40.0,
        w,
        h,
    ));
    let settings = RasterSettings::new(camera, ColorMode::Features);
    let view = RigidFrame::of_camera(&camera, &device);
    let layers = render_layers(None, Some(&avatar), &view, &settings, [0.0; 3]).unwrap();
    let rendered = values(layers.normal.clone());
    let alpha = values(layers.avatar_alpha.clone());
    let (mut sum, mut count) = (0.0, 0usize);
    let mut truth = vec![0.0f32; rendered.len()];
    let mut mask = vec![0.0f32; alpha.len()];
    for y in 0..h as usize {
        for x in 0..w as usize {
            // The pixel's ray and its first hit on the sphere.
            let d = [
                (x as f64 + 0.5 - f64::from(camera.cx)) / f64::from(camera.fx),
                (y as f64 + 0.5 - f64::from(camera.cy)) / f64::from(camera.fy),
                1.0,
            ];
            let dd: f64 = d.iter().map(|v| v * v).sum();
            let dc: f64 = (0..3).map(|k| d[k] * centre[k]).sum();
            let cc: f64 = centre.iter().map(|v| v * v).sum();
            let disc = dc * dc - dd * (cc - r * r);
            if disc <= 0.0 {
                continue;
            }
            let t = (dc - disc.sqrt()) / dd;
            let normal = [0, 1, 2].map(|k| (t * d[k] - centre[k]) / r);
            let p = y * w as usize + x;
            truth[3 * p..3 * p + 3].copy_from_slice(&normal.map(|v| v as f32));
            // Interior only: stay clear of the silhouette, where blending mixes in the back.
            if normal[2] > -0.5 || alpha[p] < 0.98 {
                continue;
            }
            mask[p] = 1.0;
            let got = [0, 1, 2].map(|k| f64::from(rendered[3 * p + k]));
            let len = got.iter().map(|v| v * v).sum::<f64>().sqrt();
            let cos = (0..3).map(|k| got[k] * normal[k]).sum::<f64>() / len;
            sum += cos.clamp(-1.0, 1.0).acos().to_degrees();
            count += 1;
        }
    }
    assert!(count > 500, "{count} interior pixels");
    let mean = sum / count as f64;
    assert!(mean < 2.0, "mean normal error {mean}°");
    // Eq. 6 against a tilted target: gradient on the vertices, exactly none on the colours.
    let target: Vec<f32> = truth.iter().map(|v| v * 0.9).collect();
    let target = Tensor::<3>::from_data(
        TensorData::new(target, [h as usize, w as usize, 3]),
        &device,
    );
    let mask = Tensor::<2>::from_data(TensorData::new(mask, [h as usize, w as usize]), &device);
    let loss = normal_loss(layers.normal, target, mask);
    let grads = loss.backward();
    let g_vertices = values(vertices.grad(&grads).expect("vertices are reached"));
    assert!(g_vertices.iter().all(|v| v.is_finite()));
    assert!(
        g_vertices.iter().any(|v| *v != 0.0),
        "no gradient on the vertices"
    );
    let g_colors = colors.grad(&grads).map(values).unwrap_or_default();
    assert!(
        g_colors.iter().all(|v| *v == 0.0),
        "colours got a normal-loss gradient"
    );
}
