//! The mesh renderer against geometry with known answers: coverage and depth of planes
//! (perspective-correct), textures at the right place, shadows where an occluder is, masks
//! consistent with depth, normals consistent with depth, near-plane clipping, determinism; an
//! SH environment lighting by its irradiance, the albedo buffer, and the analytic probe SH.

use splatzoo_datasets::render::{
    Albedo, Light, Lighting, MeshInstance, RenderSettings, Texture, render,
};
use splatzoo_models::body::builtin_body;
use splatzoo_rasterizer::Camera;
use splatzoo_rasterizer::sh::irradiance_f64;

fn quad(corners: [[f32; 3]; 4]) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    (corners.to_vec(), vec![[0, 1, 2], [0, 2, 3]])
}

/// The built-in body's rest mesh as position and face rows.
fn body_mesh() -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let body = builtin_body();
    let p = body
        .model
        .template
        .chunks(3)
        .map(|v| [v[0], v[1], v[2]])
        .collect();
    let f = body
        .model
        .faces
        .chunks(3)
        .map(|v| [v[0], v[1], v[2]])
        .collect();
    (p, f)
}

fn flat_light() -> Lighting {
    Lighting {
        ambient: [1.0; 3],
        environment: None,
        light: None,
        shadow_resolution: None,
    }
}

/// Camera at the origin looking down +z (world = camera frame, OpenCV axes).
fn identity_camera(w: u32, h: u32, f: f32) -> Camera {
    Camera {
        fx: f,
        fy: f,
        cx: w as f32 / 2.0,
        cy: h as f32 / 2.0,
        width: w,
        height: h,
        near: 0.05,
        far: 100.0,
        world_to_camera: [
            [1.0, 0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, 0.0],
        ],
    }
}

#[test]
fn tilted_plane_depth_is_perspective_correct_and_coverage_matches_area() {
    // Plane z = 2 + 0.5 y, a square in x ∈ [−0.5, 0.5], y ∈ [−0.5, 0.5].
    let z = |y: f32| 2.0 + 0.5 * y;
    let (p, f) = quad([
        [-0.5, -0.5, z(-0.5)],
        [0.5, -0.5, z(-0.5)],
        [0.5, 0.5, z(0.5)],
        [-0.5, 0.5, z(0.5)],
    ]);
    let camera = identity_camera(64, 64, 50.0);
    let mesh = MeshInstance {
        positions: &p,
        faces: &f,
        albedo: Albedo::Uniform([1.0; 3]),
        label: 3,
        smooth: false,
    };
    let settings = RenderSettings {
        background: [0.0; 3],
        supersample: 1,
    };
    let out = render(&[mesh], &camera, &flat_light(), &settings);
    let mut worst = 0.0f64;
    let mut covered = 0;
    for row in 0..64 {
        for col in 0..64 {
            let i = row * 64 + col;
            // The ray through the pixel centre meets the plane at depth d: y = d (row + 0.5 − cy)/fy.
            let ry = (row as f64 + 0.5 - 32.0) / 50.0;
            let rx = (col as f64 + 0.5 - 32.0) / 50.0;
            let d = 2.0 / (1.0 - 0.5 * ry);
            let inside = (rx * d).abs() < 0.5 && (ry * d).abs() < 0.5;
            let hit = out.depth[i].is_finite();
            if (rx * d).abs() < 0.49 && (ry * d).abs() < 0.49 {
                assert!(hit, "pixel ({col}, {row}) should be covered");
            }
            if !inside && ((rx * d).abs() > 0.51 || (ry * d).abs() > 0.51) {
                assert!(!hit, "pixel ({col}, {row}) should be empty");
            }
            if hit {
                covered += 1;
                worst = worst.max((out.depth[i] as f64 - d).abs());
                assert_eq!(out.label[i], 3);
                // Normal of the plane, facing the camera.
                let n = out.normal[i];
                let want = [0.0, 0.5 / 1.25f32.sqrt(), -1.0 / 1.25f32.sqrt()];
                assert!(
                    (0..3).all(|k| (n[k] - want[k]).abs() < 1e-4),
                    "normal {n:?}"
                );
            } else {
                assert_eq!(out.label[i], 0);
            }
        }
    }
    assert!(worst < 1e-5, "depth off by {worst}");
    assert!(covered > 300);
}

