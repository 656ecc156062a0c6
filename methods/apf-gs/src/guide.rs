//! The guidance module's inputs and outputs per (person, frame): `f_img` is `E` over the
//! person's crops from the training views at that frame, averaged over cameras; at a frame
//! with no training crop (a held-out timestep, or one where the person is hidden) it is
//! interpolated linearly from the nearest frames that have one, as drivestudio interpolates a
//! test frame's pose (no held-out image is read). Then `(c_t, σ_t) = C(f_img ‖ e_h ‖ γ(t))`.

use crate::config::ApfConfig;
use crate::data::ApfCapture;
use crate::networks::{ApfNetworks, Embeddings};
use crate::scene::{Guided, time_encoding};
use burn::tensor::Tensor;

/// `[1, image_features]` of person `h` at a frame with crops.
fn features_at(nets: &ApfNetworks, capture: &ApfCapture, h: usize, t: usize) -> Option<Tensor<2>> {
    let crops = capture.crops[h][t].as_ref()?;
    let [v, _, _, _] = crops.dims();
    let crops = if nets.encoder.out.weight.val().is_autodiff() {
        crops.clone().autodiff()
    } else {
        crops.clone()
    };
    let f = nets.encoder.forward(crops);
    let [_, c] = f.dims();
    Some(f.sum_dim(0).reshape([1, c]) / v as f64)
}

/// `f_img` of person `h` at frame `t` (interpolated where the frame has no crop; zeros when
/// the person has no crop at all).
pub fn image_features(nets: &ApfNetworks, capture: &ApfCapture, h: usize, t: usize) -> Tensor<2> {
    if let Some(f) = features_at(nets, capture, h, t) {
        return f;
    }
    let has = |k: usize| capture.crops[h][k].is_some();
    let before = (0..t).rev().find(|&k| has(k));
    let after = (t + 1..capture.frames).find(|&k| has(k));
    let at = |k: usize| features_at(nets, capture, h, k).expect("frame has crops");
    match (before, after) {
        (Some(a), Some(b)) => {
            let w = (t - a) as f64 / (b - a) as f64;
            at(a) * (1.0 - w) + at(b) * w
        }
        (Some(k), None) | (None, Some(k)) => at(k),
        (None, None) => {
            let weight = nets.encoder.out.weight.val();
            let [_, c] = weight.dims();
            Tensor::zeros([1, c], &weight.device())
        }
    }
}

/// `(c_t, σ_t)` of person `h` at frame `t`.
pub fn guide(
    nets: &ApfNetworks,
    capture: &ApfCapture,
    config: &ApfConfig,
    h: usize,
    t: usize,
) -> Guided {
    let f = image_features(nets, capture, h, t);
    let device = f.device();
    let e = Embeddings::row(&nets.embeddings.person, h);
    let duration = capture.frames as f64 / capture.fps;
    let mut time = time_encoding(
        t as f64 / capture.fps,
        duration,
        config.network.time_levels,
        &device,
    );
    if f.is_autodiff() {
        time = time.autodiff();
    }
    let (condition, logit) = nets.guidance.forward(Tensor::cat(vec![f, e, time], 1));
    Guided {
        sigma: config.gate.sigma(logit.clone()),
        logit,
        condition,
    }
}
