//! What a finished `train-prior4d` run writes beside its checkpoint: INRIA `.ply` of the scene
//! prior, of the scene after stage D, of the canonical avatar and of scene + person posed at the
//! first acting frame; renders at the evaluation camera (render | truth) and a GIF of them; and
//! the summary for `metrics.json` (final scores, the priors-alone baseline, stage C's plane
//! and σ₀).

use crate::error::Prior4dError;
use crate::method::Prior4d;
use crate::offsets::PoseOffsetNet;
use burn::module::Module;
use splatzoo_datasets::DatasetError;
use splatzoo_train::TrainError;
use splatzoo_train::gaussians::GaussianSet;
use splatzoo_train::harness::Say;
use splatzoo_train::images::{side_by_side, srgb_image, write_gif, write_png};
use splatzoo_train::ply::write_ply;
use splatzoo_train::scene::concatenate;
use std::path::Path;

pub fn write_outputs(
    method: &Prior4d,
    run: &Path,
    say: &mut dyn Say,
) -> Result<serde_json::Map<String, serde_json::Value>, TrainError> {
    let joint = method.joint.as_ref().ok_or_else(|| {
        TrainError::from(Prior4dError::input(
            "train-prior4d",
            "the run ended before stage D started",
        ))
    })?;
    let capture = &method.capture;
    let refine = method.config.joint.refines_cameras();
    write_ply(&run.join("scene_prior.ply"), &method.scene.node.set)?;
    write_ply(&run.join("scene.ply"), &joint.scene.set)?;
    write_ply(
        &run.join("avatar_canonical.ply"),
        joint.avatar.canonical_set(),
    )?;
    let view = joint.acting_view(capture, 0, refine, None);
    let placed = joint.placed_avatar(capture, 0, &view, joint.log_sigma.clone());
    let both = concatenate(vec![joint.scene_splats(capture), placed.splats]);
    write_ply(
        &run.join("posed_frame_0000.ply"),
        &GaussianSet::from_splats(&both),
    )?;

    let renders = run.join("renders");
    std::fs::create_dir_all(&renders)
        .map_err(|e| DatasetError::file(&renders, format!("cannot create ({e})")))?;
    let scene = joint.scene_splats(capture);
    let mut frames = Vec::new();
    for t in (0..capture.eval.len()).step_by(method.config.joint.eval_stride.max(1)) {
        let eval = &capture.eval[t];
        let layers = joint.render_eval(capture, &scene, t, refine)?;
        let image = srgb_image(&layers.color.clamp(0.0, 1.0));
        let pair = side_by_side(&[image.clone(), srgb_image(&eval.image)]);
        write_png(&renders.join(format!("eval_{t:04}.png")), &pair)?;
        frames.push(image);
    }
    write_gif(&run.join("eval.gif"), &frames, 5)?;
    say.say(&format!(
        "wrote scene_prior.ply, scene.ply, avatar_canonical.ply, posed_frame_0000.ply, {} renders \
         and eval.gif",
        frames.len()
    ));

    // The offset network as ONNX, its vectors the avatar's first rows at frames 0 and 1.
    let canonical = joint.avatar.canonical_set().splats();
    let rows = crate::onnx::ROWS.min(canonical.len());
    let first_rows = canonical.means.clone().slice([0..rows, 0..3]);
    let net = joint.offsets.valid();
    let levels = method.config.joint.offset_network.position_levels;
    let samples: Vec<_> = (0..capture.acting.len().min(2))
        .map(|t| {
            let pose = joint.avatar.poses.frame(t, false).rotations;
            PoseOffsetNet::inputs(first_rows.clone(), pose, levels)
        })
        .collect();
    let exported = crate::onnx::export(&net, &samples, &run.join("onnx"))?;
    say.say(&format!(
        "wrote onnx/pose_offsets.onnx ({rows} rows per run; tract matches Burn to {:.1e})",
        exported.relative_error
    ));

    let mut summary = serde_json::Map::new();
    summary.insert(
        "onnx_relative_error".into(),
        f64::from(exported.relative_error).into(),
    );
    let plane = &joint.init.fit.plane;
    summary.insert(
        "initialisation".into(),
        serde_json::json!({
            "plane_normal": plane.normal,
            "plane_offset": plane.offset,
            "plane_inliers": joint.init.fit.inliers.len(),
            "ground_candidates": joint.init.candidates,
            "sigma0": joint.init.sigma0,
            "sigma_star": method.sigma_star(),
        }),
    );
    if let Some(p) = &method.priors_only {
        summary.insert(
            "priors_only".into(),
            serde_json::to_value(p).expect("plain data"),
        );
    }
    summary.insert("sigma".into(), joint.sigma().into());
    Ok(summary)
}
