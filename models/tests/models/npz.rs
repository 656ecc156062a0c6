//! The `.npz` loader on files these tests write in the released key layouts and shapes of
//! SMPL (6890 vertices, 24 joints), SMPL-H (6890, 52) and SMPL-X (10475, 55), and on broken ones.

use burn::tensor::{Device, Tensor};
use npyz::WriterBuilder;
use npyz::npz::NpzWriter;
use splatzoo_models::body::{
    BodyKind, BodyTensors, FaceLandmark, PoseInput, lbs, load_npz, save_npz,
};
use std::path::Path;
use zip::write::FileOptions;

fn stored() -> FileOptions {
    FileOptions::default().compression_method(zip::CompressionMethod::Stored)
}

/// Writes an array of f64 or f32 (`single`) values, C or Fortran order.
fn put(
    npz: &mut NpzWriter<std::io::BufWriter<std::fs::File>>,
    key: &str,
    shape: &[usize],
    values: impl Iterator<Item = f64>,
    single: bool,
    fortran: bool,
) {
    let shape: Vec<u64> = shape.iter().map(|&d| d as u64).collect();
    let order = if fortran {
        npyz::Order::Fortran
    } else {
        npyz::Order::C
    };
    if single {
        let mut w = npz
            .array::<f32>(key, stored())
            .unwrap()
            .default_dtype()
            .shape(&shape)
            .order(order)
            .begin_nd()
            .unwrap();
        w.extend(values.map(|v| v as f32)).unwrap();
        w.finish().unwrap();
    } else {
        let mut w = npz
            .array::<f64>(key, stored())
            .unwrap()
            .default_dtype()
            .shape(&shape)
            .order(order)
            .begin_nd()
            .unwrap();
        w.extend(values).unwrap();
        w.finish().unwrap();
    }
}

struct Layout {
    vertices: usize,
    joints: usize,
    shape_dirs: usize,
    faces: usize,
}

const SMPL: Layout = Layout {
    vertices: 6890,
    joints: 24,
    shape_dirs: 10,
    faces: 13776,
};
const SMPLH: Layout = Layout {
    vertices: 6890,
    joints: 52,
    shape_dirs: 16,
    faces: 13776,
};
const SMPLX: Layout = Layout {
    vertices: 10475,
    joints: 55,
    shape_dirs: 400,
    faces: 20908,
};

/// A model file in `layout`: template on a helix, each joint regressing one vertex, vertices
/// skinned to one joint each, a chain of parents. `skip` leaves a key out; `root` is the root's
/// parent value in `kintree_table` (−1 or 2³²−1 in released files).
fn write_model(path: &Path, l: &Layout, skip: Option<&str>, root: f64) {
    let mut npz = NpzWriter::create(path).unwrap();
    let (v, j) = (l.vertices, l.joints);
    let mut put_unless = |key: &str,
                          shape: &[usize],
                          values: Box<dyn Iterator<Item = f64>>,
                          single: bool,
                          fortran: bool| {
        if skip != Some(key) {
            put(&mut npz, key, shape, values, single, fortran);
        }
    };
    put_unless(
        "v_template",
        &[v, 3],
        Box::new((0..v * 3).map(move |k| ((k / 3) as f64 * 0.01 + (k % 3) as f64).sin())),
        false,
        false,
    );
    put_unless(
        "f",
        &[l.faces, 3],
        Box::new((0..l.faces * 3).map(move |k| ((k / 3 + k % 3) % v) as f64)),
        false,
        false,
    );
    // Fortran order (as some conversions save it): element (joint, vertex) at joint + J·vertex.
    put_unless(
        "J_regressor",
        &[j, v],
        Box::new((0..j * v).map(move |k| if k / j == (k % j) * 7 { 1.0 } else { 0.0 })),
        false,
        true,
    );
    put_unless(
        "kintree_table",
        &[2, j],
        Box::new((0..2 * j).map(move |k| {
            if k == 0 {
                root
            } else if k < j {
                (k - 1) as f64
            } else {
                (k - j) as f64
            }
        })),
        false,
        false,
    );
    put_unless(
        "weights",
        &[v, j],
        Box::new((0..v * j).map(move |k| if k % j == (k / j) % j { 1.0 } else { 0.0 })),
        false,
        false,
    );
    put_unless(
        "shapedirs",
        &[v, 3, l.shape_dirs],
        Box::new((0..v * 3 * l.shape_dirs).map(|k| (k % 13) as f64 * 1e-3)),
        true,
        false,
    );
    put_unless(
        "posedirs",
        &[v, 3, 9 * (j - 1)],
        Box::new((0..v * 3 * 9 * (j - 1)).map(|_| 0.0)),
        true,
        false,
    );
    if j == 55 {
        // SMPL-X's 51 static face landmarks: face 100 + 3k, barycentrics (0.2, 0.3, 0.5).
        put_unless(
            "lmk_faces_idx",
            &[51],
            Box::new((0..51).map(|k| (100 + 3 * k) as f64)),
            false,
            false,
        );
        put_unless(
            "lmk_bary_coords",
            &[51, 3],
            Box::new((0..153).map(|k| [0.2, 0.3, 0.5][k % 3])),
            true,
            false,
        );
    }
    npz.zip_writer().finish().unwrap();
}

