//! Eq. 6, Eq. 7 and the Huber prior against hand-computed values; the contact rule's trap (the
//! paper's "closest" reads zero while a foot sinks in); the foot vertices of the built-in body;
//! σ's gradient through the contact term against its closed form.

use crate::{Rng, fresh_seed, values};
use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_models::body::builtin_body;
use splatzoo_prior_4d::camera::RigidFrame;
use splatzoo_prior_4d::contact::{
    ContactConfig, ContactSelect, ContactUnits, LEFT_ANKLE, LEFT_FOOT, RIGHT_ANKLE, RIGHT_FOOT,
    contact_loss, foot_vertices,
};
use splatzoo_prior_4d::locate::place;
use splatzoo_prior_4d::loss::{HuberConfig, huber, huber_prior, normal_loss};
use splatzoo_prior_4d::plane::Plane;
use splatzoo_rasterizer::Splats;

fn points(heights: &[f64], device: &Device) -> Tensor<2> {
    let flat: Vec<f32> = heights
        .iter()
        .enumerate()
        .flat_map(|(k, &h)| [k as f32 * 0.01, h as f32, 0.3])
        .collect();
    Tensor::<2>::from_data(TensorData::new(flat, [heights.len(), 3]), device)
}

fn floor() -> Plane {
    Plane::new([0.0, 1.0, 0.0], 0.0).expect("a valid plane")
}

fn config(count: usize, select: ContactSelect) -> ContactConfig {
    ContactConfig {
        count,
        margin: 0.02,
        units: ContactUnits::Scene,
        select,
    }
}

/// Points above, inside and below the ±Δc band, each rule's selection and value by hand.
#[test]
fn contact_loss_matches_hand_computed_values() {
    let device = Device::flex();
    let heights = [0.05, 0.01, -0.03, -0.015, 0.0];
    let all = contact_loss(
        points(&heights, &device),
        &floor(),
        &config(5, ContactSelect::Lowest),
        1.0,
    )
    .unwrap();
    // (0.05 − 0.02) + 0 + (0.03 − 0.02) + 0 + 0.
    let loss = values(all.loss)[0];
    assert!((loss - 0.04).abs() < 1e-6, "{loss}");
    let lowest = contact_loss(
        points(&heights, &device),
        &floor(),
        &config(2, ContactSelect::Lowest),
        1.0,
    )
    .unwrap();
    assert_eq!(lowest.selected, vec![2, 3]);
    assert!((values(lowest.loss)[0] - 0.01).abs() < 1e-6);
    let closest = contact_loss(
        points(&heights, &device),
        &floor(),
        &config(2, ContactSelect::Closest),
        1.0,
    )
    .unwrap();
    assert_eq!(closest.selected, vec![4, 1]);
    assert_eq!(values(closest.loss)[0], 0.0);
    // Margins in metres scale with σ; in scene units they do not.
    let metres = ContactConfig {
        units: ContactUnits::Metres,
        ..ContactConfig::default()
    };
    assert!((metres.margin_in_scene(0.7) - 0.014).abs() < 1e-12);
    assert_eq!(config(1, ContactSelect::Lowest).margin_in_scene(0.7), 0.02);
}

/// Read in metres, Eq. 7 is the same number in a scene of any unit: the same feet and floor in
/// units `k` times smaller (σ and every coordinate × k) give the same loss, by hand at k = 1,
/// on fresh random heights and units from 1e-3 to 1e3. In scene units it is the literal sum in
/// the scene's numbers, which changes with k.
#[test]
fn contact_loss_in_metres_does_not_depend_on_the_scene_unit() {
    let seed = fresh_seed();
    let mut rng = Rng(seed);
    let device = Device::flex();
    let heights: Vec<f64> = (0..30).map(|_| rng.range(-0.08, 0.08)).collect();
    let metres = ContactConfig {
        count: 30,
        units: ContactUnits::Metres,
        ..ContactConfig::default()
    };
    let want: f64 = heights.iter().map(|h| (h.abs() - 0.02).max(0.0)).sum();
    for k in [1e-3, 0.37, 1.0, 2.9, 1e3] {
        let scaled: Vec<f64> = heights.iter().map(|h| h * k).collect();
        let floor = Plane::new([0.0, 1.0, 0.0], 0.0).unwrap();
        let eval = |cfg: &ContactConfig| {
            f64::from(
                values(
                    contact_loss(points(&scaled, &device), &floor, cfg, k)
                        .unwrap()
                        .loss,
                )[0],
            )
        };
        let got = eval(&metres);
        assert!(
            (got - want).abs() <= 1e-4 * want.max(1e-3),
            "seed {seed}, unit ×{k}: {got} against {want}"
        );
        let scene = eval(&ContactConfig {
            units: ContactUnits::Scene,
            ..metres
        });
        let literal: f64 = scaled.iter().map(|h| (h.abs() - 0.02).max(0.0)).sum();
        assert!(
            (scene - literal).abs() <= 1e-4 * literal.max(1e-3),
            "seed {seed}, unit ×{k}: scene units {scene} against {literal}"
        );
    }
}

