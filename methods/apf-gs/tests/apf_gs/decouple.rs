//! Eq. 3 per instance (A6): the literal set difference bit for bit with the cleanup off, no
//! accessory for an untracked person, other tracked people's silhouettes kept out of a
//! person's accessory mask, and the accessory-node rule.

use splatzoo_apf_gs::decouple::{DecoupleConfig, decouple_view, wants_accessory};
use splatzoo_datasets::masks::Mask;
use splatzoo_datasets::synth::rng::Rng;

const W: usize = 40;
const H: usize = 30;

fn rect(x0: usize, y0: usize, x1: usize, y1: usize) -> Mask {
    let mut data = vec![false; W * H];
    for y in y0..y1 {
        for x in x0..x1 {
            data[y * W + x] = true;
        }
    }
    Mask::new(W, H, data)
}

#[test]
fn without_cleanup_it_is_the_literal_difference_per_person() {
    let seed = crate::fresh_seed();
    let mut rng = Rng(seed);
    let coarse = Mask::new(W, H, (0..W * H).map(|_| rng.next() < 0.5).collect());
    let boxes = vec![rect(0, 0, 25, 30), rect(15, 0, 40, 30)];
    let owner: Vec<Option<usize>> = (0..W * H)
        .map(|_| match rng.below(3) {
            0 => None,
            k => Some(k - 1),
        })
        .collect();
    let config = DecoupleConfig {
        cleanup: false,
        ..DecoupleConfig::default()
    };
    let people = decouple_view(&config, &coarse, &boxes, &owner);
    for (p, masks) in people.iter().enumerate() {
        for (i, &o) in owner.iter().enumerate() {
            let c = coarse.data[i] && boxes[p].data[i];
            assert_eq!(masks.coarse.data[i], c, "seed {seed}");
            assert_eq!(masks.kine.data[i], o == Some(p));
            assert_eq!(masks.accessory.data[i], c && o != Some(p), "seed {seed}");
        }
    }
}

#[test]
fn an_untracked_person_outside_every_box_gets_no_accessory() {
    // Person 0: body 5..10 × 5..25 with a bag 10..18 × 12..18; an untracked walker at 28..33.
    let coarse = rect(5, 5, 10, 25)
        .or(&rect(10, 12, 18, 18))
        .or(&rect(28, 5, 33, 25));
    let boxes = vec![rect(3, 3, 20, 28)];
    let owner: Vec<Option<usize>> = (0..W * H)
        .map(|i| rect(5, 5, 10, 25).data[i].then_some(0))
        .collect();
    for cleanup in [false, true] {
        let config = DecoupleConfig {
            cleanup,
            ..DecoupleConfig::default()
        };
        let masks = &decouple_view(&config, &coarse, &boxes, &owner)[0];
        let walker = rect(28, 5, 33, 25);
        assert_eq!(masks.accessory.and(&walker).area(), 0);
        assert_eq!(masks.kine.area(), 100);
        // The bag survives the cleanup but for the columns next to the dilated body and its
        // corners (the opening).
        assert!(
            masks.accessory.area() >= 20,
            "cleanup {cleanup}: {}",
            masks.accessory.area()
        );
        assert_eq!(masks.accessory.and(&rect(5, 5, 10, 25)).area(), 0);
    }
}

#[test]
fn the_cleanup_keeps_another_persons_silhouette_out() {
    // Two people whose boxes overlap; person 1's body lies inside person 0's box.
    let coarse = rect(5, 5, 12, 25).or(&rect(14, 5, 20, 25));
    let boxes = vec![rect(2, 2, 22, 28), rect(12, 2, 24, 28)];
    let owner: Vec<Option<usize>> = (0..W * H)
        .map(|i| {
            if rect(5, 5, 12, 25).data[i] {
                Some(0)
            } else if rect(14, 5, 20, 25).data[i] {
                Some(1)
            } else {
                None
            }
        })
        .collect();
    let literal = DecoupleConfig {
        cleanup: false,
        ..DecoupleConfig::default()
    };
    assert!(
        decouple_view(&literal, &coarse, &boxes, &owner)[0]
            .accessory
            .area()
            > 0
    );
    let cleaned = decouple_view(&DecoupleConfig::default(), &coarse, &boxes, &owner);
    assert_eq!(cleaned[0].accessory.area(), 0);
    assert_eq!(cleaned[1].accessory.area(), 0);
}

#[test]
fn accessory_nodes_need_a_large_enough_mask_often_enough() {
    let config = DecoupleConfig::default();
    let coarse = rect(5, 5, 15, 25).or(&rect(15, 10, 20, 20));
    let boxes = vec![rect(0, 0, 30, 30)];
    let with_bag: Vec<Option<usize>> = (0..W * H)
        .map(|i| rect(5, 5, 15, 25).data[i].then_some(0))
        .collect();
    let carrying = decouple_view(&config, &coarse, &boxes, &with_bag);
    let bare_coarse = rect(5, 5, 15, 25);
    let bare = decouple_view(&config, &bare_coarse, &boxes, &with_bag);
    let (yes, why) = wants_accessory(&config, &[&carrying[0], &bare[0], &carrying[0]]);
    assert!(yes, "{why}");
    let (no, why) = wants_accessory(&config, &[&bare[0], &bare[0], &bare[0], &carrying[0]]);
    assert!(!no, "{why}");
    let hidden = decouple_view(&config, &Mask::empty(W, H), &boxes, &with_bag);
    assert!(!wants_accessory(&config, &[&hidden[0]]).0);
}