#[test]
fn smpl_smplh_smplx_load_with_their_released_layouts() {
    let dir = tempfile::tempdir().unwrap();
    for (name, layout, kind, shapes, exprs) in [
        ("smpl.npz", &SMPL, BodyKind::Smpl, 10, 0),
        ("smplh.npz", &SMPLH, BodyKind::SmplH, 16, 0),
        ("smplx.npz", &SMPLX, BodyKind::SmplX, 300, 100),
    ] {
        let path = dir.path().join(name);
        write_model(&path, layout, None, -1.0);
        let model = load_npz(&path).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(model.kind, kind);
        assert_eq!(model.vertex_count(), layout.vertices);
        assert_eq!(model.joint_count(), layout.joints);
        assert_eq!(model.face_count(), layout.faces);
        assert_eq!(model.shape_count(), shapes, "{name}");
        assert_eq!(model.expression_count(), exprs, "{name}");
        assert_eq!(model.joint_names.len(), layout.joints);
        assert_eq!(model.parents[0], None);
        assert_eq!(model.parents[5], Some(4));
        // The Fortran-ordered regressor came back in C order: joint k regresses vertex 7k.
        assert_eq!(model.joint_regressor[3 * layout.vertices + 21], 1.0);
        assert_eq!(
            model.pose_dirs.as_ref().map(Vec::len),
            Some(layout.vertices * 3 * 9 * (layout.joints - 1))
        );
    }
    let smplx = load_npz(&dir.path().join("smplx.npz")).unwrap();
    assert_eq!(smplx.joint_names[22], "jaw");
    let landmarks = smplx
        .face_landmarks
        .as_ref()
        .expect("SMPL-X's face landmarks");
    assert_eq!(landmarks.len(), 51);
    assert_eq!(
        landmarks[4],
        FaceLandmark {
            face: 112,
            weights: [0.2, 0.3, 0.5]
        }
    );
    assert!(
        load_npz(&dir.path().join("smpl.npz"))
            .unwrap()
            .face_landmarks
            .is_none()
    );
    // They survive `save_npz`.
    let again = dir.path().join("again.npz");
    save_npz(&smplx, &again).unwrap();
    assert_eq!(
        load_npz(&again).unwrap().face_landmarks,
        smplx.face_landmarks
    );
}

/// Face landmarks come in pairs of arrays and must sit on the mesh.
#[test]
fn face_landmark_errors_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let half = dir.path().join("half.npz");
    write_model(&half, &SMPLX, Some("lmk_bary_coords"), -1.0);
    let err = load_npz(&half).unwrap_err().to_string();
    assert!(
        err.contains("half.npz") && err.contains("`lmk_bary_coords`") && err.contains("[L, 3]"),
        "{err}"
    );
    let mut model = load_npz(&{
        let whole = dir.path().join("whole.npz");
        write_model(&whole, &SMPLX, None, -1.0);
        whole
    })
    .unwrap();
    model.face_landmarks.as_mut().unwrap()[7].face = 99_999;
    let off = dir.path().join("off.npz");
    save_npz(&model, &off).unwrap();
    let err = load_npz(&off).unwrap_err().to_string();
    assert!(
        err.contains("off.npz") && err.contains("`lmk_faces_idx`") && err.contains("landmark 7"),
        "{err}"
    );
}

#[test]
fn loaded_model_poses_to_its_template_at_rest() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("smpl.npz");
    write_model(&path, &SMPL, None, 4294967295.0);
    let model = load_npz(&path).unwrap();
    let device = Device::flex();
    let body = BodyTensors::new(&model, &device);
    let input = PoseInput::from_axis_angle(
        Tensor::zeros([1, 10], &device),
        Tensor::zeros([1, 72], &device),
        Tensor::zeros([1, 3], &device),
    );
    let posed = lbs::pose(&body, &input);
    let v = posed
        .vertices
        .into_data()
        .convert::<f32>()
        .try_into_vec::<f32>()
        .unwrap();
    for (a, e) in v.iter().zip(&model.template) {
        assert!((a - e).abs() < 1e-5);
    }
}

#[test]
fn errors_name_the_file_key_and_expected_shape() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("no_weights.npz");
    write_model(&missing, &SMPL, Some("weights"), -1.0);
    let err = load_npz(&missing).unwrap_err().to_string();
    assert!(
        err.contains("no_weights.npz") && err.contains("`weights`") && err.contains("[6890, 24]"),
        "{err}"
    );

    let wrong = dir.path().join("wrong.npz");
    {
        let mut npz = NpzWriter::create(&wrong).unwrap();
        put(
            &mut npz,
            "v_template",
            &[6890, 2],
            (0..6890 * 2).map(|_| 0.0),
            false,
            false,
        );
        npz.zip_writer().finish().unwrap();
    }
    let err = load_npz(&wrong).unwrap_err().to_string();
    assert!(
        err.contains("v_template") && err.contains("[V, 3]") && err.contains("[6890, 2]"),
        "{err}"
    );

    let truncated = dir.path().join("truncated.npz");
    let bytes = std::fs::read(&missing).unwrap();
    std::fs::write(&truncated, &bytes[..bytes.len() / 2]).unwrap();
    let err = load_npz(&truncated).unwrap_err().to_string();
    assert!(err.contains("truncated.npz"), "{err}");

    let err = load_npz(&dir.path().join("absent.npz"))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("absent.npz") && err.contains("cannot open"),
        "{err}"
    );

    let joints = dir.path().join("joints.npz");
    write_model(
        &joints,
        &Layout {
            vertices: 100,
            joints: 23,
            shape_dirs: 10,
            faces: 50,
        },
        None,
        -1.0,
    );
    let err = load_npz(&joints).unwrap_err().to_string();
    assert!(
        err.contains("kintree_table") && err.contains("23 joints"),
        "{err}"
    );
}
