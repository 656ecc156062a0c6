//! NLF-GS training data from real THuman2.0 renders in GHG's layout (one split folder, e.g.
//! `THuman/train`, read by [`splatzoo_datasets::formats::ghg`]) posed with a user-given SMPL-X
//! model: one [`NlfSubject`] per THuman2.0 subject, with GHG's test protocol as the views
//! (inputs: view 0 of ring positions 0, 6, 11; targets: view 0 of 3, 8, 13).
//!
//! Per subject: the SMPL-X fit (`smplx/<s>/smplx_param.pkl` + `transform/<s>_transform.npy`)
//! is posed by the differentiable LBS of `splatzoo-models` (global orient, body, jaw, eyes and
//! 45-D hands; betas; expression) and placed in the render's world by the loader's
//! [`Similarity`]; the input views' body depth (camera z, ∞ off the mesh) comes from the mesh
//! renderer's z-buffer ([`rasterize`]) at the loaded resolution. Images stay sRGB as stored; with
//! `size` they are shrunk (longest side = `size`, no upscaling) by averaging the source pixels
//! whose centres fall in each output pixel, masks likewise then thresholded at ½, and the
//! intrinsics scaled by the same factors (exact with pixel centres at +0.5). The background is
//! the mean colour off the masks over the subject's views. What cannot be represented is said
//! in [`GhgSubjects::warnings`]: subjects skipped (no fit, missing views or masks) and
//! parameters posed at rest (THuman2.0's 12-D PCA hand poses need the model's
//! `hands_components`, which [`splatzoo_models::body::BodyModel`] does not keep).

