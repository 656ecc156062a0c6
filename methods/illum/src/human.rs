//! Stage 1 of Illum (§3.1, Eq. 1): the human as a refined, subdivided body mesh,
//! `v' = v + F_Δ(v)`, `c = F_c(v)`, with hash-encoded fields over the fixed canonical vertices
//! `v`, and Gaussians taken from the faces. No PBR yet: each face's Gaussian carries the mean
//! of its three vertex colours. The mesh is optimised only through its Gaussians (and the mesh
//! regulariser, [`splatzoo_models::laplacian::UniformLaplacian::energy`]).
//!
//! - [`BodyMesh`]: the body model subdivided `subdivisions` times (skinning carried), its
//!   height `H`, the unit cube (template AABB × 1.05) the hash grids read, and the fixed
//!   hash queries of its vertices (`[V, L·8]` rows and weights, computed once).
//! - [`RefinedBody`]: F_Δ (linear head, zero at start, each component clamped to
//!   `±max_offset·H`), F_c (sigmoid RGB), and per face a learnable in-plane angle and two
//!   in-plane log-scales (starting at the face's in-circle radius). The normal-axis σ is fixed
//!   at `1e-3·H/1.7` and the opacity at 0.99 (iHuman's layout).
//! - [`pose_refined`]: the offsets ride each vertex's blended LBS transform, so
//!   `x = R_v (v_shaped + Δ_v) + t_v`.

use crate::IllumError;
use burn::module::{Module, Param};
use burn::tensor::activation::{relu, sigmoid};
use burn::tensor::{Device, Int, Tensor, TensorData};
use splatzoo_models::anchor::{face_frames, subdivide};
use splatzoo_models::body::{BodyModel, Posed};
use splatzoo_models::networks::hash_grid::HashQueries;
use splatzoo_models::networks::hash_mlp::{HashMlp, HashMlpConfig, UnitCube};
use splatzoo_models::rotation::matrix_to_quaternion;
use splatzoo_rasterizer::Splats;

/// Stage 1's shape.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Stage1Config {
    /// Midpoint subdivisions of the body mesh (each ×4 faces).
    pub subdivisions: usize,
    /// F_Δ and F_c (one encoder each).
    pub field: HashMlpConfig,
    /// Bound on each offset component, as a fraction of the body height.
    pub max_offset: f64,
    /// The face Gaussians' fixed opacity.
    pub opacity: f64,
}

impl Default for Stage1Config {
    fn default() -> Self {
        Self {
            subdivisions: 1,
            field: HashMlpConfig::default(),
            max_offset: 0.05,
            opacity: 0.99,
        }
    }
}

/// The subdivided body and everything fixed about it.
#[derive(Debug, Clone)]
pub struct BodyMesh {
    pub model: BodyModel,
    /// `H`: the template's extent along y.
    pub height: f64,
    /// Maps the template into the hash grids' unit cube.
    pub cube: UnitCube,
    /// Each face's in-circle radius on the template.
    pub inradius: Vec<f64>,
}

impl BodyMesh {
    /// `model` subdivided `subdivisions` times.
    pub fn new(model: &BodyModel, subdivisions: usize) -> Result<Self, IllumError> {
        let mut model = model.clone();
        for _ in 0..subdivisions {
            model = subdivide(&model).0;
        }
        let vertices: Vec<[f64; 3]> = model
            .template
            .chunks(3)
            .map(|p| [p[0], p[1], p[2]].map(f64::from))
            .collect();
        let cube = UnitCube::around(&vertices, 1.05).ok_or_else(|| {
            IllumError::input("body model template", "no vertices, or non-finite ones")
        })?;
        let (lo, hi) = vertices.iter().fold((f64::MAX, f64::MIN), |(lo, hi), v| {
            (lo.min(v[1]), hi.max(v[1]))
        });
        let inradius = model
            .faces
            .chunks(3)
            .map(|t| {
                let [a, b, c] = [t[0], t[1], t[2]].map(|i| vertices[i as usize]);
                let len = |p: [f64; 3], q: [f64; 3]| {
                    ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt()
                };
                let (ab, bc, ca) = (len(a, b), len(b, c), len(c, a));
                let s = 0.5 * (ab + bc + ca);
                // Heron: area / half-perimeter, floored for degenerate faces.
                let area = (s * (s - ab) * (s - bc) * (s - ca)).max(0.0).sqrt();
                (area / s.max(1e-12)).max(1e-6)
            })
            .collect();
        Ok(Self {
            model,
            height: hi - lo,
            cube,
            inradius,
        })
    }

