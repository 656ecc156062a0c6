//! Vertex normals: the Burn ops against the f64 reference on fresh random meshes, analytic
//! normals of a symmetric solid, gradients against finite differences, degenerate meshes; and
//! the uniform mesh Laplacian, the other per-vertex mesh operator.

use crate::common::values;
use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_models::body::builtin_body;
use splatzoo_models::normals::{vertex_normals, vertex_normals_reference};

fn seed() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .expect("clock")
        .as_nanos() as u64
}

/// A SplitMix64 stream of uniforms in [-1, 1).
struct Stream(u64);

impl Stream {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }
}

fn tensor(vertices: &[[f64; 3]], device: &Device) -> Tensor<3> {
    let flat: Vec<f32> = vertices.iter().flatten().map(|&v| v as f32).collect();
    Tensor::<3>::from_data(TensorData::new(flat, [1, vertices.len(), 3]), device)
}

/// The built-in body's mesh with every vertex jittered by up to 5 mm.
fn jittered_body(stream: &mut Stream) -> (Vec<[f64; 3]>, Vec<u32>) {
    let body = builtin_body();
    let model = &body.model;
    let vertices = model
        .template
        .chunks(3)
        .map(|p| [0, 1, 2].map(|k| f64::from(p[k]) + 0.005 * stream.next()))
        .collect();
    (vertices, model.faces.clone())
}

