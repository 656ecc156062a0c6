//! Eq. 2's pose-dependent offsets on the skinned node: zero heads reproduce the avatar prior
//! exactly (step 0 of stage D), and offsets are added in canonical space before skinning, so an
//! offset on a forearm turns with the elbow.

use crate::{Rng, fresh_seed, values};
use burn::module::Param;
use burn::tensor::{Device, Tensor};
use splatzoo_datasets::pose_sequence::PoseSequence;
use splatzoo_models::body::builtin_body;
use splatzoo_prior_4d::offsets::{PoseOffsetConfig, PoseOffsetNet, PoseOffsets};
use splatzoo_train::densify::{DensifyConfig, Strategy};
use splatzoo_train::optimizer::LearningRates;
use splatzoo_train::scene::SkinnedGaussianNode;
use splatzoo_train::scene::skinned::{CanonicalPose, Placement, SkinnedConfig};

const LEFT_ELBOW: usize = 18;

/// One frame of the built-in body: the root at 3 m in front of a camera, the left elbow bent by
/// `elbow` (axis-angle), every other joint at rest.
fn node(elbow: [f64; 3], device: &Device) -> SkinnedGaussianNode {
    let mut poses = vec![0.0; 72];
    poses[3 * LEFT_ELBOW..3 * LEFT_ELBOW + 3].copy_from_slice(&elbow);
    let prior = PoseSequence {
        joints: 24,
        poses,
        translations: vec![0.0, 0.0, 3.0],
        betas: vec![0.0],
        shape_count: 1,
        fps: None,
    };
    let config = SkinnedConfig {
        placement: Placement::Vertices,
        canonical_pose: CanonicalPose::TPose,
        ..SkinnedConfig::default()
    };
    SkinnedGaussianNode::new(
        "avatar",
        &builtin_body().model,
        &prior,
        vec![true],
        &config,
        LearningRates::default(),
        &DensifyConfig {
            strategy: Strategy::None,
            ..DensifyConfig::default()
        },
        1.0,
        7,
        device,
    )
    .expect("a node on the built-in body")
}

/// With zero-initialised heads the field adds exactly nothing: posed centres and scales are
/// bit-identical with and without it, at a random pose.
#[test]
fn zero_heads_reproduce_the_prior_exactly() {
    let seed = fresh_seed();
    let mut rng = Rng(seed);
    let device = Device::flex();
    let elbow = [0.0; 3].map(|_| rng.range(-1.0, 1.0));
    let mut avatar = node(elbow, &device);
    let canonical = avatar.canonical_set().splats();
    let without = avatar.posed(canonical.clone(), 0).splats;
    avatar.set_non_rigid(Some(Box::new(PoseOffsets {
        net: PoseOffsetNet::new(&PoseOffsetConfig::default(), 24, &device),
        levels: PoseOffsetConfig::default().position_levels,
    })));
    let with = avatar.posed(canonical, 0).splats;
    assert_eq!(values(with.means), values(without.means), "seed {seed}");
    assert_eq!(
        values(with.log_scales),
        values(without.log_scales),
        "seed {seed}"
    );
}

/// A constant canonical offset δ (the head's bias) on forearm and hand Gaussians comes out rotated by
/// the elbow's rotation R: `posed(δ) − posed(0) = R δ`, not δ (which a posed-space offset
/// would give).
#[test]
fn offsets_are_applied_before_skinning() {
    let device = Device::flex();
    // 90° about the body's vertical axis.
    let angle = std::f64::consts::FRAC_PI_2;
    let mut avatar = node([0.0, angle, 0.0], &device);
    let canonical = avatar.canonical_set().splats();
    let without = values(avatar.posed(canonical.clone(), 0).splats.means);
    let delta = [0.03f32, 0.0, 0.0];
    let config = PoseOffsetConfig::default();
    let mut net = PoseOffsetNet::new(&config, 24, &device);
    net.offset_head.bias = Some(Param::from_tensor(Tensor::<1>::from_floats(delta, &device)));
    avatar.set_non_rigid(Some(Box::new(PoseOffsets {
        net,
        levels: config.position_levels,
    })));
    let with = values(avatar.posed(canonical, 0).splats.means);
    // Forearm and hand Gaussians (one per vertex): skinned (almost) only to the elbow and the
    // joints below it, which all turn with the elbow.
    let model = &builtin_body().model;
    let j = model.joint_count();
    let below_elbow: Vec<bool> = (0..j)
        .map(|mut joint| {
            loop {
                if joint == LEFT_ELBOW {
                    break true;
                }
                match model.parents[joint] {
                    Some(parent) => joint = parent,
                    None => break false,
                }
            }
        })
        .collect();
    let forearm: Vec<usize> = (0..model.vertex_count())
        .filter(|&k| {
            let w: f32 = (0..j)
                .filter(|&joint| below_elbow[joint])
                .map(|joint| model.skin_weights[k * j + joint])
                .sum();
            w > 0.9999
        })
        .collect();
    assert!(forearm.len() > 20, "{} forearm vertices", forearm.len());
    // R δ for a rotation of 90° about +y: (x, y, z) ↦ (z, y, −x).
    let want = [0.0, 0.0, -0.03];
    for &k in &forearm {
        let moved = [0, 1, 2].map(|c| with[3 * k + c] - without[3 * k + c]);
        for c in 0..3 {
            assert!(
                (moved[c] - want[c]).abs() < 1e-4,
                "vertex {k}: moved {moved:?}, want {want:?}"
            );
        }
    }
}
