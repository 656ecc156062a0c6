//! The synthetic identities of the embedded default (spec §7, preset `portrait`): K people on
//! the built-in body in the canonical pose, each with its baked texture, photographed by the
//! independent CPU mesh renderer — never by the splat rasterizer — under a studio light. They
//! are the mixture oracle's data ([`Targets`]) and the truth the avatar is scored against.

use crate::data::PortraitConfig;
use crate::oracle::Targets;
use splatzoo_datasets::render::{
    Albedo, Light, Lighting, MeshInstance, MeshRender, RenderSettings, Texture, render,
};
use splatzoo_datasets::synth::identity::Identity;
use splatzoo_models::body::builtin_body;
use splatzoo_rasterizer::Camera;

/// Texture size of each identity.
const TEXTURE_SIZE: usize = 512;

/// One identity's canonical mesh and texture, in normalised units.
#[derive(Debug, Clone)]
pub struct IdentityMesh {
    pub identity: Identity,
    /// `[V]` normalised canonical vertices.
    pub vertices: Vec<[f32; 3]>,
    pub texture: Texture,
    /// With `view_variants`: the textures the oracle shows from the body's left and right
    /// sides (skin lighter and darker, hair recoloured); empty otherwise.
    pub side_textures: Vec<Texture>,
}

/// The identities seen from any camera: the oracle's [`Targets`].
#[derive(Debug, Clone)]
pub struct IdentityBank {
    pub identities: Vec<IdentityMesh>,
    pub faces: Vec<[u32; 3]>,
    pub uv_coords: Vec<[f32; 2]>,
    pub uv_faces: Vec<[u32; 3]>,
    pub lighting: Lighting,
    pub settings: RenderSettings,
}

/// The light every identity is photographed under: ambient plus a frontal key light, no
/// shadows (a studio portrait).
pub fn studio_lighting() -> Lighting {
    Lighting {
        ambient: [0.55; 3],
        environment: None,
        light: Some(Light::Directional {
            direction: [-0.3, -0.5, -1.0],
            color: [0.5; 3],
        }),
        shadow_resolution: None,
    }
}

impl IdentityBank {
    /// The identities of `config`, each posed as `posed` says (body-space vertices) and moved
    /// into the capture's units by `normalise`.
    pub fn build(
        config: &PortraitConfig,
        identities: &[Identity],
        posed: &[Vec<[f32; 3]>],
        normalise: impl Fn(&[f32; 3]) -> [f32; 3],
    ) -> Self {
        let body = builtin_body();
        Self {
            identities: identities
                .iter()
                .zip(posed)
                .enumerate()
                .map(|(k, (identity, vertices))| IdentityMesh {
                    texture: identity.bake_texture(body, TEXTURE_SIZE),
                    side_textures: if config.view_variants && k == config.prompt {
                        side_variants(identity)
                            .iter()
                            .map(|v| v.bake_texture(body, TEXTURE_SIZE))
                            .collect()
                    } else {
                        Vec::new()
                    },
                    identity: identity.clone(),
                    vertices: vertices.iter().map(&normalise).collect(),
                })
                .collect(),
            faces: body
                .model
                .faces
                .chunks(3)
                .map(|f| [f[0], f[1], f[2]])
                .collect(),
            uv_coords: body.uv.coords.chunks(2).map(|c| [c[0], c[1]]).collect(),
            uv_faces: body
                .uv
                .faces
                .chunks(3)
                .map(|f| [f[0], f[1], f[2]])
                .collect(),
            lighting: studio_lighting(),
            settings: RenderSettings {
                background: [0.0; 3],
                supersample: 1,
            },
        }
    }

    pub fn render(&self, label: usize, camera: &Camera) -> MeshRender {
        self.render_posed(label, &self.identities[label].vertices, camera)
    }

    /// Identity `label`'s textured mesh with its vertices moved to `vertices` (a pose).
    pub fn render_posed(&self, label: usize, vertices: &[[f32; 3]], camera: &Camera) -> MeshRender {
        self.render_textured(vertices, &self.identities[label].texture, camera)
    }

