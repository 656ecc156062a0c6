//! The joint render: a shadowed scene Gaussian is darkened by exactly its ao (0 black, ½
//! halved, 1 unchanged), the colour matches the rasterizer's own SH evaluation when ao ≡ 1,
//! the human's maps appear only where the human is in front, and an empty frame is an error.

use crate::values;
use burn::tensor::{Device, Tensor};
use splatzoo_illum::IllumError;
use splatzoo_illum::render::{HumanLayer, SceneLayer, render_joint};
use splatzoo_rasterizer::{Camera, ColorMode, RasterSettings, Splats, rasterize};

fn settings() -> RasterSettings {
    let camera = Camera::look_at([0.0, 0.0, -4.0], [0.0; 3], [0.0, -1.0, 0.0], 40.0, 24, 24);
    RasterSettings::new(camera, ColorMode::Sh { degree: 1 })
}

/// Two wide opaque Gaussians: one at the centre (z = 0), one behind it to the right.
fn scene(device: &Device) -> Splats {
    Splats {
        means: Tensor::<2>::from_floats([[0.0, 0.0, 0.0], [0.6, 0.0, 1.0]], device),
        quats: Tensor::<2>::from_floats([[1.0, 0.0, 0.0, 0.0]; 2], device),
        log_scales: Tensor::<2>::full([2, 3], (0.25f32).ln(), device),
        opacity_logits: Tensor::<1>::full([2], 6.0, device),
        colors: Tensor::<3>::from_floats(
            [
                [
                    [0.8, 0.1, -0.3],
                    [0.1, 0.2, 0.0],
                    [0.0, 0.1, 0.1],
                    [0.2, 0.0, 0.0],
                ],
                [[0.3, 0.3, 0.3], [0.0; 3], [0.0; 3], [0.0; 3]],
            ],
            device,
        ),
    }
}

#[test]
fn ao_darkens_the_scene_colour_and_one_keeps_the_rasterizers() {
    let device = Device::flex();
    let splats = scene(&device);
    let settings = settings();
    let with = |ao: Option<[f32; 2]>| {
        render_joint(
            Some(SceneLayer {
                splats: &splats,
                degree: 1,
                ao: ao.map(|a| Tensor::<1>::from_floats(a, &device)),
            }),
            None,
            &settings,
            [0.0; 3],
        )
        .unwrap()
    };
    let plain = values(with(None).colour);
    let reference = values(
        rasterize(&splats, Tensor::<1>::zeros([3], &device), &settings)
            .unwrap()
            .color,
    );
    let worst = plain
        .iter()
        .zip(&reference)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f32::max);
    assert!(
        worst < 1e-5,
        "world-frame SH differs from the op's: {worst}"
    );
    let ones = values(with(Some([1.0, 1.0])).colour);
    assert_eq!(ones, plain);
    let half = values(with(Some([0.5, 0.5])).colour);
    for (h, p) in half.iter().zip(&plain) {
        assert!((h - 0.5 * p).abs() < 1e-6);
    }
    let black = with(Some([0.0, 0.0]));
    assert!(values(black.colour).iter().all(|&v| v == 0.0));
    // The ao channel shows the occlusion; the human channels stay empty.
    let shadow = with(Some([0.25, 0.25]));
    let ao = values(shadow.ao);
    let alpha = values(shadow.render.alpha.clone());
    let centre = 12 * 24 + 12;
    assert!(
        (ao[centre] - 0.25 * alpha[centre]).abs() < 1e-3,
        "{} vs {}",
        ao[centre],
        alpha[centre]
    );
    assert!(values(shadow.human_alpha).iter().all(|&v| v == 0.0));
}

#[test]
fn the_human_maps_show_where_the_human_is_in_front() {
    let device = Device::flex();
    let settings = settings();
    let walls = scene(&device);
    // The human: one opaque Gaussian in front of the scene on the left, one hidden far behind
    // the central scene Gaussian.
    let body = Splats {
        means: Tensor::<2>::from_floats([[-0.9, 0.0, -1.0], [0.0, 0.0, 3.0]], &device),
        quats: Tensor::<2>::from_floats([[1.0, 0.0, 0.0, 0.0]; 2], &device),
        log_scales: Tensor::<2>::full([2, 3], (0.3f32).ln(), &device),
        opacity_logits: Tensor::<1>::full([2], 8.0, &device),
        colors: Tensor::<3>::zeros([2, 1, 3], &device),
    };
    let maps = render_joint(
        Some(SceneLayer {
            splats: &walls,
            degree: 1,
            ao: None,
        }),
        Some(HumanLayer {
            splats: &body,
            colour: Tensor::<2>::from_floats([[0.9, 0.2, 0.1]; 2], &device),
            material: Tensor::<2>::from_floats([[0.0, 0.7]; 2], &device),
            albedo: Tensor::<2>::from_floats([[0.5, 0.4, 0.3]; 2], &device),
            normals: Tensor::<2>::from_floats([[0.0, 0.0, -1.0]; 2], &device),
        }),
        &settings,
        [0.0; 3],
    )
    .unwrap();
    let human = values(maps.human_alpha);
    let roughness = values(maps.material);
    // The left Gaussian projects near column 2 (x < 0 is left), the hidden one at the centre.
    let left = 12 * 24 + 2;
    let centre = 12 * 24 + 12;
    assert!(human[left] > 0.9, "human alpha {}", human[left]);
    // What shows at the centre is the left Gaussian's 3σ tail and the far one through the
    // scene Gaussian's remaining transmittance.
    assert!(
        human[centre] < 0.1,
        "the scene hides the far human: {}",
        human[centre]
    );
    assert!((roughness[left * 2 + 1] - 0.7 * human[left]).abs() < 1e-4);
    let nothing = render_joint(None, None, &settings, [0.0; 3]);
    assert!(matches!(nothing, Err(IllumError::Input { .. })));
}