#[test]
fn textures_are_sampled_perspective_correctly() {
    // A plane receding in depth, textured with u along x and v along the receding direction.
    let (p, f) = quad([
        [-1.0, 0.5, 1.0],
        [1.0, 0.5, 1.0],
        [1.0, 0.5, 5.0],
        [-1.0, 0.5, 5.0],
    ]);
    let coords = vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
    let corners = vec![[0, 1, 2], [0, 2, 3]];
    // Texture value encodes v directly.
    let texture = Texture::from_fn(64, 256, |_, v| [v, 0.0, 0.0]);
    let camera = identity_camera(64, 64, 40.0);
    let mesh = MeshInstance {
        positions: &p,
        faces: &f,
        albedo: Albedo::Textured {
            coords: &coords,
            corners: &corners,
            texture: &texture,
        },
        label: 1,
        smooth: false,
    };
    let out = render(
        &[mesh],
        &camera,
        &flat_light(),
        &RenderSettings {
            background: [0.0; 3],
            supersample: 1,
        },
    );
    let mut checked = 0;
    for row in 33..64 {
        let i = row * 64 + 32;
        if !out.depth[i].is_finite() {
            continue;
        }
        let d = out.depth[i] as f64;
        let v = (d - 1.0) / 4.0;
        assert!(
            (out.color[i][0] as f64 - v).abs() < 0.01,
            "row {row}: {} vs v {v}",
            out.color[i][0]
        );
        checked += 1;
    }
    assert!(checked > 10);
}

#[test]
fn ground_behind_the_camera_is_clipped_not_lost() {
    // A ground plane around and behind the camera: the lower half must be fully covered.
    let (p, f) = quad([
        [-50.0, 1.0, -50.0],
        [50.0, 1.0, -50.0],
        [50.0, 1.0, 50.0],
        [-50.0, 1.0, 50.0],
    ]);
    let camera = identity_camera(48, 48, 30.0);
    let mesh = MeshInstance {
        positions: &p,
        faces: &f,
        albedo: Albedo::Uniform([0.5; 3]),
        label: 1,
        smooth: false,
    };
    let out = render(&[mesh], &camera, &flat_light(), &RenderSettings::default());
    for row in 26..48 {
        for col in 0..48 {
            assert_eq!(out.coverage[row * 48 + col], 1.0, "hole at ({col}, {row})");
        }
    }
    assert!(
        (0..20).all(|row| out.coverage[row * 48] == 0.0),
        "sky covered"
    );
}

fn box_mesh(lo: [f32; 3], hi: [f32; 3]) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let p: Vec<[f32; 3]> = (0..8)
        .map(|c| {
            [
                if c & 1 == 0 { lo[0] } else { hi[0] },
                if c & 2 == 0 { lo[1] } else { hi[1] },
                if c & 4 == 0 { lo[2] } else { hi[2] },
            ]
        })
        .collect();
    let f = vec![
        [0, 2, 3],
        [0, 3, 1],
        [4, 5, 7],
        [4, 7, 6],
        [0, 1, 5],
        [0, 5, 4],
        [2, 6, 7],
        [2, 7, 3],
        [0, 4, 6],
        [0, 6, 2],
        [1, 3, 7],
        [1, 7, 5],
    ];
    (p, f)
}