use crate::data::{NlfSubject, NlfView};
use burn::tensor::{Device, Tensor, TensorData};
use splatzoo_datasets::DatasetError;
use splatzoo_datasets::formats::{self, BodyFrame, Dataset, Format, Similarity, ViewRecord};
use splatzoo_datasets::render::visibility::rasterize;
use splatzoo_datasets::render::{MeshRef, camera_view};
use splatzoo_models::body::{BodyKind, BodyModel, BodyTensors, PoseInput, lbs, load_body_model};
use splatzoo_train::{TrainError, host_f32};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The body the anchors live on: the user's model's triangles (the trainer's `faces`).
#[derive(Debug, Clone)]
pub struct BodyMesh {
    pub source: PathBuf,
    pub kind: BodyKind,
    /// `[F · 3]` vertex indices.
    pub faces: Vec<u32>,
    pub vertex_count: usize,
}

/// What [`ghg_subjects`] built from one split.
pub struct GhgSubjects {
    pub subjects: Vec<NlfSubject>,
    /// The THuman2.0 subject id of each subject (`0004`).
    pub names: Vec<String>,
    /// Per subject, where the SMPL-X output lives in the render's world (GHG's scale and shift;
    /// [`NlfSubject::translation`] holds only its translation).
    pub placements: Vec<Similarity>,
    pub body: BodyMesh,
    /// Subjects skipped and parameters not represented, one line each.
    pub warnings: Vec<String>,
}

/// SMPL-X parameters beyond body pose: key, first joint, axis-angle values.
const EXTRA_JOINTS: [(&str, usize, usize); 5] = [
    ("jaw_pose", 22, 3),
    ("leye_pose", 23, 3),
    ("reye_pose", 24, 3),
    ("left_hand_pose", 25, 45),
    ("right_hand_pose", 40, 45),
];

/// Loads the GHG split `split`, poses `body_model` (SMPL-X, `.npz` or `.pkl`) per subject and
/// builds one subject per THuman2.0 subject that has a fit, its input and target views and
/// masks; `size` shrinks the images to that longest side.
pub fn ghg_subjects(
    split: &Path,
    body_model: &Path,
    size: Option<u32>,
    device: &Device,
) -> Result<GhgSubjects, TrainError> {
    let model = load_body_model(body_model).map_err(DatasetError::from)?;
    if model.kind != BodyKind::SmplX {
        return Err(TrainError::Config(format!(
            "{}: a {:?} model with {} joints; GHG's THuman2.0 fits are SMPL-X (55 joints)",
            body_model.display(),
            model.kind,
            model.joint_count()
        )));
    }
    if size == Some(0) {
        return Err(TrainError::Config("size 0: expected ≥ 1 pixel".into()));
    }
    let dataset = formats::load(split, Some(Format::Ghg))?;
    let tensors = BodyTensors::new(&model, device);
    let faces: Vec<[u32; 3]> = model
        .faces
        .chunks_exact(3)
        .map(|f| [f[0], f[1], f[2]])
        .collect();
    let role = |name: &str| dataset.splits.get(name).cloned().unwrap_or_default();
    let (inputs, targets) = (role("inputs"), role("targets"));
    let mut warnings = Vec::new();
    let mut notes: BTreeMap<&'static str, usize> = BTreeMap::new();
    let (mut subjects, mut names, mut placements) = (Vec::new(), Vec::new(), Vec::new());
    for (f, track) in dataset.people.iter().enumerate() {
        let name = &track.person;
        let (ins, outs) = (
            views_of(&dataset, &inputs, f),
            views_of(&dataset, &targets, f),
        );
        let Some(frame) = track.frames.get(f).and_then(Option::as_ref) else {
            warnings.push(format!(
                "subject {name}: no SMPL-X fit (smplx/{name}/smplx_param.pkl and \
                 transform/{name}_transform.npy): skipped"
            ));
            continue;
        };
        if ins.len() != 3 || outs.is_empty() {
            warnings.push(format!(
                "subject {name}: {} input views (view 0 of positions 0, 6, 11) and {} target \
                 views (3, 8, 13), expected 3 and ≥ 1: skipped",
                ins.len(),
                outs.len()
            ));
            continue;
        }
        if let Some(v) = ins.iter().chain(&outs).find(|v| v.mask.is_none()) {
            warnings.push(format!(
                "subject {name}: {} has no mask under mask/: skipped",
                v.image.display()
            ));
            continue;
        }
        if frame.root_position.is_some() {
            warnings.push(format!(
                "subject {name}: the fit gives a root position, not a translation: skipped"
            ));
            continue;
        }
        let vertices = posed_vertices(&model, &tensors, frame, device, &mut notes);
        let mut background = ([0.0f64; 3], 0u64);
        let mut load = |v: &&ViewRecord| load_view(v, size, device, &mut background);
        let input_views = ins.iter().map(&mut load).collect::<Result<Vec<_>, _>>()?;
        let target_views = outs.iter().map(&mut load).collect::<Result<Vec<_>, _>>()?;
        let (w, h) = (input_views[0].camera.width, input_views[0].camera.height);
        for (record, view) in ins.iter().zip(&input_views) {
            if (view.camera.width, view.camera.height) != (w, h) {
                return Err(DatasetError::file(
                    &record.image,
                    format!(
                        "is {}×{} as loaded, the first input view {w}×{h}: the three inputs \
                         must share one size",
                        view.camera.width, view.camera.height
                    ),
                )
                .into());
            }
        }
        let mesh = [MeshRef {
            positions: &vertices,
            faces: &faces,
        }];
        let depth: Vec<f32> = input_views
            .iter()
            .flat_map(|v| rasterize(&mesh, &camera_view(&v.camera, 1)))
            .map(|hit| hit.map_or(f32::INFINITY, |hit| hit.depth as f32))
            .collect();
        let (sum, count) = background;
        let mean = sum.map(|s| (s / count.max(1) as f64) as f32);
        let flat: Vec<f32> = vertices.iter().flatten().copied().collect();
        let (w, h) = (w as usize, h as usize);
        subjects.push(NlfSubject {
            seed: name.parse().unwrap_or(f as u64),
            inputs: input_views,
            targets: target_views,
            vertices: Tensor::<3>::from_data(TensorData::new(flat, [1, vertices.len(), 3]), device),
            input_depth: Tensor::<3>::from_data(TensorData::new(depth, [3, h, w]), device),
            background: mean,
            betas: frame.betas.clone(),
            translation: frame.world_from_smpl.apply(frame.transl),
        });
        names.push(name.clone());
        placements.push(frame.world_from_smpl);
    }
    for (key, n) in notes {
        let hint = if key.ends_with("hand_pose") {
            " (THuman2.0 stores 12 PCA coefficients; decoding them needs the model's \
             `hands_components`, which the body-model loader does not keep)"
        } else {
            ""
        };
        warnings.push(format!(
            "`{key}` could not be applied in full in {n} subject(s){hint}: the joints it \
             poses stay at rest, or its coefficients beyond the model's are dropped"
        ));
    }
    if subjects.is_empty() {
        return Err(TrainError::Config(format!(
            "{}: no usable subject of {}: {}",
            split.display(),
            dataset.people.len(),
            warnings.join("; ")
        )));
    }
    Ok(GhgSubjects {
        subjects,
        names,
        placements,
        body: BodyMesh {
            source: body_model.to_path_buf(),
            kind: model.kind,
            faces: model.faces.clone(),
            vertex_count: model.vertex_count(),
        },
        warnings,
    })
}

/// The views among `list` (indices into `dataset.views`) that show frame (subject) `frame`.
fn views_of<'a>(dataset: &'a Dataset, list: &[usize], frame: usize) -> Vec<&'a ViewRecord> {
    list.iter()
        .map(|&i| &dataset.views[i])
        .filter(|v| v.frame == frame)
        .collect()
}

