//! File writers shared by the loader tests ([`crate::formats`], [`crate::real_layouts`]): images
//! and masks, `.npy`/`.npz` arrays through npyz, numbers and matrices as `np.savetxt` writes
//! them, and THuman2.0 rendered by GHG (the renders of `process_dataset/render_image.py`, the
//! SMPL-X fits and transforms beside them).

use npyz::WriterBuilder;
use splatzoo_models::pickle::{Writer, npy_object_bytes};
use std::path::Path;

pub(crate) fn close(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-5
}

pub(crate) fn write_rgb(path: &Path, w: u32, h: u32) {
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    image::RgbImage::from_fn(w, h, |x, y| image::Rgb([x as u8 * 20, y as u8 * 30, 90]))
        .save(path)
        .unwrap();
}

/// A grey mask with `inside` inside the block x < 4, y < 3 and `outside` elsewhere.
pub(crate) fn write_mask(path: &Path, w: u32, h: u32, inside: u8, outside: u8) {
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    image::GrayImage::from_fn(w, h, |x, y| {
        image::Luma([if x < 4 && y < 3 { inside } else { outside }])
    })
    .save(path)
    .unwrap();
}

/// Writes arrays into an `.npz` as float32 (`f32 = true`) or float64, or as int64 scalars.
pub(crate) fn write_npz(path: &Path, arrays: &[(&str, &[u64], &[f64])], f32s: bool) {
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    let mut npz = npyz::npz::NpzWriter::create(path).unwrap();
    for &(name, shape, values) in arrays {
        if shape.is_empty() {
            let mut w = npz
                .array::<i64>(name, Default::default())
                .unwrap()
                .default_dtype()
                .shape(shape)
                .begin_nd()
                .unwrap();
            w.extend(values.iter().map(|&v| v as i64)).unwrap();
            w.finish().unwrap();
        } else if f32s {
            let mut w = npz
                .array::<f32>(name, Default::default())
                .unwrap()
                .default_dtype()
                .shape(shape)
                .begin_nd()
                .unwrap();
            w.extend(values.iter().map(|&v| v as f32)).unwrap();
            w.finish().unwrap();
        } else {
            let mut w = npz
                .array::<f64>(name, Default::default())
                .unwrap()
                .default_dtype()
                .shape(shape)
                .begin_nd()
                .unwrap();
            w.extend(values.iter().copied()).unwrap();
            w.finish().unwrap();
        }
    }
    npz.zip_writer().finish().unwrap();
}

pub(crate) fn write_npy_u8(path: &Path, h: usize, w: usize, values: &[u8]) {
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    let mut out = npyz::WriteOptions::new()
        .default_dtype()
        .shape(&[h as u64, w as u64])
        .writer(std::fs::File::create(path).unwrap())
        .begin_nd()
        .unwrap();
    out.extend(values.iter().copied()).unwrap();
    out.finish().unwrap();
}

pub(crate) fn write_npy_f64(path: &Path, shape: &[u64], values: &[f64]) {
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    let mut out = npyz::WriteOptions::new()
        .default_dtype()
        .shape(shape)
        .writer(std::fs::File::create(path).unwrap())
        .begin_nd()
        .unwrap();
    out.extend(values.iter().copied()).unwrap();
    out.finish().unwrap();
}

/// GHG's look-at rule: camera at `position` looking at `target` with OpenCV axes (y down), world
/// y up: rows of R are right, down, forward; t = −R · position.
pub(crate) fn ghg_extrinsic(position: [f64; 3], target: [f64; 3]) -> Vec<f64> {
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let norm = |a: [f64; 3]| {
        let l = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
        a.map(|v| v / l)
    };
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let forward = norm(sub(target, position));
    let right = norm(cross(forward, [0.0, 1.0, 0.0]));
    let down = cross(forward, right);
    let r = [right, down, forward];
    let mut e = Vec::new();
    for row in r {
        e.extend(row);
        e.push(-(0..3).map(|j| row[j] * position[j]).sum::<f64>());
    }
    // [r00 r01 r02 t0; …] row-major.
    let mut out = Vec::new();
    for i in 0..3 {
        out.extend(&e[4 * i..4 * i + 4]);
    }
    out
}

