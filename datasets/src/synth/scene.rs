//! A synthetic capture in memory: people (identity, texture, accessories, true motion and its
//! perturbed prior, posed once per frame), static surroundings, camera tracks and light; and
//! rendering any (frame, camera) with its ground truth. Nothing here touches the disk.
//!
//! Labels in [`ViewTruth::render`]`.label`: 0 nothing, [`STATIC_LABEL`] the surroundings, then
//! per person `k`: `2 + 2k` the body, `3 + 2k` its accessories.

use super::accessory::Accessory;
use super::environment::{Environment, Surface};
use super::identity::Identity;
use super::motion::relaxed_pose;
use super::prior::PriorNoise;
use super::rig::CameraTrack;
use crate::pose_sequence::PoseSequence;
use crate::posing::{PosedFrame, pose_frames_with_joints};
use crate::render::shadow::ShadowMap;
use crate::render::{
    Albedo, Lighting, MeshInstance, MeshRender, RenderSettings, Texture, render_with_shadows,
    shadow_map,
};
use burn::tensor::Device;
use rayon::prelude::*;
use splatzoo_models::body::builtin_body;
use splatzoo_rasterizer::Camera;

pub const STATIC_LABEL: u8 = 1;

/// The body label of person `k`.
pub fn body_label(k: usize) -> u8 {
    u8::try_from(2 + 2 * k).expect("at most 126 people")
}

/// The accessory label of person `k`.
pub fn accessory_label(k: usize) -> u8 {
    body_label(k) + 1
}

/// Texture size of a person's baked identity.
const TEXTURE_SIZE: usize = 512;

/// One person of a scene.
#[derive(Debug, Clone)]
pub struct Person {
    pub identity: Identity,
    pub texture: Texture,
    pub accessories: Vec<Accessory>,
    /// True motion, fitted to the built-in body with the identity's shape on every frame.
    pub motion: PoseSequence,
    /// The motion and shape with [`PriorNoise`] applied.
    pub prior: PoseSequence,
    /// `motion` posed, one entry per frame.
    pub frames: Vec<PosedFrame>,
}

/// Pelvis height of the built-in body with shape `betas` standing on y = 0.
pub fn standing_height(betas: &[f64], device: &Device) -> f64 {
    let rest = posed_once(betas, &[0.0; 72], device);
    -rest
        .vertices
        .iter()
        .map(|p| p[1] as f64)
        .fold(f64::INFINITY, f64::min)
}

fn posed_once(betas: &[f64], pose: &[f64; 72], device: &Device) -> PosedFrame {
    let seq = PoseSequence {
        joints: 24,
        poses: pose.to_vec(),
        translations: vec![0.0; 3],
        betas: betas.to_vec(),
        shape_count: betas.len(),
        fps: None,
    };
    pose_frames_with_joints(&builtin_body().model, &seq, device)
        .pop()
        .expect("one frame")
}

impl Person {
    /// A person of `identity` following `motion` (a 24-joint sequence from
    /// [`super::motion::generate`], whose shape is replaced by the identity's), carrying
    /// `accessories` (kind and colour); the prior is `motion` perturbed by `noise` from `seed`.
    pub fn new(
        identity: Identity,
        motion: &PoseSequence,
        accessories: &[(super::accessory::AccessoryKind, [f32; 3])],
        noise: &PriorNoise,
        seed: u64,
        device: &Device,
    ) -> Self {
        let body = builtin_body();
        let s = identity.betas.len();
        let mut motion = motion.clone();
        motion.shape_count = s;
        motion.betas = identity.betas.repeat(motion.frames());
        let frames = pose_frames_with_joints(&body.model, &motion, device);
        let reference = posed_once(&identity.betas, &relaxed_pose(), device);
        let accessories = accessories
            .iter()
            .map(|&(kind, colour)| Accessory::fit(kind, colour, &reference, &body.part_of_vertex))
            .collect();
        Self {
            texture: identity.bake_texture(body, TEXTURE_SIZE),
            prior: noise.perturb(&motion, seed),
            identity,
            accessories,
            motion,
            frames,
        }
    }
}

/// Which method's protocol a scene follows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Preset {
    /// NLF-GS: one person in a studio, 16-camera ring, a few poses.
    Multiview,
    /// Prior-4D and Illum: a person in a room, hand-held orbiting camera and a fixed one.
    Monocular,
    /// APF-GS: pedestrians with accessories crossing a street, cameras on a moving car.
    Driving,
    /// 3DGS: a static yard with crates and a standing person, three rings of cameras.
    Static,
}

/// A synthetic capture.
#[derive(Debug, Clone)]
pub struct Scene {
    pub preset: Preset,
    pub seed: u64,
    pub fps: f64,
    pub frame_count: usize,
    pub environment: Environment,
    pub people: Vec<Person>,
    pub tracks: Vec<CameraTrack>,
    pub lighting: Lighting,
    pub noise: PriorNoise,
    pub settings: RenderSettings,
}

/// One rendered (frame, camera) with its ground truth.
#[derive(Debug, Clone)]
pub struct ViewTruth {
    pub frame: usize,
    pub track: usize,
    pub camera: Camera,
    pub render: MeshRender,
}

impl ViewTruth {
    /// Pixels showing any person's body.
    pub fn human_mask(&self) -> Vec<bool> {
        self.render
            .label
            .iter()
            .map(|&l| l >= 2 && l % 2 == 0)
            .collect()
    }