/// Writes axis-angle `values` from joint `joint` on (clipped to the pose vector).
fn put(angles: &mut [f32], joint: usize, values: &[f64]) {
    for (slot, &v) in angles[3 * joint..].iter_mut().zip(values) {
        *slot = v as f32;
    }
}

/// The fit's SMPL-X mesh in the render's world; parameters that cannot be applied are counted
/// in `notes` by key.
fn posed_vertices(
    model: &BodyModel,
    tensors: &BodyTensors,
    frame: &BodyFrame,
    device: &Device,
    notes: &mut BTreeMap<&'static str, usize>,
) -> Vec<[f32; 3]> {
    let j = model.joint_count();
    let mut angles = vec![0.0f32; 3 * j];
    put(&mut angles, 0, &frame.global_orient);
    put(
        &mut angles,
        1,
        &frame.body_pose[..frame.body_pose.len().min(63)],
    );
    for (key, joint, len) in EXTRA_JOINTS {
        match frame.extra.get(key) {
            Some(v) if v.len() == len => put(&mut angles, joint, v),
            Some(v) if v.iter().any(|&x| x != 0.0) => *notes.entry(key).or_default() += 1,
            _ => {}
        }
    }
    let s = frame.betas.len().min(model.shape_count());
    if frame.betas[s..].iter().any(|&b| b != 0.0) {
        *notes.entry("betas").or_default() += 1;
    }
    let betas = if s == 0 {
        Tensor::<2>::zeros([1, 0], device)
    } else {
        let b: Vec<f32> = frame.betas[..s].iter().map(|&b| b as f32).collect();
        Tensor::<2>::from_data(TensorData::new(b, [1, s]), device)
    };
    let transl: Vec<f32> = frame.transl.iter().map(|&t| t as f32).collect();
    let mut input = PoseInput::from_axis_angle(
        betas,
        Tensor::<2>::from_data(TensorData::new(angles, [1, 3 * j]), device),
        Tensor::<2>::from_data(TensorData::new(transl, [1, 3]), device),
    );
    if let Some(e) = frame.extra.get("expression") {
        let k = e.len().min(model.expression_count());
        if e[k..].iter().any(|&x| x != 0.0) {
            *notes.entry("expression").or_default() += 1;
        }
        if k > 0 {
            let c: Vec<f32> = e[..k].iter().map(|&x| x as f32).collect();
            input.expression = Some(Tensor::<2>::from_data(TensorData::new(c, [1, k]), device));
        }
    }
    let posed = host_f32(&lbs::pose(tensors, &input).vertices);
    let m = &frame.world_from_smpl;
    posed
        .chunks_exact(3)
        .map(|p| {
            m.apply([p[0] as f64, p[1] as f64, p[2] as f64])
                .map(|x| x as f32)
        })
        .collect()
}