    /// What the oracle sees of identity `label` from `camera`: its own texture, or with
    /// `view_variants` a side variant when the camera is on the body's left or right
    /// (45° < |azimuth| < 135°, the azimuth measured from the body's front, +z).
    pub fn oracle_render(&self, label: usize, camera: &Camera) -> MeshRender {
        let mesh = &self.identities[label];
        let texture = match mesh.side_textures.as_slice() {
            [left, right] => {
                let m = &camera.world_to_camera;
                let centre: [f32; 3] =
                    std::array::from_fn(|k| -(0..3).map(|r| m[r][k] * m[r][3]).sum::<f32>());
                let azimuth = f64::from(centre[0])
                    .atan2(f64::from(centre[2]))
                    .to_degrees();
                if (45.0..135.0).contains(&azimuth) {
                    left
                } else if (-135.0..-45.0).contains(&azimuth) {
                    right
                } else {
                    &mesh.texture
                }
            }
            _ => &mesh.texture,
        };
        self.render_textured(&mesh.vertices, texture, camera)
    }

    fn render_textured(
        &self,
        vertices: &[[f32; 3]],
        texture: &Texture,
        camera: &Camera,
    ) -> MeshRender {
        let instance = MeshInstance {
            positions: vertices,
            faces: &self.faces,
            albedo: Albedo::Textured {
                coords: &self.uv_coords,
                corners: &self.uv_faces,
                texture,
            },
            label: 1,
            smooth: true,
        };
        render(&[instance], camera, &self.lighting, &self.settings)
    }
}

/// A mesh render as the model's two branches, `[3, H, W]` RGB and `[1, H, W]` depth, each
/// mapped from [0, 1] to [−1, 1]; depth is camera z on the body (0 on the background)
/// normalised by its image's min and max (Eq. 4 as HumanGaussian feeds it).
pub fn render_to_branches(r: &MeshRender) -> Vec<Vec<f32>> {
    let n = r.width * r.height;
    let mut rgb = vec![0.0f32; 3 * n];
    for (p, c) in r.color.iter().enumerate() {
        for k in 0..3 {
            rgb[k * n + p] = 2.0 * c[k].clamp(0.0, 1.0) - 1.0;
        }
    }
    let depth: Vec<f32> = r
        .depth
        .iter()
        .zip(&r.coverage)
        .map(|(d, c)| if d.is_finite() { d * c } else { 0.0 })
        .collect();
    vec![
        rgb,
        normalised_depth(&depth)
            .iter()
            .map(|d| 2.0 * d - 1.0)
            .collect(),
    ]
}

/// `(d − min) / (max − min)` over one image (0 where the image is flat).
pub fn normalised_depth(depth: &[f32]) -> Vec<f32> {
    let lo = depth.iter().copied().fold(f32::INFINITY, f32::min);
    let hi = depth.iter().copied().fold(f32::NEG_INFINITY, f32::max);
    let range = hi - lo;
    depth
        .iter()
        .map(|d| if range > 1e-8 { (d - lo) / range } else { 0.0 })
        .collect()
}

impl Targets for IdentityBank {
    fn count(&self) -> usize {
        self.identities.len()
    }

    fn target(&self, label: usize, camera: &Camera) -> Vec<Vec<f32>> {
        render_to_branches(&self.oracle_render(label, camera))
    }
}

/// `[3, H, W]` in [0, 1] from a render's colours.
pub fn planar_rgb(r: &MeshRender) -> Vec<f32> {
    let n = r.width * r.height;
    let mut out = vec![0.0; 3 * n];
    for (p, c) in r.color.iter().enumerate() {
        for k in 0..3 {
            out[k * n + p] = c[k].clamp(0.0, 1.0);
        }
    }
    out
}

/// The spec's `view_variants`: the identity as the oracle shows it from its left (skin 40 %
/// lighter, hair a warm brown) and from its right (skin 40 % darker, hair a pale blond) — an
/// honest prior that disagrees with itself across views, as the paper's fragmented and
/// asymmetric faces suggest a real one does.
fn side_variants(identity: &Identity) -> [Identity; 2] {
    let scaled = |c: [f32; 3], f: f32| c.map(|v| (v * f).clamp(0.0, 1.0));
    [
        Identity {
            skin: scaled(identity.skin, 1.4),
            hair: [0.45, 0.25, 0.1],
            ..identity.clone()
        },
        Identity {
            skin: scaled(identity.skin, 0.6),
            hair: [0.85, 0.75, 0.5],
            ..identity.clone()
        },
    ]
}