/// A sole sunk 10 cm into the floor: the paper's closest-|d| rule picks the vertices where the
/// sole crosses the floor and reads zero; the lowest rule keeps the penetration in the loss.
#[test]
fn closest_rule_reads_zero_while_a_foot_sinks_in() {
    let device = Device::flex();
    // 60 sole vertices from 10 cm under the floor to 2 cm above, evenly.
    let heights: Vec<f64> = (0..60).map(|k| -0.10 + 0.12 * k as f64 / 59.0).collect();
    let eval = |select| {
        values(
            contact_loss(
                points(&heights, &device),
                &floor(),
                &config(25, select),
                1.0,
            )
            .unwrap()
            .loss,
        )[0]
    };
    let closest = eval(ContactSelect::Closest);
    let lowest = eval(ContactSelect::Lowest);
    assert!(closest < 0.05, "closest {closest}");
    assert!(lowest > 1.0, "lowest {lowest}");
}

/// Bad inputs give errors, never a panic or a NaN loss.
#[test]
fn contact_loss_rejects_bad_inputs() {
    let device = Device::flex();
    let nan = points(&[0.0, f64::NAN], &device);
    let err = contact_loss(nan, &floor(), &config(2, ContactSelect::Lowest), 1.0)
        .err()
        .expect("a NaN foot is an error");
    assert!(err.to_string().contains("foot vertex 1"), "{err}");
    let empty = Tensor::<2>::zeros([0, 3], &device);
    assert!(contact_loss(empty, &floor(), &config(2, ContactSelect::Lowest), 1.0).is_err());
    let one = points(&[0.0], &device);
    assert!(
        contact_loss(
            one.clone(),
            &floor(),
            &config(0, ContactSelect::Lowest),
            1.0
        )
        .is_err()
    );
    assert!(
        contact_loss(
            one.clone(),
            &floor(),
            &config(1, ContactSelect::Lowest),
            f64::NAN
        )
        .is_err()
    );
    assert!(contact_loss(one, &floor(), &ContactConfig::default(), 0.0).is_err());
}

/// The built-in body's contact candidates: both feet, all skinned to an ankle or foot, none
/// above its ankle + 2 cm, and the body's lowest vertex among them.
#[test]
fn foot_vertices_are_the_soles_of_both_feet() {
    let model = &builtin_body().model;
    let feet = foot_vertices(model);
    let j = model.joint_count();
    let dominant = |k: usize| {
        let row = &model.skin_weights[k * j..(k + 1) * j];
        (0..j).max_by(|&a, &b| row[a].total_cmp(&row[b])).unwrap()
    };
    let mut sides = [0usize; 2];
    for &k in &feet {
        match dominant(k) {
            LEFT_ANKLE | LEFT_FOOT => sides[0] += 1,
            RIGHT_ANKLE | RIGHT_FOOT => sides[1] += 1,
            other => panic!("vertex {k} is skinned to joint {other}"),
        }
    }
    assert!(sides[0] >= 25 && sides[1] >= 25, "{sides:?} per foot");
    let lowest = (0..model.vertex_count())
        .min_by(|&a, &b| model.template[3 * a + 1].total_cmp(&model.template[3 * b + 1]))
        .unwrap();
    assert!(feet.contains(&lowest), "the body's lowest vertex {lowest}");
    assert!(
        feet.len() < model.vertex_count() / 10,
        "{} feet",
        feet.len()
    );
}

/// `dL_contact/ds` through Eq. 3′ equals its closed form `σ Σ_active sign(h) n·(R v)`.
#[test]
fn contact_gradient_reaches_the_global_scale() {
    let seed = fresh_seed();
    let mut rng = Rng(seed);
    let device = Device::flex().autodiff();
    // A camera 1.5 units above the floor looking level; feet 1.4–1.7 m below it in camera space.
    let frame = RigidFrame::from_host(
        [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]],
        [0.0, 1.5, 0.0],
        &device,
    );
    let feet: Vec<[f64; 3]> = (0..40)
        .map(|_| {
            [
                rng.range(-0.2, 0.2),
                rng.range(1.4, 1.7),
                rng.range(2.0, 3.0),
            ]
        })
        .collect();
    let sigma = rng.range(0.6, 1.3);
    let flat: Vec<f32> = feet.iter().flatten().map(|&v| v as f32).collect();
    let means = Tensor::<2>::from_data(TensorData::new(flat, [40, 3]), &device);
    let splats = Splats {
        means,
        quats: Tensor::zeros([40, 4], &device),
        log_scales: Tensor::zeros([40, 3], &device),
        opacity_logits: Tensor::zeros([40], &device),
        colors: Tensor::zeros([40, 1, 3], &device),
    };
    let s = Tensor::<1>::from_floats([sigma.ln() as f32], &device).require_grad();
    let placed = place(splats, s.clone(), &frame);
    let cfg = config(25, ContactSelect::Lowest);
    let term = contact_loss(placed.means, &floor(), &cfg, sigma).unwrap();
    let grads = term.loss.backward();
    let got = f64::from(values(s.grad(&grads).expect("σ gets a gradient"))[0]);
    // World height of camera-space v: 1.5 − σ v_y (the camera's y axis points down).
    let mut want = 0.0;
    for &k in &term.selected {
        let h = 1.5 - sigma * feet[k][1];
        if h.abs() > 0.02 {
            want += h.signum() * sigma * (-feet[k][1]);
        }
    }
    assert!(
        want.abs() > 1e-3,
        "seed {seed}: the test needs active contacts"
    );
    assert!(
        (got - want).abs() < 1e-3 * (1.0 + want.abs()),
        "seed {seed}: autodiff {got} vs closed form {want}"
    );
}