/// `(width, height)` with the longest side `side`, or `None` when that would upscale.
fn target_size(side: u32, w: usize, h: usize) -> Option<(usize, usize)> {
    let long = w.max(h);
    if side as usize > long {
        return None;
    }
    let scale = side as f64 / long as f64;
    let dim = |d: usize| ((d as f64 * scale).round() as usize).max(1);
    Some((dim(w), dim(h)))
}

/// `[h, w, c]` values averaged down to `[oh, ow, c]`: each source pixel goes to the output
/// pixel holding its centre.
fn shrink(
    values: Vec<f32>,
    (w, h): (usize, usize),
    c: usize,
    (ow, oh): (usize, usize),
) -> Vec<f32> {
    if (w, h) == (ow, oh) {
        return values;
    }
    let mut sum = vec![0.0f32; ow * oh * c];
    let mut count = vec![0u32; ow * oh];
    for y in 0..h {
        let oy = (2 * y + 1) * oh / (2 * h);
        for x in 0..w {
            let o = oy * ow + (2 * x + 1) * ow / (2 * w);
            count[o] += 1;
            let source = &values[(y * w + x) * c..][..c];
            for (s, &v) in sum[o * c..][..c].iter_mut().zip(source) {
                *s += v;
            }
        }
    }
    for (pixel, &n) in sum.chunks_exact_mut(c).zip(&count) {
        pixel.iter_mut().for_each(|s| *s /= n.max(1) as f32);
    }
    sum
}

/// One view: the sRGB image and its mask (shrunk to `size` with its camera); adds its
/// off-mask colours to `background` (sum, count).
fn load_view(
    record: &ViewRecord,
    size: Option<u32>,
    device: &Device,
    background: &mut ([f64; 3], u64),
) -> Result<NlfView, TrainError> {
    let path = record.image.as_path();
    let decoded = image::open(path)
        .map_err(|e| DatasetError::file(path, format!("cannot decode ({e})")))?
        .to_rgb32f();
    let (w, h) = (decoded.width(), decoded.height());
    let mut camera = record.camera;
    if (w, h) != (camera.width, camera.height) {
        return Err(DatasetError::file(
            path,
            format!(
                "is {w}×{h}, its camera says {}×{}",
                camera.width, camera.height
            ),
        )
        .into());
    }
    let mask_path = record.mask.as_deref().unwrap_or(path);
    let (mw, mh, person) = match record.read_mask() {
        Some(mask) => mask?,
        None => return Err(DatasetError::file(path, "has no mask").into()),
    };
    if (mw, mh) != (w, h) {
        return Err(
            DatasetError::file(mask_path, format!("is {mw}×{mh}, its image {w}×{h}")).into(),
        );
    }
    let (w, h) = (w as usize, h as usize);
    let mut srgb = decoded.into_raw();
    let mut mask: Vec<f32> = person.iter().map(|&p| p as u8 as f32).collect();
    let (ow, oh) = match size {
        None => (w, h),
        Some(side) => target_size(side, w, h).ok_or_else(|| {
            TrainError::Config(format!(
                "size {side} exceeds {} ({w}×{h}): images are not upscaled",
                path.display()
            ))
        })?,
    };
    if (ow, oh) != (w, h) {
        srgb = shrink(srgb, (w, h), 3, (ow, oh));
        mask = shrink(mask, (w, h), 1, (ow, oh))
            .into_iter()
            .map(|m| (m >= 0.5) as u8 as f32)
            .collect();
        let (sx, sy) = (ow as f32 / w as f32, oh as f32 / h as f32);
        camera.fx *= sx;
        camera.cx *= sx;
        camera.fy *= sy;
        camera.cy *= sy;
        camera.width = ow as u32;
        camera.height = oh as u32;
    }
    for (&m, pixel) in mask.iter().zip(srgb.chunks_exact(3)) {
        if m == 0.0 {
            background.1 += 1;
            for (s, &c) in background.0.iter_mut().zip(pixel) {
                *s += c as f64;
            }
        }
    }
    Ok(NlfView {
        camera,
        image: Tensor::<3>::from_data(TensorData::new(srgb, [oh, ow, 3]), device),
        mask: Tensor::<2>::from_data(TensorData::new(mask, [oh, ow]), device),
    })
}