fn shadow_scene(light: Light) {
    // Ground at y = 0 (y up), a box floating above it; camera looking down from above.
    let (gp, gf) = quad([
        [-2.0, 0.0, -2.0],
        [2.0, 0.0, -2.0],
        [2.0, 0.0, 2.0],
        [-2.0, 0.0, 2.0],
    ]);
    let (bp, bf) = box_mesh([-0.3, 0.6, -0.3], [0.3, 0.9, 0.3]);
    let ground = MeshInstance {
        positions: &gp,
        faces: &gf,
        albedo: Albedo::Uniform([0.8; 3]),
        label: 1,
        smooth: false,
    };
    let occluder = MeshInstance {
        positions: &bp,
        faces: &bf,
        albedo: Albedo::Uniform([0.8; 3]),
        label: 2,
        smooth: false,
    };
    let camera = Camera::look_at(
        [0.0, 4.0, 2.5],
        [0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        60.0,
        96,
        96,
    );
    let lighting = Lighting {
        ambient: [0.2; 3],
        environment: None,
        light: Some(light),
        shadow_resolution: Some(512),
    };
    let out = render(
        &[ground, occluder],
        &camera,
        &lighting,
        &RenderSettings::default(),
    );
    let mut shadowed = 0;
    let mut lit_far = 0;
    for i in 0..out.color.len() {
        if out.label[i] != 1 || out.coverage[i] < 1.0 {
            continue;
        }
        // World point of this ground pixel: find it through depth along the ray.
        let (col, row) = ((i % 96) as f32 + 0.5, (i / 96) as f32 + 0.5);
        let d = out.depth[i];
        let cam = [
            (col - camera.cx) / camera.fx * d,
            (row - camera.cy) / camera.fy * d,
            d,
        ];
        let m = camera.world_to_camera;
        let t = [cam[0] - m[0][3], cam[1] - m[1][3], cam[2] - m[2][3]];
        let world: [f32; 3] =
            std::array::from_fn(|c| m[0][c] * t[0] + m[1][c] * t[1] + m[2][c] * t[2]);
        let r = (world[0] * world[0] + world[2] * world[2]).sqrt();
        let (c, u) = (out.color[i][0], out.color_unshadowed[i][0]);
        if r < 0.15 {
            assert!(
                c < 0.6 * u,
                "ground under the box at {world:?} is lit: {c} vs {u}"
            );
            shadowed += 1;
        } else if r > 0.9 {
            assert!(
                (c - u).abs() < 1e-5,
                "open ground at {world:?} is shadowed: {c} vs {u}"
            );
            lit_far += 1;
        }
    }
    assert!(
        shadowed > 5 && lit_far > 100,
        "{shadowed} shadowed, {lit_far} open pixels checked"
    );
}

#[test]
fn directional_light_casts_a_shadow_under_an_occluder() {
    shadow_scene(Light::Directional {
        direction: [0.0, -1.0, 0.0],
        color: [1.0; 3],
    });
}

#[test]
fn point_light_casts_a_shadow_under_an_occluder() {
    shadow_scene(Light::Point {
        position: [0.0, 2.0, 0.0],
        color: [4.0; 3],
    });
}

/// On the body: the label mask is exactly where depth is finite, and normals estimated from
/// depth by finite differences agree with the rendered normals.
#[test]
fn body_masks_match_depth_and_normals_match_depth_gradients() {
    let (p, f) = body_mesh();
    let camera = Camera::look_at(
        [0.3, 0.0, 2.5],
        [0.0, -0.3, 0.0],
        [0.0, 1.0, 0.0],
        45.0,
        128,
        128,
    );
    let mesh = MeshInstance {
        positions: &p,
        faces: &f,
        albedo: Albedo::Uniform([0.7; 3]),
        label: 5,
        smooth: true,
    };
    let out = render(
        &[mesh],
        &camera,
        &Lighting::default(),
        &RenderSettings::default(),
    );
    for i in 0..out.depth.len() {
        assert_eq!(out.label[i] == 5, out.depth[i].is_finite(), "pixel {i}");
    }
    // Back-project to camera space and compare cross-product normals with rendered ones.
    let back = |i: usize| {
        let (col, row) = ((i % 128) as f32 + 0.5, (i / 128) as f32 + 0.5);
        let d = out.depth[i];
        [
            (col - camera.cx) / camera.fx * d,
            (row - camera.cy) / camera.fy * d,
            d,
        ]
    };
    let m = camera.world_to_camera;
    let (mut agree, mut total) = (0, 0);
    for row in 1..127 {
        for col in 1..127 {
            let i = row * 128 + col;
            let nb = [i - 1, i + 1, i - 128, i + 128];
            if !nb.iter().chain([&i]).all(|&k| out.depth[k].is_finite()) {
                continue;
            }
            let (l, r, u, d) = (back(nb[0]), back(nb[1]), back(nb[2]), back(nb[3]));
            let dx = [r[0] - l[0], r[1] - l[1], r[2] - l[2]];
            let dy = [d[0] - u[0], d[1] - u[1], d[2] - u[2]];
            let n = [
                dx[1] * dy[2] - dx[2] * dy[1],
                dx[2] * dy[0] - dx[0] * dy[2],
                dx[0] * dy[1] - dx[1] * dy[0],
            ];
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            if len == 0.0 {
                continue;
            }
            // Rendered normal into camera space.
            let w = out.normal[i];
            let nc: [f32; 3] =
                std::array::from_fn(|r| m[r][0] * w[0] + m[r][1] * w[1] + m[r][2] * w[2]);
            let cos = -(n[0] * nc[0] + n[1] * nc[1] + n[2] * nc[2]) / len;
            total += 1;
            if cos.abs() > 0.9 {
                agree += 1;
            }
        }
    }
    assert!(total > 1000, "{total} interior pixels");
    assert!(
        agree as f64 > 0.9 * total as f64,
        "{agree} of {total} normals agree with depth"
    );
}

#[test]
fn output_does_not_depend_on_thread_count() {
    let (p, f) = body_mesh();
    let camera = Camera::look_at(
        [0.0, 0.0, 2.5],
        [0.0, -0.3, 0.0],
        [0.0, 1.0, 0.0],
        45.0,
        96,
        80,
    );
    let go = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mesh = MeshInstance {
                positions: &p,
                faces: &f,
                albedo: Albedo::Uniform([0.7; 3]),
                label: 1,
                smooth: true,
            };
            render(
                &[mesh],
                &camera,
                &Lighting::default(),
                &RenderSettings::default(),
            )
        })
    };
    let (a, b) = (go(1), go(3));
    assert_eq!(a.color, b.color);
    assert_eq!(a.depth, b.depth);
    assert_eq!(a.label, b.label);
}

