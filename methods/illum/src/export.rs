//! What a finished `train-illum` run writes beside its checkpoint:
//!
//! - `scene.ply` (INRIA layout, the scene's SH) and `human_canonical.ply` (the stage-2
//!   human in canonical space, its colour slot written as the DC colour: linear albedo with
//!   the light volume, the display colour without; `albedo_0..2`, `metallic` and `roughness`
//!   as extra properties, the refined canonical mesh's normals in `nx ny nz`);
//! - `posed_frame_<t>.ply`: scene and human together at the first held-out frame, the human's
//!   shaded colour baked into its DC and its material maps as extra properties (`human`,
//!   `albedo_0..2`, `metallic`, `roughness`; normals in `nx ny nz`; zeros on the scene's rows);
//! - `renders/test_<k>.png` (the `k`-th scored view): render | truth | albedo | scene occlusion for each scored
//!   held-out frame, and `test.gif` of the renders;
//! - `onnx/`: F_Δ and F_c (their hash encodings and networks), and where stage 2 ran F_vis, F_ao
//!   and F_m, with test vectors, checked in tract.

use crate::IllumError;
use crate::onnx::{IllumNetworks, Stage2Networks, export};
use crate::trainer::IllumTrainer;
use burn::module::Module;
use burn::tensor::activation::sigmoid;
use burn::tensor::{Tensor, TensorData};
use splatzoo_datasets::DatasetError;
use splatzoo_rasterizer::Splats;
use splatzoo_rasterizer::sh::SH_C0;
use splatzoo_train::TrainError;
use splatzoo_train::gaussians::{GaussianSet, SH_REST};
use splatzoo_train::harness::Say;
use splatzoo_train::host_f32;
use splatzoo_train::images::{side_by_side, srgb_image, write_gif, write_png};
use splatzoo_train::ply::{write_ply, write_ply_with};
use splatzoo_train::scene::concatenate;
use std::path::Path;

/// Rows per ONNX test vector.
const ONNX_ROWS: usize = 64;

/// `[N, 3]` colours in [0, 1] as degree-3 SH with only the DC set.
fn colour_as_sh(colour: Tensor<2>) -> Tensor<3> {
    let n = colour.dims()[0];
    let device = colour.device();
    let dc = ((colour - 0.5) / SH_C0).reshape([n, 1, 3]);
    Tensor::cat(vec![dc, Tensor::zeros([n, SH_REST, 3], &device)], 1)
}

/// The human's material maps, host-side: `[N, 2]` metallic and roughness, `[N, 3]` linear
/// albedo, `[N, 3]` world normals where posed.
struct HumanMaps {
    material: Vec<f32>,
    albedo: Vec<f32>,
    normals: Option<Vec<f32>>,
}

impl HumanMaps {
    /// `set` with the maps as extra properties `albedo_0..2`, `metallic`, `roughness` and the
    /// normals in INRIA's `nx ny nz`; with `scene_rows`, `set` is the scene's Gaussians then the
    /// human's, a `human` flag (1 on the human's rows) comes first and the scene's rows carry
    /// zeros.
    fn write(
        &self,
        path: &Path,
        set: &GaussianSet,
        scene_rows: Option<usize>,
    ) -> Result<(), TrainError> {
        let padding = scene_rows.unwrap_or(0);
        let human_rows = self.albedo.len() / 3;
        let column = |values: &[f32], stride: usize, k: usize| -> Vec<f32> {
            std::iter::repeat_n(0.0, padding)
                .chain(values.chunks_exact(stride).map(|row| row[k]))
                .collect()
        };
        let mut columns = Vec::new();
        if scene_rows.is_some() {
            let flags: Vec<f32> = std::iter::repeat_n(0.0, padding)
                .chain(std::iter::repeat_n(1.0, human_rows))
                .collect();
            columns.push(("human", flags));
        }
        columns.extend([
            ("albedo_0", column(&self.albedo, 3, 0)),
            ("albedo_1", column(&self.albedo, 3, 1)),
            ("albedo_2", column(&self.albedo, 3, 2)),
            ("metallic", column(&self.material, 2, 0)),
            ("roughness", column(&self.material, 2, 1)),
        ]);
        let normals = self.normals.as_ref().map(|n| {
            let mut all = vec![0.0; 3 * padding];
            all.extend_from_slice(n);
            all
        });
        let extra: Vec<(&str, &[f32])> = columns
            .iter()
            .map(|(name, values)| (*name, values.as_slice()))
            .collect();
        write_ply_with(path, set, normals.as_deref(), &extra)?;
        Ok(())
    }
}

