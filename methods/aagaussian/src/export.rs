//! What a finished run writes into its directory: the canonical avatar as an INRIA
//! `point_cloud.ply` (normalised units), a turntable GIF (avatar | prompted identity; the
//! avatar alone for a user's photo), the
//! face view beside the face crop, the final scores for `metrics.json` (with the guidance's
//! fixed points, [`crate::fixed_points`]), and the avatar
//! animated by the built-in motion (`animation/`).

use crate::animate::{FrameOutput, animate, builtin_motion};
use crate::cameras::orbit_camera;
use crate::error::AagError;
use crate::fixed_points;
use crate::identities::planar_rgb;
use crate::sds::Guidance;
use crate::trainer::{AagTrainer, planar_to_tensor, render_views};
use splatzoo_train::harness::Say;
use splatzoo_train::images::{side_by_side, srgb_image, write_gif, write_png};
use splatzoo_train::ply::write_ply;
use std::path::Path;

/// Turntable frames.
const TURNTABLE: usize = 24;

pub fn write_outputs(
    trainer: &AagTrainer,
    run: &Path,
    say: &mut dyn Say,
) -> Result<serde_json::Map<String, serde_json::Value>, AagError> {
    let capture = &trainer.capture;
    let set = &trainer.node.set;
    let device = set.means.device();
    let ply = run.join("point_cloud.ply");
    write_ply(&ply, set).map_err(splatzoo_train::TrainError::from)?;
    let splats = set.splats();
    let size = capture.config.eval_size;
    let mut frames = Vec::with_capacity(TURNTABLE);
    for k in 0..TURNTABLE {
        let az = -180.0 + 360.0 * k as f64 / TURNTABLE as f64;
        let camera = orbit_camera(
            [0.0; 3],
            az,
            10.0,
            capture.config.eval_distance,
            capture.config.eval_fovy_degrees,
            size,
        );
        let render = render_views(&splats, &[camera])?.remove(0);
        let mut panels = vec![srgb_image(&render.color.clamp(0.0, 1.0))];
        if let Some(truth) = &capture.truth {
            let target = planar_rgb(&truth.bank.render(capture.config.prompt, &camera));
            panels.push(srgb_image(&planar_to_tensor(
                &target,
                size as usize,
                &device,
            )));
        }
        frames.push(side_by_side(&panels));
    }
    let dataset = |e| AagError::Train(splatzoo_train::TrainError::Dataset(e));
    write_gif(&run.join("turntable.gif"), &frames, 12).map_err(dataset)?;
    let face = render_views(&splats, &[capture.face_camera])?.remove(0);
    let crop = planar_to_tensor(
        &capture.face_crop,
        capture.config.face_size as usize,
        &device,
    );
    write_png(
        &run.join("face.png"),
        &side_by_side(&[srgb_image(&face.color.clamp(0.0, 1.0)), srgb_image(&crop)]),
    )
    .map_err(dataset)?;
    say.say(&format!(
        "wrote {} ({} Gaussians), turntable.gif, face.png",
        ply.display(),
        set.len()
    ));
    // LPIPS, where the user gave its weights, is in the harness's final evaluation.
    let scores = trainer.evaluate(None)?;
    let mut summary = serde_json::Map::new();
    summary.insert(
        "aag".into(),
        serde_json::to_value(&scores).expect("plain data"),
    );
    summary.insert("metres_per_unit".into(), capture.metres_per_unit.into());
    let sds = &trainer.config.sds;
    let mut forms = vec![Guidance::Plain];
    if sds.guidance != Guidance::Plain {
        forms.push(sds.guidance);
    }
    let fixed = fixed_points::check(&forms, sds.scale, sds.anpg_switch, trainer.config.seed)?;
    for c in &fixed {
        say.say(&format!(
            "guidance fixed point ({:?}, ω {}, point masses): {:.3} from the prompt's image on \
             average (closed form {}; an L2 fit: 0)",
            c.guidance,
            c.scale,
            c.beyond_target,
            match (c.closed_form_beyond_target, c.closed_form_error) {
                (Some(d), Some(e)) => format!("{d:.3}, reached within {e:.1e}"),
                _ => "none".into(),
            }
        ));
    }
    summary.insert(
        "guidance_fixed_points".into(),
        serde_json::to_value(&fixed).expect("plain data"),
    );
    let animation = &trainer.config.animation;
    if animation.frames > 0 {
        let dir = run.join("animation");
        std::fs::create_dir_all(&dir).map_err(|e| {
            dataset(splatzoo_datasets::DatasetError::file(
                &dir,
                format!("cannot create ({e})"),
            ))
        })?;
        let motion = builtin_motion(animation.frames, animation.fps);
        let scores = animate(
            set,
            capture,
            &motion,
            animation,
            Some(FrameOutput {
                dir: &dir,
                ply: true,
            }),
        )?;
        say.say(&format!(
            "animated {} frames (built-in walk then wave){}; {} Gaussians bound, {} culled; \
             {:.1} fps; wrote {}",
            scores.frames,
            scores
                .identity
                .as_ref()
                .map_or_else(String::new, |kept| kept.line()),
            scores.gaussians,
            scores.culled,
            scores.fps,
            dir.display()
        ));
        summary.insert(
            "animation".into(),
            serde_json::to_value(&scores).expect("plain data"),
        );
    }
    Ok(summary)
}