/// A wall facing the camera lit only by an SH environment sends out `b E(n) / π`; the albedo
/// buffer holds `b` on the wall and 0 on the background.
#[test]
fn an_sh_environment_lights_by_its_irradiance_and_the_albedo_buffer_holds_the_albedo() {
    let (p, f) = quad([
        [-1.0, -1.0, 3.0],
        [1.0, -1.0, 3.0],
        [1.0, 1.0, 3.0],
        [-1.0, 1.0, 3.0],
    ]);
    let albedo = [0.6, 0.4, 0.2];
    let wall = MeshInstance {
        positions: &p,
        faces: &f,
        albedo: Albedo::Uniform(albedo),
        label: 1,
        smooth: false,
    };
    let mut environment = [[0.0f32; 3]; 9];
    environment[0] = [2.0, 1.5, 1.0];
    environment[2] = [0.3, -0.2, 0.1]; // Y_1,0 ∝ z: brighter light from +z
    environment[6] = [0.2, 0.2, -0.1];
    let lighting = Lighting {
        ambient: [0.0; 3],
        environment: Some(environment),
        light: None,
        shadow_resolution: None,
    };
    let camera = identity_camera(32, 32, 30.0);
    let settings = RenderSettings {
        background: [0.0; 3],
        supersample: 1,
    };
    let out = render(&[wall], &camera, &lighting, &settings);
    let centre = 16 * 32 + 16;
    // The wall's normal faces the camera: −z.
    let sh = environment.map(|row| row.map(f64::from));
    let e = irradiance_f64(&sh, 2, [0.0, 0.0, -1.0]);
    for c in 0..3 {
        let want = f64::from(albedo[c]) * e[c] / std::f64::consts::PI;
        assert!(
            (f64::from(out.color[centre][c]) - want).abs() < 1e-5,
            "{c}: {:?}",
            out.color[centre]
        );
        assert_eq!(out.albedo[centre][c], albedo[c]);
        assert_eq!(out.albedo[0][c], 0.0, "the corner sees the background");
    }
}

/// The analytic probe SH: ambient as π·a of irradiance, and a point light's band-limited
/// clamped cosine, `π I/d² Σ_{l ≤ 2} Â_l (2l + 1)/(4π) P_l(cos θ)` (the addition theorem).
#[test]
fn probe_sh_of_the_lighting_reproduces_its_irradiance() {
    use std::f64::consts::PI;
    let lighting = Lighting {
        ambient: [0.2, 0.3, 0.4],
        environment: None,
        light: Some(Light::Point {
            position: [1.0, 2.0, -0.5],
            color: [3.0, 2.0, 1.0],
        }),
        shadow_resolution: None,
    };
    let mut seed = 0x1234_5678u64;
    let mut next = || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    };
    for _ in 0..20 {
        let point = [next(), next(), next()];
        let n = {
            let v = [next(), next(), next()];
            let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt().max(1e-3);
            v.map(|x| x / l)
        };
        let sh = lighting.radiance_sh(point);
        let e = irradiance_f64(&sh, 2, n);
        let d = [1.0 - point[0], 2.0 - point[1], -0.5 - point[2]];
        let r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        let cos = (d[0] * n[0] + d[1] * n[1] + d[2] * n[2]) / r2.sqrt();
        let legendre = [1.0, cos, 0.5 * (3.0 * cos * cos - 1.0)];
        let bands = [PI, 2.0 * PI / 3.0, PI / 4.0];
        let lobe: f64 = (0..3)
            .map(|l| bands[l] * (2 * l + 1) as f64 / (4.0 * PI) * legendre[l])
            .sum();
        for (c, (a, i)) in [(0.2, 3.0), (0.3, 2.0), (0.4, 1.0)].into_iter().enumerate() {
            let want = PI * a + PI * i / r2 * lobe;
            // f32 inputs (0.2f32 is not 0.2) bound the agreement.
            assert!(
                (e[c] - want).abs() < 1e-7 * want.abs().max(1.0),
                "{c}: {} vs {want}",
                e[c]
            );
        }
    }
}