/// One subject's renders in a split folder as GHG's `process_dataset/render_image.py` writes
/// them: per ring position `<subject>_<pid:03>`, views `0..views` with `img/<s>/<v>.jpg`,
/// `mask/<s>/<v>.png` (the renderer's 3-channel 0/255 mask), `depth/<s>/<v>.png` (uint16,
/// depth·2¹⁵), `parm/<s>/<v>_{intrinsic,extrinsic}.npy` (float64), and `<v>_hr.jpg` at twice the
/// size for views 2–4. K is GHG's at 1024 px scaled to 16 px (`fx = 0.8·res`, `cx = res/2`,
/// `cy = res/2 + 25·res/1024`), cameras on a 2 m ring looking at (0, 0.85, 0).
pub(crate) fn ghg_subject(split: &Path, subject: &str, positions: &[usize], views: usize) {
    for &position in positions {
        let s = format!("{subject}_{position:03}");
        for v in 0..views {
            write_rgb(&split.join(format!("img/{s}/{v}.jpg")), 16, 16);
            if (2..5).contains(&v) {
                write_rgb(&split.join(format!("img/{s}/{v}_hr.jpg")), 32, 32);
            }
            let mask = split.join(format!("mask/{s}/{v}.png"));
            std::fs::create_dir_all(mask.parent().unwrap()).unwrap();
            image::RgbImage::from_fn(16, 16, |x, y| {
                image::Rgb([if x < 4 && y < 3 { 255 } else { 0 }; 3])
            })
            .save(&mask)
            .unwrap();
            let depth = split.join(format!("depth/{s}/{v}.png"));
            std::fs::create_dir_all(depth.parent().unwrap()).unwrap();
            image::ImageBuffer::from_pixel(16, 16, image::Luma([1u16 << 15]))
                .save(&depth)
                .unwrap();
            write_npy_f64(
                &split.join(format!("parm/{s}/{v}_intrinsic.npy")),
                &[3, 3],
                &[12.8, 0.0, 8.0, 0.0, 12.8, 8.4, 0.0, 0.0, 1.0],
            );
            let angle = (position as f64 * 22.5 + v as f64 * 22.5).to_radians();
            let position_3d = [2.0 * angle.sin(), 1.128, 2.0 * angle.cos()];
            write_npy_f64(
                &split.join(format!("parm/{s}/{v}_extrinsic.npy")),
                &[3, 4],
                &ghg_extrinsic(position_3d, [0.0, 0.85, 0.0]),
            );
        }
    }
}

/// A subject's SMPL-X fit where GHG keeps THuman2.0's (`<thuman>/THuman2.0_smplx/<subject>/
/// smplx_param.pkl`, a plain pickle of float32 arrays; `render_image.py`,
/// `generate_smplx_obj.py`) and the transform `render_image.py` saves beside the scan
/// (`<thuman>/THuman2.0_Release/<subject>/<subject>_transform.npy`, `np.save` of its dict).
pub(crate) fn ghg_fit(thuman: &Path, subject: &str) {
    let mut w = Writer::new(false);
    w.begin_dict();
    for (key, n) in [
        ("betas", 10),
        ("global_orient", 3),
        ("body_pose", 63),
        ("left_hand_pose", 12),
        ("right_hand_pose", 12),
        ("jaw_pose", 3),
        ("leye_pose", 3),
        ("reye_pose", 3),
        ("expression", 10),
    ] {
        w.str(key).array(&[1, n], &vec![0.1; n], false);
    }
    w.str("scale")
        .array(&[1], &[0.9], false)
        .str("translation")
        .array(&[1, 3], &[0.0, 0.3, 0.1], false);
    w.end_dict();
    let params = thuman.join(format!("THuman2.0_smplx/{subject}/smplx_param.pkl"));
    std::fs::create_dir_all(params.parent().unwrap()).unwrap();
    std::fs::write(&params, w.finish()).unwrap();
    let mut w = Writer::new(false);
    w.begin_object_scalar().begin_dict();
    w.str("vy_max")
        .numpy_scalar(1.2)
        .str("vy_min")
        .numpy_scalar(-0.6)
        .str("height_delta")
        .array(&[1], &[0.0], true);
    w.str("human_height")
        .array(&[1], &[1.8], true)
        .str("offset")
        .numpy_scalar(-0.5);
    w.str("delta_x")
        .numpy_scalar(0.5)
        .str("delta_z")
        .numpy_scalar(0.4)
        .str("move_range")
        .float(0.05);
    w.str("move_delta_axis_0")
        .array(&[1], &[0.05], true)
        .str("move_delta_axis_2")
        .array(&[1], &[-0.01], true);
    w.end_dict().end_object_scalar();
    let transform = thuman.join(format!(
        "THuman2.0_Release/{subject}/{subject}_transform.npy"
    ));
    std::fs::create_dir_all(transform.parent().unwrap()).unwrap();
    std::fs::write(&transform, npy_object_bytes(&w.finish())).unwrap();
}

/// THuman2.0 rendered by GHG (`CUSTOM_DATASET.md`'s tree): subject 0004 at ring positions 0, 3
/// and 6, views 0 and 1, in `<thuman>/val`, with its fit; returns the split folder.
pub(crate) fn ghg_fixture(thuman: &Path) -> std::path::PathBuf {
    let split = thuman.join("val");
    ghg_subject(&split, "0004", &[0, 3, 6], 2);
    ghg_fit(thuman, "0004");
    split
}

/// A number as numpy's `savetxt` writes it (`%.18e`: `1.500000000000000000e+00`).
pub(crate) fn savetxt_number(v: f64) -> String {
    let text = format!("{v:.18e}");
    let (mantissa, exponent) = text.split_once('e').expect("Rust's {:e} has an exponent");
    let exponent: i32 = exponent.parse().expect("an integer exponent");
    let sign = if exponent < 0 { '-' } else { '+' };
    format!("{mantissa}e{sign}{:02}", exponent.abs())
}

/// A 4×4 matrix as `np.savetxt` writes one (rows on lines, `%.18e`, space-separated), as
/// drivestudio's `waymo_preprocess.py` saves ego poses and extrinsics.
pub(crate) fn write_matrix(path: &Path, m: [[f64; 4]; 4]) {
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    let rows: Vec<String> = m
        .iter()
        .map(|r| {
            r.iter()
                .map(|&v| savetxt_number(v))
                .collect::<Vec<_>>()
                .join(" ")
        })
        .collect();
    std::fs::write(path, rows.join("\n") + "\n").unwrap();
}
