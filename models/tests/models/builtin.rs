//! The built-in body: closed manifold mesh, SMPL skeleton layout, exact shape space and joint
//! regressor, smooth skinning, regions and texture charts, and driving it with SMPL poses.

use crate::common::values;
use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_models::body::builtin::proportions::Skeleton;
use splatzoo_models::body::builtin::{SHAPE_COUNT, generate};
use splatzoo_models::body::lbs::{self, BodyTensors, PoseInput};
use splatzoo_models::body::skeleton::{SMPL_JOINT_NAMES, SMPL_PARENTS};
use splatzoo_models::body::{BuiltinBody, builtin_body};
use std::collections::{HashMap, HashSet, VecDeque};

fn vertex(body: &BuiltinBody, i: usize) -> [f64; 3] {
    let t = &body.model.template;
    [t[3 * i] as f64, t[3 * i + 1] as f64, t[3 * i + 2] as f64]
}

fn triangles(body: &BuiltinBody) -> impl Iterator<Item = [usize; 3]> + '_ {
    body.model
        .faces
        .chunks(3)
        .map(|f| [f[0] as usize, f[1] as usize, f[2] as usize])
}

/// Vertices for shape coefficients `betas` (template + shape directions), f64.
fn shaped(body: &BuiltinBody, betas: &[f64]) -> Vec<[f64; 3]> {
    let s = body.model.shape_count();
    (0..body.model.vertex_count())
        .map(|i| {
            let mut p = vertex(body, i);
            for (k, pk) in p.iter_mut().enumerate() {
                for (c, &b) in betas.iter().enumerate() {
                    *pk += b * body.model.shape_dirs[(i * 3 + k) * s + c] as f64;
                }
            }
            p
        })
        .collect()
}