/// Eq. 6 by hand on a 1×2 image with one masked pixel, and its zero on a perfect match.
#[test]
fn normal_loss_matches_hand_computed_values() {
    let device = Device::flex();
    let image =
        |v: [f32; 6]| Tensor::<3>::from_data(TensorData::new(v.to_vec(), [1, 2, 3]), &device);
    let rendered = image([0.0, 0.0, -0.5, 9.0, 9.0, 9.0]);
    let target = image([0.0, 0.6, -0.8, 1.0, 0.0, 0.0]);
    let mask = Tensor::<2>::from_floats([[1.0, 0.0]], &device);
    // L1: 0 + 0.6 + 0.3 = 0.9; dot 0.4 → |1 − 0.4| = 0.6; the second pixel is masked out.
    let loss = values(normal_loss(rendered, target.clone(), mask.clone()))[0];
    assert!((loss - 1.5).abs() < 1e-6, "{loss}");
    let perfect = values(normal_loss(target.clone(), target, mask))[0];
    assert!(perfect.abs() < 1e-6, "{perfect}");
    let empty = Tensor::<2>::zeros([1, 2], &device);
    let none = values(normal_loss(image([0.0; 6]), image([1.0; 6]), empty))[0];
    assert_eq!(none, 0.0, "an empty mask gives zero, not NaN");
}

/// ρ_δ: quadratic inside, linear outside, continuous with slope δ at the threshold; the prior
/// term is zero at the prior and grows away from it.
#[test]
fn huber_matches_its_definition() {
    let seed = fresh_seed();
    let mut rng = Rng(seed);
    let device = Device::flex().autodiff();
    let delta = rng.range(0.05, 0.5);
    let xs: Vec<f64> = (0..32).map(|_| rng.range(-1.0, 1.0)).collect();
    let x = Tensor::<1>::from_data(
        TensorData::new(xs.iter().map(|&v| v as f32).collect::<Vec<_>>(), [32]),
        &device,
    )
    .require_grad();
    let y = huber(x.clone(), delta);
    let got = values(y.clone());
    let grads = y.sum().backward();
    let slope = values(x.grad(&grads).unwrap());
    for (k, &v) in xs.iter().enumerate() {
        let (want, dwant) = if v.abs() <= delta {
            (0.5 * v * v, v)
        } else {
            (delta * (v.abs() - 0.5 * delta), delta * v.signum())
        };
        assert!(
            (f64::from(got[k]) - want).abs() < 1e-5,
            "seed {seed}: ρ({v})"
        );
        assert!(
            (f64::from(slope[k]) - dwant).abs() < 1e-5,
            "seed {seed}: ρ'({v})"
        );
    }
    let c = Tensor::<2>::from_floats([[0.2, 0.4, 0.6], [0.1, 0.9, 0.5]], &device);
    let r = Tensor::<1>::from_floats([-5.0, -4.0], &device);
    let cfg = HuberConfig::default();
    let zero = values(huber_prior(
        c.clone(),
        c.clone(),
        r.clone(),
        r.clone(),
        &cfg,
    ))[0];
    assert_eq!(zero, 0.0);
    // One colour off by 0.5 (linear: 0.1 · (0.5 − 0.05)), one radius off by 0.05 (½ 0.05²).
    let c2 = Tensor::<2>::from_floats([[0.7, 0.4, 0.6], [0.1, 0.9, 0.5]], &device);
    let r2 = Tensor::<1>::from_floats([-5.0, -3.95], &device);
    let value = values(huber_prior(c2, c, r2, r, &cfg))[0];
    let want = 0.1 * 0.45 / 2.0 + 0.5 * 0.05 * 0.05 / 2.0;
    assert!((f64::from(value) - want).abs() < 1e-6, "{value} vs {want}");
}
