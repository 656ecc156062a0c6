//! Image losses and metrics on `[H, W, C]` tensors in [0, 1]: L1, SSIM with the 11-tap Gaussian
//! window (σ = 1.5, zero padding, as INRIA 3DGS computes it), D-SSIM = (1 − SSIM) / 2, the 3DGS
//! training loss `(1 − λ) L1 + λ D-SSIM`, their masked variants, silhouette, and PSNR (plain
//! and masked).

use burn::tensor::Tensor;
use burn::tensor::module::conv2d;
use burn::tensor::ops::ConvOptions;

/// SSIM window radius (11 taps).
pub const WINDOW_RADIUS: usize = 5;
pub const WINDOW_SIGMA: f64 = 1.5;
const C1: f64 = 0.01 * 0.01;
const C2: f64 = 0.03 * 0.03;

/// The normalised 1-D Gaussian window.
pub fn window() -> [f64; 2 * WINDOW_RADIUS + 1] {
    let w: [f64; 2 * WINDOW_RADIUS + 1] = std::array::from_fn(|i| {
        let x = i as f64 - WINDOW_RADIUS as f64;
        (-x * x / (2.0 * WINDOW_SIGMA * WINDOW_SIGMA)).exp()
    });
    let sum: f64 = w.iter().sum();
    w.map(|v| v / sum)
}

/// Mean absolute difference.
pub fn l1(image: Tensor<3>, target: Tensor<3>) -> Tensor<1> {
    (image - target).abs().mean()
}

/// Gaussian blur of `[1, C, H, W]`, per channel, zero padding (separable).
fn blur(x: Tensor<4>) -> Tensor<4> {
    let c = x.dims()[1];
    let device = x.device();
    let taps: Vec<f32> = window().iter().map(|&v| v as f32).collect();
    let k = taps.len();
    let row = Tensor::<1>::from_floats(taps.as_slice(), &device)
        .reshape([1, 1, 1, k])
        .repeat_dim(0, c);
    let column = row.clone().reshape([c, 1, k, 1]);
    let r = WINDOW_RADIUS;
    let x = conv2d(x, row, None, ConvOptions::new([1, 1], [0, r], [1, 1], c));
    conv2d(x, column, None, ConvOptions::new([1, 1], [r, 0], [1, 1], c))
}

/// Per-pixel SSIM map `[H, W, C]` of two `[H, W, C]` images.
pub fn ssim_map(image: Tensor<3>, target: Tensor<3>) -> Tensor<3> {
    let [h, w, c] = image.dims();
    assert_eq!(
        target.dims(),
        [h, w, c],
        "ssim: image and target shapes differ"
    );
    let x = image.permute([2, 0, 1]).reshape([1, c, h, w]);
    let y = target.permute([2, 0, 1]).reshape([1, c, h, w]);
    let mu_x = blur(x.clone());
    let mu_y = blur(y.clone());
    let xx = blur(x.clone() * x.clone()) - mu_x.clone() * mu_x.clone();
    let yy = blur(y.clone() * y.clone()) - mu_y.clone() * mu_y.clone();
    let xy = blur(x * y) - mu_x.clone() * mu_y.clone();
    let numerator = (mu_x.clone() * mu_y.clone() * 2.0 + C1) * (xy * 2.0 + C2);
    let denominator = (mu_x.powi_scalar(2) + mu_y.powi_scalar(2) + C1) * (xx + yy + C2);
    (numerator / denominator)
        .reshape([c, h, w])
        .permute([1, 2, 0])
}

/// Mean SSIM.
pub fn ssim(image: Tensor<3>, target: Tensor<3>) -> Tensor<1> {
    ssim_map(image, target).mean()
}

/// D-SSIM = (1 − SSIM) / 2.
pub fn d_ssim(image: Tensor<3>, target: Tensor<3>) -> Tensor<1> {
    (ssim(image, target) - 1.0) * -0.5
}

/// The 3DGS photometric loss `(1 − λ) L1 + λ (1 − SSIM)` (Eq. 7 of 3DGS, λ = 0.2 there).
pub fn photometric(image: Tensor<3>, target: Tensor<3>, lambda: f64) -> Tensor<1> {
    let l1 = l1(image.clone(), target.clone());
    let structure = (ssim(image, target) - 1.0) * -1.0;
    l1 * (1.0 - lambda) + structure * lambda
}

/// L1 over the pixels where `mask` `[H, W]` is 1 (mean over masked pixels and channels).
pub fn masked_l1(image: Tensor<3>, target: Tensor<3>, mask: Tensor<2>) -> Tensor<1> {
    let [h, w, c] = image.dims();
    let m = mask.reshape([h, w, 1]);
    let count = m.clone().sum().clamp_min(1.0) * c as f64;
    ((image - target).abs() * m).sum() / count
}

/// Mean SSIM over the pixels where `mask` `[H, W]` is 1.
pub fn masked_ssim(image: Tensor<3>, target: Tensor<3>, mask: Tensor<2>) -> Tensor<1> {
    let [h, w, c] = image.dims();
    let m = mask.reshape([h, w, 1]);
    let count = m.clone().sum().clamp_min(1.0) * c as f64;
    (ssim_map(image, target) * m).sum() / count
}

/// Silhouette loss: mean absolute difference of rendered alpha `[H, W]` and a mask.
pub fn silhouette(alpha: Tensor<2>, mask: Tensor<2>) -> Tensor<1> {
    (alpha - mask).abs().mean()
}

/// PSNR in dB of images in [0, 1] (from the mean squared error over all pixels and channels).
pub fn psnr(image: Tensor<3>, target: Tensor<3>) -> f64 {
    let mse = scalar((image - target).powi_scalar(2).mean());
    -10.0 * mse.max(1e-20).log10()
}

/// PSNR over the pixels where `mask` `[H, W]` is 1 (the human-region PSNR).
pub fn masked_psnr(image: Tensor<3>, target: Tensor<3>, mask: Tensor<2>) -> f64 {
    let [h, w, c] = image.dims();
    let m = mask.reshape([h, w, 1]);
    let count = scalar(m.clone().sum()) * c as f64;
    let sse = scalar(((image - target).powi_scalar(2) * m).sum());
    -10.0 * (sse / count.max(1.0)).max(1e-20).log10()
}

/// The value of a one-element tensor.
pub fn scalar(t: Tensor<1>) -> f64 {
    t.into_data()
        .convert::<f64>()
        .try_into_vec::<f64>()
        .expect("f64 data")[0]
}