    pub fn vertex_count(&self) -> usize {
        self.model.vertex_count()
    }

    pub fn face_count(&self) -> usize {
        self.model.faces.len() / 3
    }

    /// `[V, 3]` template vertices.
    pub fn template(&self, device: &Device) -> Tensor<2> {
        let v = self.vertex_count();
        Tensor::<2>::from_data(TensorData::new(self.model.template.clone(), [v, 3]), device)
    }

    /// The fixed hash queries of the template vertices for a field's grid.
    pub fn queries(&self, field: &HashMlp, device: &Device) -> HashQueries {
        field.grid.queries(self.cube.apply(self.template(device)))
    }

    /// The normal-axis log-σ of the face Gaussians: `ln(1e-3·H/1.7)`.
    pub fn normal_log_scale(&self) -> f64 {
        (1e-3 * self.height / 1.7).ln()
    }
}

/// F_Δ, F_c and the faces' in-plane parameters (Eq. 1).
#[derive(Module, Debug)]
pub struct RefinedBody {
    pub offset: HashMlp,
    pub colour: HashMlp,
    /// `[F, 3]`: in-plane angle (radians) and the two in-plane log-scales.
    pub in_plane: Param<Tensor<2>>,
    #[module(skip)]
    max_offset: f64,
    #[module(skip)]
    opacity: f64,
}

impl RefinedBody {
    pub fn new(mesh: &BodyMesh, config: &Stage1Config, seed: u64, device: &Device) -> Self {
        let f = mesh.face_count();
        let in_plane: Vec<f32> = mesh
            .inradius
            .iter()
            .flat_map(|&r| [0.0, r.ln() as f32, r.ln() as f32])
            .collect();
        Self {
            offset: HashMlp::new(config.field, 3, true, seed, device),
            colour: HashMlp::new(config.field, 3, false, seed.wrapping_add(1), device),
            in_plane: Param::from_tensor(Tensor::<2>::from_data(
                TensorData::new(in_plane, [f, 3]),
                device,
            )),
            max_offset: config.max_offset * mesh.height,
            opacity: config.opacity,
        }
    }

    /// `Δ = F_Δ(v)` `[V, 3]`, each component clamped to `±max_offset·H`.
    pub fn offsets(&self, queries: &HashQueries) -> Tensor<2> {
        self.offsets_from_code(self.offset.grid.encode_queries(queries))
    }

    /// The bound `max_offset·H` on each component of Δ (metres).
    pub fn max_offset(&self) -> f64 {
        self.max_offset
    }

    /// F_Δ's network from its hash codes `[R, L·F]` → `[R, 3]` clamped offsets (what
    /// `offsets.onnx` computes).
    pub fn offsets_from_code(&self, code: Tensor<2>) -> Tensor<2> {
        self.offset
            .forward_code(code)
            .clamp(-self.max_offset, self.max_offset)
    }

    /// [`Self::offsets_from_code`] as `offsets.onnx` computes it: burn-onnx 0.22 cannot lower
    /// `clamp`, so the bound is `relu(2m − relu(m − x)) − m`: exactly `±m` beyond the bound
    /// (no cancellation however large `x`), `x` up to a rounding of `m` inside it (tested
    /// against the clamp).
    pub fn offsets_for_export(&self, code: Tensor<2>) -> Tensor<2> {
        let x = self.offset.forward_code(code);
        let m = self.max_offset;
        relu(relu(x.neg() + m).neg() + 2.0 * m) - m
    }