pub fn write_outputs(
    trainer: &IllumTrainer,
    run: &Path,
    say: &mut dyn Say,
) -> Result<serde_json::Map<String, serde_json::Value>, TrainError> {
    let mut summary = serde_json::Map::new();
    write_ply(&run.join("scene.ply"), &trainer.scene.set)?;
    let mut written = vec!["scene.ply".to_owned()];
    let (volume, decoder, materials) = trainer.frozen();
    if let Some(stage2) = &trainer.stage2 {
        let set = &stage2.human.set;
        let n = set.len();
        let canonical = GaussianSet {
            sh_dc: colour_as_sh(set.sh_dc.clone().reshape([n, 3]).clamp(0.0, 1.0)).slice([
                0..n,
                0..1,
                0..3,
            ]),
            ..set.clone()
        };
        // Metallic and roughness of each Gaussian from the material network (zero without the
        // light volume, which has no materials); the albedo is the DC colour's.
        let material = if trainer.config.ablation.light_volume {
            let per_vertex = sigmoid(materials.forward_queries(&trainer.material_queries));
            host_f32(&stage2.binding.transfer.apply(per_vertex).inner())
        } else {
            vec![0.0; 2 * n]
        };
        // Canonical normals: the refined canonical mesh's vertex normals carried by the binding
        // (as the posed frames' are from the posed mesh).
        let vertices: Vec<f32> = stage2.canonical.iter().flatten().copied().collect();
        let rows = stage2.canonical.len();
        let mesh = Tensor::<2>::from_data(TensorData::new(vertices, [rows, 3]), &trainer.autodiff);
        let normals = crate::stage2::posed_normals(&stage2.binding, &trainer.mesh, mesh);
        let maps = HumanMaps {
            material,
            albedo: host_f32(&set.sh_dc.clone().reshape([n, 3]).clamp(0.0, 1.0)),
            normals: Some(host_f32(&normals.inner())),
        };
        maps.write(&run.join("human_canonical.ply"), &canonical, None)?;
        written.push("human_canonical.ply".into());
    }

    let renders = run.join("renders");
    std::fs::create_dir_all(&renders)
        .map_err(|e| DatasetError::file(&renders, format!("cannot create ({e})")))?;
    let nets = crate::steps::Nets {
        volume: &volume,
        decoder: &decoder,
        materials: &materials,
    };
    let mut frames = Vec::new();
    for (k, frame) in trainer
        .capture
        .test_frames()
        .step_by(trainer.config.eval_stride)
        .enumerate()
    {
        let pose = trainer.frame_pose(frame.frame, true);
        let maps = trainer
            .render_view(nets, &frame.camera, &pose, true)
            .map_err(TrainError::from)?;
        let [h, w] = maps.ao.dims();
        let image = srgb_image(&maps.colour.clone().inner().clamp(0.0, 1.0));
        let albedo = srgb_image(&maps.albedo.clone().inner().clamp(0.0, 1.0));
        let ao = srgb_image(
            &maps
                .ao
                .clone()
                .inner()
                .reshape([h, w, 1])
                .repeat_dim(2, 3)
                .clamp(0.0, 1.0),
        );
        let row = side_by_side(&[image.clone(), srgb_image(&frame.image), albedo, ao]);
        // Named by the scored view's place (a multi-camera capture has several views a frame).
        write_png(&renders.join(format!("test_{k:04}.png")), &row)?;
        frames.push(image);
        if k == 0 {
            // Scene and human at this frame, the human's shaded colour baked in.
            let scene = trainer.scene.set.splats();
            let (human, maps) = match &trainer.stage2 {
                Some(stage2) => {
                    let canonical = crate::eval::untracked(stage2.human.set.splats());
                    let (posed, [colour, material, albedo, normals]) = trainer.stage2_human(
                        nets,
                        &canonical,
                        &pose,
                        &frame.camera,
                        trainer.config.stage2.sampling(false),
                        None,
                    );
                    let maps = HumanMaps {
                        material: host_f32(&material.inner()),
                        albedo: host_f32(&albedo.inner()),
                        normals: Some(host_f32(&normals.inner())),
                    };
                    let splats = Splats {
                        means: posed.means.inner(),
                        quats: posed.quats.inner(),
                        log_scales: posed.log_scales.inner(),
                        opacity_logits: posed.opacity_logits.inner(),
                        colors: colour_as_sh(colour.inner().clamp(0.0, 1.0)),
                    };
                    (splats, maps)
                }
                None => {
                    return Err(TrainError::from(IllumError::Input {
                        what: "train-illum".into(),
                        problem: "the run ended before stage 2 started".into(),
                    }));
                }
            };
            let name = format!("posed_frame_{:04}.ply", frame.frame);
            let scene_rows = scene.len();
            let set = GaussianSet::from_splats(&concatenate(vec![scene, human]));
            maps.write(&run.join(&name), &set, Some(scene_rows))?;
            written.push(name);
        }
    }
    write_gif(&run.join("test.gif"), &frames, 5)?;
    say.say(&format!(
        "wrote {}, {} renders and test.gif",
        written.join(", "),
        frames.len()
    ));

    let body = trainer.body.valid();
    let visibility = trainer.visibility.valid();
    let shadow = trainer.decoder.valid();
    let materials = trainer.materials.valid();
    let graphs = export(
        &IllumNetworks {
            body: &body,
            cube: &trainer.mesh.cube,
            stage2: trainer.stage2.is_some().then_some(Stage2Networks {
                visibility: &visibility,
                shadow: &shadow,
                materials: &materials,
            }),
        },
        ONNX_ROWS,
        &run.join("onnx"),
        &trainer.device,
    )
    .map_err(TrainError::from)?;
    let worst = graphs
        .iter()
        .map(|g| g.relative_error)
        .fold(0.0f32, f32::max);
    say.say(&format!(
        "wrote onnx/ ({} graphs; tract matches Burn to {worst:.1e})",
        graphs.len()
    ));
    summary.insert("onnx_relative_error".into(), f64::from(worst).into());

    summary.insert(
        "probes".into(),
        serde_json::json!({
            "dims": trainer.volume.grid().dims,
            "spacing": trainer.volume.grid().spacing,
            "gain": trainer.probe_gain(),
        }),
    );
    Ok(summary)
}