fn regress(body: &BuiltinBody, vertices: &[[f64; 3]]) -> Vec<[f64; 3]> {
    let v = vertices.len();
    (0..body.model.joint_count())
        .map(|j| {
            let mut p = [0.0; 3];
            for (i, x) in vertices.iter().enumerate() {
                let w = body.model.joint_regressor[j * v + i] as f64;
                for k in 0..3 {
                    p[k] += w * x[k];
                }
            }
            p
        })
        .collect()
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

#[test]
fn mesh_is_a_closed_oriented_sphere_of_the_right_size() {
    let body = builtin_body();
    let v = body.model.vertex_count();
    assert!((5000..=10000).contains(&v), "{v} vertices");
    let mut directed: HashMap<(usize, usize), usize> = HashMap::new();
    for f in triangles(body) {
        assert!(
            f[0] != f[1] && f[1] != f[2] && f[0] != f[2],
            "degenerate face {f:?}"
        );
        for k in 0..3 {
            *directed.entry((f[k], f[(k + 1) % 3])).or_default() += 1;
        }
    }
    for (&(a, b), &n) in &directed {
        assert_eq!(n, 1, "edge {a}->{b} used {n} times in one direction");
        assert_eq!(
            directed.get(&(b, a)),
            Some(&1),
            "edge {a}-{b} is a boundary or non-manifold edge"
        );
    }
    let edges = directed.len() / 2;
    let faces = body.model.face_count();
    assert_eq!(
        v as i64 - edges as i64 + faces as i64,
        2,
        "Euler characteristic"
    );
    // One connected component.
    let mut nb = vec![Vec::new(); v];
    for &(a, b) in directed.keys() {
        nb[a].push(b);
    }
    let mut seen = vec![false; v];
    let mut queue = VecDeque::from([0usize]);
    seen[0] = true;
    while let Some(a) = queue.pop_front() {
        for &b in &nb[a] {
            if !seen[b] {
                seen[b] = true;
                queue.push_back(b);
            }
        }
    }
    assert!(seen.iter().all(|&s| s), "mesh has more than one component");
    // Outward orientation and a human volume (SMPL's mean body is about 0.07 m³).
    let volume: f64 = triangles(body)
        .map(|[a, b, c]| {
            let (p, q, r) = (vertex(body, a), vertex(body, b), vertex(body, c));
            (p[0] * (q[1] * r[2] - q[2] * r[1]) - p[1] * (q[0] * r[2] - q[2] * r[0])
                + p[2] * (q[0] * r[1] - q[1] * r[0]))
                / 6.0
        })
        .sum();
    assert!((0.05..0.10).contains(&volume), "volume {volume} m³");
    let ys: Vec<f64> = (0..v).map(|i| vertex(body, i)[1]).collect();
    let height =
        ys.iter().cloned().fold(f64::MIN, f64::max) - ys.iter().cloned().fold(f64::MAX, f64::min);
    assert!((1.6..1.8).contains(&height), "height {height} m");
}

#[test]
fn triangles_are_well_shaped() {
    let body = builtin_body();
    let mut small = 0;
    let mut worst = f64::MAX;
    for [a, b, c] in triangles(body) {
        let p = [vertex(body, a), vertex(body, b), vertex(body, c)];
        let mut min_angle = f64::MAX;
        for k in 0..3 {
            let (o, u, w) = (p[k], p[(k + 1) % 3], p[(k + 2) % 3]);
            let d1 = [u[0] - o[0], u[1] - o[1], u[2] - o[2]];
            let d2 = [w[0] - o[0], w[1] - o[1], w[2] - o[2]];
            let cos = (d1[0] * d2[0] + d1[1] * d2[1] + d1[2] * d2[2]) / (dist(u, o) * dist(w, o));
            min_angle = min_angle.min(cos.clamp(-1.0, 1.0).acos().to_degrees());
        }
        worst = worst.min(min_angle);
        if min_angle < 20.0 {
            small += 1;
        }
    }
    let fraction = small as f64 / body.model.face_count() as f64;
    eprintln!("min angle {worst:.2}°, {:.2}% below 20°", 100.0 * fraction);
    assert!(
        fraction < 0.03,
        "{:.2}% of triangles have an angle below 20°",
        100.0 * fraction
    );
    assert!(worst > 3.0, "a sliver triangle of {worst}°");
}

#[test]
fn skeleton_is_smpls_and_the_regressor_reproduces_it_for_every_shape() {
    let body = builtin_body();
    body.model.validate("builtin").unwrap();
    assert_eq!(
        body.model.joint_names,
        SMPL_JOINT_NAMES.map(String::from).to_vec()
    );
    assert_eq!(body.model.parents, SMPL_PARENTS.to_vec());
    assert!(body.model.shape_count() >= 10);
    let rest = regress(body, &shaped(body, &[]));
    for (j, (got, want)) in rest.iter().zip(Skeleton::mean().heads).enumerate() {
        assert!(dist(*got, want) < 1e-4, "joint {j}: {got:?} vs {want:?}");
    }
    // Left joints on +x, mirrored on the right.
    for (l, r) in [(1, 2), (13, 14), (16, 17), (18, 19), (20, 21), (7, 8)] {
        assert!(rest[l][0] > 0.05 && (rest[l][0] + rest[r][0]).abs() < 1e-3);
    }
    let mut rng_state = 7u64;
    let mut next = || {
        rng_state = rng_state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((rng_state >> 11) as f64 / (1u64 << 53) as f64) * 10.0 - 5.0
    };
    for trial in 0..3 {
        let betas: Vec<f64> = (0..SHAPE_COUNT).map(|_| next()).collect();
        let joints = regress(body, &shaped(body, &betas));
        let want = Skeleton::shaped(&betas).heads;
        for j in 0..24 {
            assert!(
                dist(joints[j], want[j]) < 1e-3,
                "trial {trial}, joint {j}: {:?} vs {:?}",
                joints[j],
                want[j]
            );
        }
    }
}

/// Each shape component, at +1 against −1, grows what it names.
#[test]
fn shape_components_change_what_they_name() {
    let body = builtin_body();
    let labelled = |l: &[u8]| -> Vec<usize> {
        (0..body.model.vertex_count())
            .filter(|&i| l.contains(&body.part_of_vertex[i]))
            .collect()
    };
    let extent = |vs: &[[f64; 3]], ids: &[usize], axis: usize| {
        let xs = ids.iter().map(|&i| vs[i][axis]);
        xs.clone().fold(f64::MIN, f64::max) - xs.fold(f64::MAX, f64::min)
    };
    let max_along = |vs: &[[f64; 3]], ids: &[usize], axis: usize| {
        ids.iter().map(|&i| vs[i][axis]).fold(f64::MIN, f64::max)
    };
    let all: Vec<usize> = (0..body.model.vertex_count()).collect();
    let torso = labelled(&[3, 6]);
    let chest = labelled(&[9]);
    let belly = labelled(&[3]);
    let head = labelled(&[15]);
    let upper_arm = labelled(&[16]);
    let pelvis = labelled(&[0]);
    type Measure<'a> = Box<dyn Fn(&[[f64; 3]]) -> f64 + 'a>;
    let measures: Vec<(usize, Measure)> = vec![
        (0, Box::new(|v| extent(v, &all, 1))),
        (1, Box::new(|v| extent(v, &torso, 0) + extent(v, &torso, 2))),
        (
            2,
            Box::new(|v| {
                let j = regress(body, v);
                dist(j[1], j[7])
            }),
        ),
        (
            3,
            Box::new(|v| {
                let j = regress(body, v);
                dist(j[16], j[20])
            }),
        ),
        (
            4,
            Box::new(|v| {
                let j = regress(body, v);
                dist(j[16], j[17])
            }),
        ),
        (5, Box::new(|v| extent(v, &pelvis, 0))),
        (
            6,
            Box::new(|v| {
                let j = regress(body, v);
                dist(j[0], j[12])
            }),
        ),
        (7, Box::new(|v| extent(v, &chest, 2))),
        (8, Box::new(|v| max_along(v, &belly, 2))),
        (9, Box::new(|v| extent(v, &head, 1))),
        (
            10,
            Box::new(|v| {
                let j = regress(body, v);
                dist(j[12], j[15])
            }),
        ),
        (11, Box::new(|v| extent(v, &upper_arm, 1))),
    ];
    for (component, measure) in measures {
        let mut betas = vec![0.0; SHAPE_COUNT];
        betas[component] = 1.0;
        let plus = measure(&shaped(body, &betas));
        betas[component] = -1.0;
        let minus = measure(&shaped(body, &betas));
        assert!(
            plus > minus * 1.01,
            "component {component}: {plus} at +1 vs {minus} at −1"
        );
    }
}

#[test]
fn skinning_weights_are_normalised_sparse_and_smooth() {
    let body = builtin_body();
    let j = body.model.joint_count();
    let w = &body.model.skin_weights;
    for row in w.chunks(j) {
        assert!(row.iter().all(|&x| x >= 0.0));
        assert!((row.iter().sum::<f32>() - 1.0).abs() < 1e-5);
        assert!(row.iter().filter(|&&x| x > 0.0).count() <= 4);
    }
    let mut worst = 0.0f32;
    for [a, b, c] in triangles(body) {
        for (p, q) in [(a, b), (b, c), (c, a)] {
            for k in 0..j {
                worst = worst.max((w[p * j + k] - w[q * j + k]).abs());
            }
        }
    }
    assert!(worst < 0.35, "weights jump by {worst} across an edge");
    // Every joint carries some part of the body.
    for k in 0..j {
        let owned = (0..body.model.vertex_count())
            .filter(|&i| w[i * j + k] > 0.5)
            .count();
        assert!(
            owned >= 10,
            "joint {k} ({}) leads only {owned} vertices",
            SMPL_JOINT_NAMES[k]
        );
    }
}

#[test]
fn face_hands_feet_landmarks_and_regions() {
    let body = builtin_body();
    let face: Vec<usize> = (0..body.model.vertex_count())
        .filter(|&i| body.face_region[i])
        .collect();
    assert!(face.len() > 100, "{} face vertices", face.len());
    let nose = body.landmark("nose_tip").unwrap() as usize;
    assert!(body.face_region[nose]);
    let head: Vec<usize> = (0..body.model.vertex_count())
        .filter(|&i| body.part_of_vertex[i] == 15)
        .collect();
    let front = head
        .iter()
        .map(|&i| vertex(body, i)[2])
        .fold(f64::MIN, f64::max);
    assert!(
        (vertex(body, nose)[2] - front).abs() < 0.01,
        "nose tip is not the front of the head"
    );
    for part in [20u8, 21, 22, 23, 7, 8, 10, 11] {
        let n = body.part_of_vertex.iter().filter(|&&p| p == part).count();
        assert!(n >= 40, "part {part} has {n} vertices");
    }
    let left_eye = vertex(body, body.landmark("left_eye").unwrap() as usize);
    let right_eye = vertex(body, body.landmark("right_eye").unwrap() as usize);
    assert!(
        left_eye[0] > 0.01 && right_eye[0] < -0.01 && (left_eye[1] - right_eye[1]).abs() < 0.01
    );
    let toe = vertex(body, body.landmark("left_toe").unwrap() as usize);
    let heel = vertex(body, body.landmark("left_heel").unwrap() as usize);
    assert!(toe[2] - heel[2] > 0.18, "foot length {}", toe[2] - heel[2]);
}

/// Rasterises every UV triangle and checks charts do not cover each other.
#[test]
fn texture_charts_fit_the_unit_square_without_overlap() {
    let body = builtin_body();
    let uv = &body.uv;
    assert_eq!(uv.faces.len(), body.model.faces.len());
    assert!(uv.coords.iter().all(|&c| (0.0..=1.0).contains(&c)));
    const N: usize = 512;
    let mut owner = vec![u8::MAX; N * N];
    let mut clashes = 0usize;
    let mut covered = 0usize;
    let mut flipped = 0usize;
    for (f, face) in triangles(body).enumerate() {
        let chart = {
            let l = face.map(|v| body.part_of_vertex[v]);
            if l[1] == l[2] { l[1] } else { l[0] }
        };
        let c: [[f32; 2]; 3] = std::array::from_fn(|k| {
            let t = uv.faces[3 * f + k] as usize;
            [uv.coords[2 * t] * N as f32, uv.coords[2 * t + 1] * N as f32]
        });
        let area =
            (c[1][0] - c[0][0]) * (c[2][1] - c[0][1]) - (c[2][0] - c[0][0]) * (c[1][1] - c[0][1]);
        if area < 0.0 {
            flipped += 1;
        }
        let (x0, x1) = (
            c.iter().map(|p| p[0]).fold(f32::MAX, f32::min),
            c.iter().map(|p| p[0]).fold(f32::MIN, f32::max),
        );
        let (y0, y1) = (
            c.iter().map(|p| p[1]).fold(f32::MAX, f32::min),
            c.iter().map(|p| p[1]).fold(f32::MIN, f32::max),
        );
        for y in (y0.floor().max(0.0) as usize)..(y1.ceil().min(N as f32) as usize) {
            for x in (x0.floor().max(0.0) as usize)..(x1.ceil().min(N as f32) as usize) {
                let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
                let edge = |a: [f32; 2], b: [f32; 2]| {
                    (b[0] - a[0]) * (py - a[1]) - (b[1] - a[1]) * (px - a[0])
                };
                let e = [edge(c[0], c[1]), edge(c[1], c[2]), edge(c[2], c[0])];
                if e.iter().all(|&v| v >= 0.0) || e.iter().all(|&v| v <= 0.0) {
                    let o = &mut owner[y * N + x];
                    if *o == u8::MAX {
                        *o = chart;
                        covered += 1;
                    } else if *o != chart {
                        clashes += 1;
                    }
                }
            }
        }
    }
    let faces = body.model.face_count();
    assert!(
        covered > N * N / 5,
        "charts cover only {covered} of {} texels",
        N * N
    );
    assert!(clashes == 0, "{clashes} texels claimed by two charts");
    assert!(
        (flipped as f64) < 0.03 * faces as f64,
        "{flipped} of {faces} UV triangles flipped"
    );
}

#[test]
fn a_72d_smpl_pose_drives_it() {
    let body = builtin_body();
    let device = Device::flex();
    let tensors = BodyTensors::new(&body.model, &device);
    let mut pose = vec![0.0f32; 72];
    // Left elbow bent 90° about y (forearm forward), right shoulder lowered 70° about z.
    pose[18 * 3 + 1] = -std::f32::consts::FRAC_PI_2;
    pose[17 * 3 + 2] = 1.2;
    let input = PoseInput::from_axis_angle(
        Tensor::<2>::zeros([1, SHAPE_COUNT], &device),
        Tensor::<2>::from_data(TensorData::new(pose, [1, 72]), &device),
        Tensor::<2>::zeros([1, 3], &device),
    );
    let posed = values(lbs::pose(&tensors, &input).vertices);
    assert!(posed.iter().all(|x| x.is_finite()));
    let at = |i: u32| {
        let i = i as usize;
        [
            posed[3 * i] as f64,
            posed[3 * i + 1] as f64,
            posed[3 * i + 2] as f64,
        ]
    };
    let left_tip = body.landmark("left_fingertip").unwrap();
    let right_tip = body.landmark("right_fingertip").unwrap();
    let (rest_l, rest_r) = (
        vertex(body, left_tip as usize),
        vertex(body, right_tip as usize),
    );
    let (new_l, new_r) = (at(left_tip), at(right_tip));
    // Forearm now points forward (+z) from the elbow; the right arm hangs down.
    assert!(
        new_l[2] - rest_l[2] > 0.3,
        "left fingertip {new_l:?} from {rest_l:?}"
    );
    assert!(
        rest_r[1] - new_r[1] > 0.4,
        "right fingertip {new_r:?} from {rest_r:?}"
    );
    // The head and the feet stay put.
    for name in ["nose_tip", "left_toe", "right_heel"] {
        let i = body.landmark(name).unwrap();
        assert!(dist(at(i), vertex(body, i as usize)) < 1e-4, "{name} moved");
    }
}

#[test]
fn generation_is_deterministic() {
    let again = generate();
    let body = builtin_body();
    assert_eq!(again.model.template, body.model.template);
    assert_eq!(again.model.faces, body.model.faces);
    assert_eq!(again.model.skin_weights, body.model.skin_weights);
    assert_eq!(again.uv.coords, body.uv.coords);
    let distinct: HashSet<u32> = body.model.faces.iter().copied().collect();
    assert_eq!(distinct.len(), body.model.vertex_count(), "unused vertices");
}