    /// `c = F_c(v)` `[V, 3]` in (0, 1).
    pub fn vertex_colours(&self, queries: &HashQueries) -> Tensor<2> {
        self.colours_from_code(self.colour.grid.encode_queries(queries))
    }

    /// F_c's network from its hash codes `[R, L·F]` → `[R, 3]` in (0, 1) (what `colours.onnx`
    /// computes).
    pub fn colours_from_code(&self, code: Tensor<2>) -> Tensor<2> {
        sigmoid(self.colour.forward_code(code))
    }

    /// One Gaussian per face of the posed refined mesh `[V, 3]`: at the barycentre, oriented
    /// by the face frame turned by its in-plane angle, coloured by the mean of its vertices'
    /// colours `[V, 3]` (features, `[F, 1, 3]`).
    pub fn face_splats(&self, mesh: &BodyMesh, posed: Tensor<2>, colours: Tensor<2>) -> Splats {
        let v = mesh.vertex_count();
        let f = mesh.face_count();
        assert_eq!(posed.dims(), [v, 3], "posed vertices must be [{v}, 3]");
        assert_eq!(colours.dims(), [v, 3], "vertex colours must be [{v}, 3]");
        let device = posed.device();
        let faces = &mesh.model.faces;
        let corner = |k: usize| {
            let idx: Vec<i64> = faces.chunks(3).map(|t| t[k] as i64).collect();
            Tensor::<1, Int>::from_data(TensorData::new(idx, [f]), &device)
        };
        let corners = [corner(0), corner(1), corner(2)];
        let mean_of = |values: &Tensor<2>| {
            corners
                .iter()
                .map(|idx| values.clone().select(0, idx.clone()))
                .reduce(|a, b| a + b)
                .expect("three corners")
                / 3.0
        };
        let means = mean_of(&posed);
        let colours = mean_of(&colours).reshape([f, 1, 3]);
        let frames = face_frames(posed.reshape([1, v, 3]), faces).reshape([f, 3, 3]);
        let in_plane = self.in_plane.val();
        let angle = in_plane.clone().slice([0..f, 0..1]);
        let (cos, sin) = (angle.clone().cos(), angle.sin());
        let zero = cos.zeros_like();
        let one = zero.ones_like();
        // Columns (cos, sin, 0), (−sin, cos, 0), (0, 0, 1): a turn about the face normal.
        let turn = Tensor::cat(
            vec![
                cos.clone(),
                sin.clone().neg(),
                zero.clone(),
                sin,
                cos,
                zero.clone(),
                zero.clone(),
                zero,
                one,
            ],
            1,
        )
        .reshape([f, 3, 3]);
        let rotations = frames.matmul(turn);
        let normal_scale = Tensor::<2>::full([f, 1], mesh.normal_log_scale() as f32, &device);
        let log_scales = Tensor::cat(vec![in_plane.slice([0..f, 1..3]), normal_scale], 1);
        let logit = (self.opacity / (1.0 - self.opacity)).ln();
        Splats {
            means,
            quats: matrix_to_quaternion(rotations),
            log_scales,
            opacity_logits: Tensor::<1>::full([f], logit as f32, &device),
            colors: colours,
        }
    }
}

/// The refined mesh posed by LBS: `x = R_v (v_shaped + Δ_v) + t_v` `[B, V, 3]`, from a posed
/// batch of the same (subdivided) model and offsets `[V, 3]` (pose correctives, which
/// `posed.vertices` carries, are kept).
pub fn pose_refined(posed: &Posed, offsets: Tensor<2>) -> Tensor<3> {
    let [b, v, _] = posed.vertices.dims();
    assert_eq!(offsets.dims(), [v, 3], "offsets must be [{v}, 3]");
    let turned = posed
        .vertex_rotations
        .clone()
        .matmul(offsets.reshape([1, v, 3, 1]).expand([b, v, 3, 1]))
        .reshape([b, v, 3]);
    posed.vertices.clone() + turned
}
