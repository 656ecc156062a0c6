//! A synthetic capture in memory: people (identity, texture, accessories, true motion and its
//! perturbed prior, posed once per frame), static surroundings, camera tracks and light; and
//! rendering any (frame, camera) with its ground truth. Nothing here touches the disk.
//!
//! Labels in [`ViewTruth::render`]`.label`: 0 nothing, [`STATIC_LABEL`] the surroundings, then
//! per person `k`: `2 + 2k` the body, `3 + 2k` its accessories. Untracked people (no prior
//! track for a method, [`Person::tracked`]) are labelled like everyone else.

use super::accessory::Accessory;
use super::clothing;
use super::environment::{Environment, Surface};
use super::identity::Identity;
use super::motion::relaxed_pose;
use super::prior::{PriorCorruption, PriorNoise, joint_angle_error};
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
    /// The motion and shape with [`PriorNoise`] applied (and, for a tracked person, the
    /// scene's [`PriorCorruption`]).
    pub prior: PoseSequence,
    /// `motion` posed, one entry per frame: the plain body model, which is what a method fits.
    pub frames: Vec<PosedFrame>,
    /// Whether a body tracker followed this person: false for a passer-by whose `prior` no
    /// method may use (none is exported); they belong to the background.
    pub tracked: bool,
    /// Whether the rendered body wears the clothing relief ([`clothing`]) on top of `frames`
    /// ([`Scene::body_vertices`]).
    pub clothed: bool,
    /// Whether that clothing also moves with the pose ([`clothing::pose_relief`]; only with
    /// `clothed`).
    pub pose_clothing: bool,
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

/// The built-in body with shape `betas` posed once by the 72-D SMPL `pose` (no translation).
pub fn posed_once(betas: &[f64], pose: &[f64; 72], device: &Device) -> PosedFrame {
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
    /// Tracked, without clothing relief.
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
            tracked: true,
            clothed: false,
            pose_clothing: false,
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
    /// The tracker failure in every tracked person's prior, if any.
    pub corruption: Option<PriorCorruption>,
    pub settings: RenderSettings,
}

/// One rendered (frame, camera) with its ground truth.
#[derive(Debug, Clone)]
pub struct ViewTruth {
    pub frame: usize,
    pub track: usize,
    pub camera: Camera,
    pub render: MeshRender,
    /// People in the scene: the length of per-person results ([`ViewTruth::person_boxes`]).
    pub people: usize,
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

/// Where every person's surfaces are at one frame.
struct PeopleAt {
    /// Rendered body vertices, per person.
    bodies: Vec<Vec<[f32; 3]>>,
    /// Accessory vertices, `[person][accessory]`.
    accessories: Vec<Vec<Vec<[f32; 3]>>>,
}

impl Scene {
    /// Seconds since the first frame.
    pub fn time(&self, frame: usize) -> f64 {
        frame as f64 / self.fps
    }

    /// World positions of person `k`'s body as rendered at `frame`: the posed body model
    /// (`frames[frame].vertices`), with the clothing relief where the person wears it (moving
    /// with the frame's true pose where it does).
    pub fn body_vertices(&self, k: usize, frame: usize) -> Vec<[f32; 3]> {
        let person = &self.people[k];
        let posed = &person.frames[frame].vertices;
        if person.clothed {
            let pose = person.pose_clothing.then(|| person.motion.pose(frame));
            clothing::dress(posed, triangles(&builtin_body().model.faces), pose)
        } else {
            posed.clone()
        }
    }

    /// World positions of person `k`'s accessory `a` at `frame`.
    pub fn accessory_vertices(&self, k: usize, a: usize, frame: usize) -> Vec<[f32; 3]> {
        let person = &self.people[k];
        person.accessories[a].place(&person.frames[frame], self.time(frame))
    }

    /// World position of the grip of person `k`'s accessory `a` at `frame`: the point its
    /// swing, if any, turns about.
    pub fn accessory_grip(&self, k: usize, a: usize, frame: usize) -> [f32; 3] {
        let person = &self.people[k];
        person.accessories[a].grip_in_world(&person.frames[frame])
    }

    /// Per frame, the error injected into person `k`'s prior: the mean angle (radians) between
    /// the true and the prior local rotations of the body joints
    /// ([`super::prior::joint_angle_error`]).
    pub fn prior_joint_error(&self, k: usize) -> Vec<f64> {
        let person = &self.people[k];
        joint_angle_error(&person.motion, &person.prior)
    }

    /// Every person's body and accessories at `frame`.
    fn people_at(&self, frame: usize) -> PeopleAt {
        PeopleAt {
            bodies: (0..self.people.len())
                .map(|k| self.body_vertices(k, frame))
                .collect(),
            accessories: (0..self.people.len())
                .map(|k| {
                    (0..self.people[k].accessories.len())
                        .map(|a| self.accessory_vertices(k, a, frame))
                        .collect()
                })
                .collect(),
        }
    }

    /// The meshes of a frame: surroundings, then (when `people` is given) each person and their
    /// accessories at those positions.
    fn meshes<'a>(
        &'a self,
        body_coords: &'a [[f32; 2]],
        people: Option<&'a PeopleAt>,
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
        let Some(at) = people else {
            return meshes;
        };
        for (k, person) in self.people.iter().enumerate() {
            meshes.push(MeshInstance {
                positions: &at.bodies[k],
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
                    positions: &at.accessories[k][a],
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
            people: self.people.len(),
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
        let people = with_people.then(|| self.people_at(frame));
        let meshes = self.meshes(&coords, people.as_ref());
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