    /// Pixels showing any accessory.
    pub fn accessory_mask(&self) -> Vec<bool> {
        self.render
            .label
            .iter()
            .map(|&l| l >= 3 && l % 2 == 1)
            .collect()
    }

    /// Human ∪ accessory: the merged annotation APF-GS starts from.
    pub fn coarse_mask(&self) -> Vec<bool> {
        self.render.label.iter().map(|&l| l >= 2).collect()
    }

    /// Which person each pixel belongs to (body or accessory), if any.
    pub fn person(&self) -> Vec<Option<usize>> {
        self.render
            .label
            .iter()
            .map(|&l| (l >= 2).then(|| (l as usize - 2) / 2))
            .collect()
    }
}

impl Scene {
    /// World positions of person `k`'s accessory `a` at `frame`.
    pub fn accessory_vertices(&self, k: usize, a: usize, frame: usize) -> Vec<[f32; 3]> {
        let person = &self.people[k];
        person.accessories[a].place(&person.frames[frame])
    }

    /// Accessory positions of every person at `frame` (`[person][accessory]`).
    fn accessories_at(&self, frame: usize) -> Vec<Vec<Vec<[f32; 3]>>> {
        (0..self.people.len())
            .map(|k| {
                (0..self.people[k].accessories.len())
                    .map(|a| self.accessory_vertices(k, a, frame))
                    .collect()
            })
            .collect()
    }

    /// The meshes of `frame`: surroundings, then (when `accessories` is given) each person and
    /// their accessories at those positions.
    fn meshes<'a>(
        &'a self,
        frame: usize,
        body_coords: &'a [[f32; 2]],
        accessories: Option<&'a [Vec<Vec<[f32; 3]>>]>,
    ) -> Vec<MeshInstance<'a>> {
        let body = builtin_body();
        let mut meshes = Vec::new();
        for prop in &self.environment.props {
            meshes.push(MeshInstance {
                positions: &prop.mesh.positions,
                faces: &prop.mesh.faces,
                albedo: match &prop.surface {
                    Surface::Colours => Albedo::PerVertex(&prop.mesh.colours),
                    Surface::Textured(texture) => Albedo::Textured {
                        coords: &prop.mesh.coords,
                        corners: &prop.mesh.faces,
                        texture,
                    },
                },
                label: STATIC_LABEL,
                smooth: false,
            });
        }
        let Some(accessories) = accessories else {
            return meshes;
        };
        for (k, person) in self.people.iter().enumerate() {
            meshes.push(MeshInstance {
                positions: &person.frames[frame].vertices,
                faces: triangles(&body.model.faces),
                albedo: Albedo::Textured {
                    coords: body_coords,
                    corners: triangles(&body.uv.faces),
                    texture: &person.texture,
                },
                label: body_label(k),
                smooth: true,
            });
            for (a, accessory) in person.accessories.iter().enumerate() {
                meshes.push(MeshInstance {
                    positions: &accessories[k][a],
                    faces: &accessory.mesh.faces,
                    albedo: Albedo::PerVertex(&accessory.mesh.colours),
                    label: accessory_label(k),
                    smooth: false,
                });
            }
        }
        meshes
    }

    fn view(
        &self,
        frame: usize,
        track: usize,
        meshes: &[MeshInstance],
        shadows: Option<&ShadowMap>,
    ) -> ViewTruth {
        let camera = self.tracks[track].cameras[frame];
        let settings = RenderSettings {
            background: self.environment.background,
            ..self.settings
        };
        ViewTruth {
            frame,
            track,
            camera,
            render: render_with_shadows(meshes, &camera, &self.lighting, &settings, shadows),
        }
    }

    /// Renders camera track `track` at `frame`; `with_people` false renders the surroundings
    /// alone (used to check masks against depth).
    pub fn render_view(&self, frame: usize, track: usize, with_people: bool) -> ViewTruth {
        self.render_tracks(frame, &[track], with_people)
            .pop()
            .expect("one view")
    }

    /// Every camera at `frame`.
    pub fn render_frame(&self, frame: usize) -> Vec<ViewTruth> {
        let all: Vec<usize> = (0..self.tracks.len()).collect();
        self.render_tracks(frame, &all, true)
    }

    /// `tracks` at `frame`: one shadow map, views rendered in parallel.
    pub fn render_tracks(
        &self,
        frame: usize,
        tracks: &[usize],
        with_people: bool,
    ) -> Vec<ViewTruth> {
        assert!(
            frame < self.frame_count,
            "frame {frame} of {}",
            self.frame_count
        );
        let coords = body_coords();
        let accessories = self.accessories_at(frame);
        let meshes = self.meshes(
            frame,
            &coords,
            with_people.then_some(accessories.as_slice()),
        );
        let shadows = shadow_map(&meshes, &self.lighting);
        tracks
            .par_iter()
            .map(|&t| self.view(frame, t, &meshes, shadows.as_ref()))
            .collect()
    }
}

/// The built-in body's texture coordinates as pairs.
fn body_coords() -> Vec<[f32; 2]> {
    builtin_body()
        .uv
        .coords
        .chunks(2)
        .map(|c| [c[0], c[1]])
        .collect()
}

/// Flat `[F·3]` indices as triangles.
fn triangles(flat: &[u32]) -> &[[u32; 3]] {
    let (triangles, rest) = flat.as_chunks::<3>();
    assert!(rest.is_empty(), "face indices come in threes");
    triangles
}
