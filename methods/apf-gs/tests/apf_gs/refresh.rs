//! `decouple.refresh_every`: `M_kine` re-rendered from the nodes' poses. At the prior's pose a
//! refresh reproduces the masks θ₀ gave (the node poses the same body the capture rendered);
//! a refresh happens on schedule, is checkpointed, and a resumed run continues with the same
//! masks; a node that is not one Gaussian per vertex is refused by name.

use crate::trainer::small;
use burn::tensor::Device;
use splatzoo_apf_gs::refresh::REFRESHED_MESHES;
use splatzoo_apf_gs::trainer::ApfTrainer;
use splatzoo_train::harness::Method;
use splatzoo_train::scene::skinned::Placement;

#[test]
fn a_refresh_at_the_prior_reproduces_the_first_masks() {
    let mut trainer = ApfTrainer::new(small(), &Device::flex()).unwrap();
    let before: Vec<_> = trainer
        .capture
        .train
        .iter()
        .map(|&i| trainer.capture.views[i].people.clone())
        .collect();
    let meshes = trainer.kinematic_meshes().unwrap();
    assert_eq!(meshes.len(), trainer.capture.people.len());
    trainer.apply_kinematic_meshes(meshes);
    let mut compared = 0;
    for (k, &i) in trainer.capture.train.iter().enumerate() {
        for (p, (old, new)) in before[k]
            .iter()
            .zip(&trainer.capture.views[i].people)
            .enumerate()
        {
            assert_eq!(old.coarse.data, new.coarse.data, "the coarse split moved");
            if old.kine.area() < 50 {
                continue;
            }
            let iou = old.kine.iou(&new.kine).unwrap();
            assert!(iou > 0.97, "view {i} person {p}: M_kine IoU {iou:.3}");
            compared += 1;
        }
    }
    assert!(compared > 10, "{compared} silhouettes compared");
}

#[test]
fn refreshes_happen_on_schedule_and_resume_exactly() {
    let mut c = small();
    c.iterations = 5;
    c.warmup = 1;
    c.decouple.refresh_every = 2;
    let mut a = ApfTrainer::new(c.clone(), &Device::flex()).unwrap();
    assert!(!a.refreshes_at(0) && a.refreshes_at(2) && !a.refreshes_at(3) && a.refreshes_at(4));
    for _ in 0..2 {
        a.step().expect("step");
    }
    assert!(!a.checkpoint().tensors.contains_key(REFRESHED_MESHES));
    a.step().expect("the step that refreshes");
    let mut saved = a.checkpoint();
    assert!(saved.tensors.contains_key(REFRESHED_MESHES));
    saved.put_meta("step", a.step);
    let mut b = ApfTrainer::resume(c, &saved, &Device::flex()).expect("resumes");
    for (va, vb) in a.capture.views.iter().zip(&b.capture.views) {
        for (pa, pb) in va.people.iter().zip(&vb.people) {
            assert_eq!(
                pa.kine.data, pb.kine.data,
                "view {}: M_kine after resume",
                va.name
            );
            assert_eq!(pa.accessory.data, pb.accessory.data);
        }
    }
    for _ in 0..2 {
        a.step().expect("step");
        b.step().expect("step");
    }
    let (ca, cb) = (a.checkpoint(), b.checkpoint());
    for (name, value) in &ca.tensors {
        assert_eq!(value, &cb.tensors[name], "{name} differs after resume");
    }
}

#[test]
fn a_node_without_one_gaussian_per_vertex_cannot_be_refreshed() {
    let mut c = small();
    c.human.placement = Placement::PerFace;
    c.decouple.refresh_every = 1;
    let trainer = ApfTrainer::new(c, &Device::flex()).unwrap();
    let e = trainer.kinematic_meshes().unwrap_err().to_string();
    assert!(
        e.contains("decouple.refresh_every") && e.contains("human.placement"),
        "{e}"
    );
}
