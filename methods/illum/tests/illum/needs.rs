//! The shadow-decoder rule ([`splatzoo_illum::needs`]): the tiny capture under the room's
//! point light shows the person's shadow and gets the decoder; the same capture under diffuse
//! light shows none and gets none, its decoder left untouched by stage-2 steps; the key forces
//! it either way; the decision reaches the trainer's config and the module list.

use burn::tensor::Device;
use splatzoo_illum::data::CaptureLight;
use splatzoo_illum::method::Illum;
use splatzoo_illum::needs::{CastShadow, shadow_decoder};
use splatzoo_illum::trainer::IllumTrainer;
use splatzoo_train::harness::Method;

fn decoder_tensors(method: &Illum) -> Vec<(String, Vec<f32>)> {
    method
        .checkpoint()
        .tensors
        .into_iter()
        .filter(|(name, _)| name.starts_with("decoder.") && !name.contains("optimizer"))
        .map(|(name, (_, values))| (name, values))
        .collect()
}

#[test]
fn the_shadow_decoder_is_built_only_where_the_persons_shadow_falls_on_the_scene() {
    let device = Device::flex();
    let lit = crate::trainer::tiny();
    let capture = lit.data.build(&device).expect("the tiny capture");
    let shadow = CastShadow::measure(&capture).expect("the synthetic capture's truth");
    assert!(shadow.needs_decoder(), "under the point light: {shadow:?}");
    let choice = shadow_decoder(None, &capture);
    assert!(choice.enabled && choice.forced_by.is_none(), "{choice:?}");

    let mut diffuse = crate::trainer::tiny();
    diffuse.data.light = CaptureLight::Diffuse;
    let capture = diffuse.data.build(&device).expect("the diffuse capture");
    let shadow = CastShadow::measure(&capture).expect("the synthetic capture's truth");
    assert!(
        shadow.frames_showing == 0 && shadow.mean_pixel_fraction < 1e-4,
        "under diffuse light: {shadow:?}"
    );
    let trainer = IllumTrainer::from_capture(diffuse.clone(), capture.clone(), &device).unwrap();
    assert_eq!(trainer.config.ablation.shadow, Some(false));
    assert!(!trainer.shadow_choice.enabled && trainer.shadow_choice.forced_by.is_none());

    // Forced on the diffuse capture: built, and the line says it was forced.
    let mut forced = diffuse.clone();
    forced.ablation.shadow = Some(true);
    let trainer = IllumTrainer::from_capture(forced, capture, &device).unwrap();
    assert!(trainer.shadow_choice.enabled);
    assert_eq!(
        trainer.shadow_choice.forced_by.as_deref(),
        Some("ablation.shadow")
    );

    // Without it, stage-2 steps leave the decoder's weights as they were drawn; the module
    // list reports the decision.
    let mut method = Illum::new(diffuse.clone(), &device).unwrap();
    let before = decoder_tensors(&method);
    assert!(!before.is_empty(), "the checkpoint keeps the decoder");
    for _ in 0..diffuse.stage1.steps + 2 {
        assert!(method.step().unwrap().loss.is_finite());
    }
    assert!(method.trainer.stage2.is_some());
    assert_eq!(decoder_tensors(&method), before);
    let listed = method
        .modules()
        .into_iter()
        .find(|m| m.module.starts_with("shadow decoder"))
        .expect("listed");
    assert!(
        !listed.enabled && listed.reason.contains("0 of"),
        "{listed:?}"
    );
}