/// The Burn ops agree with the f64 reference on a jittered body mesh.
#[test]
fn vertex_normals_match_the_reference() {
    let s = seed();
    let mut stream = Stream(s);
    let (vertices, faces) = jittered_body(&mut stream);
    let device = Device::flex();
    let got = values(vertex_normals(tensor(&vertices, &device), &faces));
    let want = vertex_normals_reference(&vertices, &faces);
    let worst = want
        .iter()
        .flatten()
        .zip(&got)
        .map(|(w, g)| (w - f64::from(*g)).abs())
        .fold(0.0, f64::max);
    assert!(worst < 1e-4, "seed {s}: worst component error {worst}");
    let unit = want
        .iter()
        .all(|n| ((n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt() - 1.0).abs() < 1e-9);
    assert!(
        unit,
        "seed {s}: every vertex of a closed mesh has a unit normal"
    );
}

/// A regular octahedron's vertex normals point along its vertices (symmetry), outward.
#[test]
fn octahedron_normals_are_analytic() {
    let vertices = [
        [1.0, 0.0, 0.0],
        [-1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
    ];
    // Counter-clockwise seen from outside.
    let faces: Vec<u32> = vec![
        0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5,
    ];
    let got = values(vertex_normals(tensor(&vertices, &Device::flex()), &faces));
    for (k, v) in vertices.iter().enumerate() {
        for c in 0..3 {
            assert!(
                (f64::from(got[3 * k + c]) - v[c]).abs() < 1e-6,
                "vertex {k}: {:?} vs {v:?}",
                &got[3 * k..3 * k + 3]
            );
        }
    }
}

/// `d(Σ w·n)/dv` matches central differences of the f64 reference.
#[test]
fn vertex_normal_gradients_match_finite_differences() {
    let s = seed();
    let mut stream = Stream(s);
    // A small open fan plus a closed tetrahedron: boundary and interior vertices.
    let mut vertices: Vec<[f64; 3]> = (0..9)
        .map(|_| [stream.next(), stream.next(), stream.next()])
        .collect();
    vertices[0] = [0.0, 0.0, 0.0];
    let faces: Vec<u32> = vec![
        0, 1, 2, 0, 2, 3, 0, 3, 4, 5, 6, 7, 5, 7, 8, 5, 8, 6, 6, 8, 7,
    ];
    let weights: Vec<f64> = (0..vertices.len() * 3).map(|_| stream.next()).collect();
    let objective = |v: &[[f64; 3]]| -> f64 {
        vertex_normals_reference(v, &faces)
            .iter()
            .flatten()
            .zip(&weights)
            .map(|(n, w)| n * w)
            .sum()
    };
    let device = Device::flex().autodiff();
    let input = tensor(&vertices, &device).require_grad();
    let w: Vec<f32> = weights.iter().map(|&w| w as f32).collect();
    let w = Tensor::<3>::from_data(TensorData::new(w, [1, vertices.len(), 3]), &device);
    let loss = (vertex_normals(input.clone(), &faces) * w).sum();
    let grads = loss.backward();
    let got = values(input.grad(&grads).expect("a gradient on the vertices"));
    let h = 1e-6;
    for k in 0..vertices.len() {
        for c in 0..3 {
            let mut plus = vertices.clone();
            plus[k][c] += h;
            let mut minus = vertices.clone();
            minus[k][c] -= h;
            let fd = (objective(&plus) - objective(&minus)) / (2.0 * h);
            let g = f64::from(got[3 * k + c]);
            assert!(
                (g - fd).abs() < 2e-3 * (1.0 + fd.abs()),
                "seed {s}: vertex {k} axis {c}: autodiff {g} vs finite difference {fd}"
            );
        }
    }
}

/// An isolated vertex and a collapsed triangle give zero normals and finite gradients.
#[test]
fn degenerate_meshes_give_zero_normals_and_finite_gradients() {
    let vertices = [
        [0.0, 0.0, 0.0],
        [0.0, 0.0, 0.0],
        [0.0, 0.0, 0.0],
        [1.0, 2.0, 3.0], // touched by no face
    ];
    let faces = vec![0, 1, 2];
    let device = Device::flex().autodiff();
    let input = tensor(&vertices, &device).require_grad();
    let normals = vertex_normals(input.clone(), &faces);
    let got = values(normals.clone());
    assert!(got.iter().all(|v| *v == 0.0), "{got:?}");
    let grads = normals.sum().backward();
    let g = values(input.grad(&grads).expect("gradient"));
    assert!(g.iter().all(|v| v.is_finite()), "{g:?}");
    let reference = vertex_normals_reference(&vertices, &faces);
    assert!(reference.iter().flatten().all(|v| *v == 0.0));
}

/// The uniform Laplacian against its f64 reference on the jittered body; zero on an affine
/// field's interior (a flat grid's inner vertices), its energy's gradient against finite
/// differences, an isolated vertex contributing nothing.
#[test]
fn the_uniform_laplacian_matches_its_reference_and_its_energy_gradient() {
    use splatzoo_models::laplacian::UniformLaplacian;
    let s = seed();
    let mut stream = Stream(s);
    let (vertices, faces) = jittered_body(&mut stream);
    let laplacian = UniformLaplacian::new(vertices.len(), &faces);
    let device = Device::flex();
    let got = values(laplacian.apply(tensor(&vertices, &device)));
    let want = laplacian.apply_reference(&vertices);
    for (g, w) in got.chunks(3).zip(&want) {
        for k in 0..3 {
            assert!(
                (f64::from(g[k]) - w[k]).abs() < 1e-5,
                "seed {s}: {g:?} vs {w:?}"
            );
        }
    }
    // A 4×4 planar grid (two triangles per square) plus one isolated vertex.
    let mut grid: Vec<[f64; 3]> = (0..16)
        .map(|i| [(i % 4) as f64, (i / 4) as f64, 0.5 * (i % 4) as f64])
        .collect();
    grid.push([9.0, 9.0, 9.0]);
    let mut quads = Vec::new();
    for y in 0..3u32 {
        for x in 0..3u32 {
            let a = y * 4 + x;
            quads.extend([a, a + 1, a + 5, a, a + 5, a + 4]);
        }
    }
    let flat = UniformLaplacian::new(grid.len(), &quads);
    let lv = flat.apply_reference(&grid);
    // Inner vertices of this triangulation have 6 neighbours symmetric about them.
    for i in [5usize, 6, 9, 10] {
        assert!(
            lv[i].iter().all(|v| v.abs() < 1e-12),
            "vertex {i}: {:?}",
            lv[i]
        );
    }
    assert_eq!(lv[16], [0.0; 3]);
    assert_eq!(values(flat.apply(tensor(&grid, &device)))[48..51], [0.0; 3]);
    // The energy's gradient against central differences.
    let leaf = tensor(&grid, &device).autodiff().require_grad();
    let grads = flat.energy(leaf.clone()).backward();
    let g = values(leaf.grad(&grads).unwrap());
    let energy = |v: &[[f64; 3]]| {
        flat.apply_reference(v)
            .iter()
            .map(|l| l.iter().map(|x| x * x).sum::<f64>())
            .sum::<f64>()
            / v.len() as f64
    };
    for (i, k) in [(0usize, 0usize), (5, 2), (7, 1), (16, 0)] {
        let h = 1e-5;
        let mut plus = grid.clone();
        plus[i][k] += h;
        let mut minus = grid.clone();
        minus[i][k] -= h;
        let fd = (energy(&plus) - energy(&minus)) / (2.0 * h);
        assert!(
            (fd - f64::from(g[i * 3 + k])).abs() < 1e-4,
            "{i},{k}: {} vs {fd}",
            g[i * 3 + k]
        );
    }
}
