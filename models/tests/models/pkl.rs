//! The `.pkl` loader on pickles these tests write byte by byte, the way Python 2's
//! `pickle.dump(protocol=2)` writes SMPL-family dicts: numpy arrays (C and Fortran order, f8,
//! f4, i8), a scipy CSC `J_regressor`, memoised dtypes; and on a chumpy pickle and broken files.

use splatzoo_models::body::{BodyKind, load_body_model, load_pkl};

/// A protocol-2 pickle writer for exactly what the tests need.
struct Pickle(Vec<u8>);

impl Pickle {
    fn new() -> Self {
        Pickle(vec![0x80, 2])
    }
    fn op(&mut self, bytes: &[u8]) -> &mut Self {
        self.0.extend_from_slice(bytes);
        self
    }
    fn global(&mut self, module: &str, name: &str) -> &mut Self {
        self.op(b"c")
            .op(module.as_bytes())
            .op(b"\n")
            .op(name.as_bytes())
            .op(b"\n")
    }
    fn str(&mut self, s: &str) -> &mut Self {
        let n = s.len() as u32;
        self.op(b"X").op(&n.to_le_bytes()).op(s.as_bytes())
    }
    fn short_bytes(&mut self, s: &[u8]) -> &mut Self {
        self.op(b"U").op(&[s.len() as u8]).op(s)
    }
    fn int(&mut self, v: i32) -> &mut Self {
        self.op(b"J").op(&v.to_le_bytes())
    }
    /// A numpy dtype; memoised under `memo` the first time, fetched after.
    fn dtype(&mut self, code: &str, memo: u8, first: bool) -> &mut Self {
        if !first {
            return self.op(&[b'h', memo]);
        }
        self.global("numpy", "dtype")
            .short_bytes(code.as_bytes())
            .int(0)
            .int(1)
            .op(&[0x87, b'R']);
        self.op(b"(")
            .int(3)
            .short_bytes(b"<")
            .op(b"NNN")
            .int(-1)
            .int(-1)
            .int(0)
            .op(b"t")
            .op(b"b");
        self.op(&[b'q', memo])
    }
    fn ndarray(
        &mut self,
        shape: &[usize],
        code: &str,
        raw: &[u8],
        fortran: bool,
        memo: (u8, bool),
    ) -> &mut Self {
        self.global("numpy.core.multiarray", "_reconstruct");
        self.global("numpy", "ndarray")
            .int(0)
            .op(&[0x85])
            .short_bytes(b"b")
            .op(&[0x87, b'R']);
        self.op(b"(").int(1).op(b"(");
        for &d in shape {
            self.int(d as i32);
        }
        self.op(b"t")
            .dtype(code, memo.0, memo.1)
            .op(&[if fortran { 0x88 } else { 0x89 }]);
        self.op(b"T")
            .op(&(raw.len() as u32).to_le_bytes())
            .op(raw)
            .op(b"t")
            .op(b"b")
    }
}

fn f8(values: impl Iterator<Item = f64>) -> Vec<u8> {
    values.flat_map(f64::to_le_bytes).collect()
}

const V: usize = 30;
const J: usize = 24;

/// An SMPL-layout dict (24 joints) on a small mesh; `chumpy` replaces `v_template` by a chumpy
/// object as in the original SMPL release.
fn smpl_pickle(chumpy: bool) -> Vec<u8> {
    let mut p = Pickle::new();
    p.op(b"}").op(b"(");
    p.str("v_template");
    if chumpy {
        p.global("copy_reg", "_reconstructor")
            .global("chumpy.ch", "Ch")
            .global("__builtin__", "object")
            .op(b"N")
            .op(&[0x87, b'R']);
        p.op(b"}").op(b"b");
    } else {
        p.ndarray(
            &[V, 3],
            "f8",
            &f8((0..V * 3).map(|k| k as f64 * 0.1)),
            false,
            (1, true),
        );
    }
    p.str("f").ndarray(
        &[V - 2, 3],
        "i8",
        &(0..(V - 2) * 3)
            .flat_map(|k| ((k / 3 + k % 3) as i64).to_le_bytes())
            .collect::<Vec<_>>(),
        false,
        (2, true),
    );
    // J_regressor as scipy CSC: joint j regresses vertex j (column j has row... transposed
    // layout: CSC of a [J, V] matrix stores columns = vertices).
    p.str("J_regressor");
    p.global("copy_reg", "_reconstructor")
        .global("scipy.sparse.csc", "csc_matrix")
        .global("__builtin__", "object")
        .op(b"N")
        .op(&[0x87, b'R']);
    p.op(b"}").op(b"(");
    p.str("_shape").int(J as i32).int(V as i32).op(&[0x86]);
    p.str("data")
        .ndarray(&[J], "f8", &f8((0..J).map(|_| 1.0)), false, (1, chumpy));
    p.str("indices").ndarray(
        &[J],
        "i4",
        &(0..J as i32).flat_map(i32::to_le_bytes).collect::<Vec<_>>(),
        false,
        (3, true),
    );
    let indptr: Vec<i32> = (0..=V as i32).map(|c| c.min(J as i32)).collect();
    p.str("indptr").ndarray(
        &[V + 1],
        "i4",
        &indptr
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect::<Vec<_>>(),
        false,
        (3, false),
    );
    p.str("format").short_bytes(b"csc");
    p.op(b"u").op(b"b");
    let kintree: Vec<u8> = (0..2 * J)
        .flat_map(|k| {
            (if k == 0 {
                -1i64
            } else if k < J {
                (k - 1) as i64
            } else {
                (k - J) as i64
            })
            .to_le_bytes()
        })
        .collect();
    p.str("kintree_table")
        .ndarray(&[2, J], "i8", &kintree, false, (2, false));
    // Weights in Fortran order: element (v, j) at v + V·j; vertex v fully on joint v % J.
    p.str("weights").ndarray(
        &[V, J],
        "f8",
        &f8((0..V * J).map(|k| if k / V == (k % V) % J { 1.0 } else { 0.0 })),
        true,
        (1, false),
    );
    p.str("shapedirs").ndarray(
        &[V, 3, 10],
        "f4",
        &(0..V * 30)
            .flat_map(|k| (k as f32 * 1e-3).to_le_bytes())
            .collect::<Vec<_>>(),
        false,
        (4, true),
    );
    p.str("posedirs").ndarray(
        &[V, 3, 207],
        "f8",
        &f8((0..V * 3 * 207).map(|_| 0.0)),
        false,
        (1, false),
    );
    p.op(b"u").op(b".");
    p.0
}

#[test]
fn smpl_pickle_of_numpy_arrays_loads() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("model.pkl");
    std::fs::write(&path, smpl_pickle(false)).unwrap();
    let model = load_body_model(&path).unwrap();
    assert_eq!(model.kind, BodyKind::Smpl);
    assert_eq!(
        (
            model.vertex_count(),
            model.joint_count(),
            model.shape_count()
        ),
        (V, J, 10)
    );
    assert_eq!(model.template[7], 0.7);
    assert_eq!(model.parents[1], Some(0));
    // Dense regressor from CSC: joint 5 reads vertex 5 only.
    assert_eq!(model.joint_regressor[5 * V + 5], 1.0);
    assert_eq!(model.joint_regressor.iter().sum::<f32>(), J as f32);
    // Fortran weights back in C order: vertex 25 sits on joint 1.
    assert_eq!(model.skin_weights[25 * J + 1], 1.0);
    assert!((model.shape_dirs[31] - 0.031).abs() < 1e-6);
}

#[test]
fn chumpy_and_broken_pickles_get_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let chumpy = dir.path().join("basicModel_neutral.pkl");
    std::fs::write(&chumpy, smpl_pickle(true)).unwrap();
    let err = load_pkl(&chumpy).unwrap_err().to_string();
    assert!(
        err.contains("basicModel_neutral.pkl")
            && err.contains("v_template")
            && err.contains("chumpy")
            && err.contains("convert"),
        "{err}"
    );

    let truncated = dir.path().join("truncated.pkl");
    let bytes = smpl_pickle(false);
    std::fs::write(&truncated, &bytes[..bytes.len() / 3]).unwrap();
    let err = load_pkl(&truncated).unwrap_err().to_string();
    assert!(
        err.contains("truncated.pkl") && err.contains("truncated"),
        "{err}"
    );

    let other = dir.path().join("model.obj");
    std::fs::write(&other, b"v 0 0 0").unwrap();
    assert!(
        load_body_model(&other)
            .unwrap_err()
            .to_string()
            .contains(".npz or .pkl")
    );
}

/// The general reader on what [`Writer`] produces in the three forms data files use (checked
/// once against Python: `pickle.load`, `joblib.load` and `np.load(allow_pickle=True)` read these
/// bytes back to the same values, and this reader reads theirs).
#[test]
fn plain_joblib_and_npy_object_pickles_read_back() {
    use splatzoo_models::pickle::{Writer, load_npy_object, to_array, unpickle};
    for joblib in [false, true] {
        let mut w = Writer::new(joblib);
        w.begin_dict().int(1).begin_dict().str("pose").begin_list();
        w.array(&[2, 3], &[1.0, 2.0, 3.0, 4.0, 5.0, 6.5], false);
        w.array(&[1], &[7.25], true);
        w.end_list().str("x").float(2.5).end_dict().end_dict();
        let bytes = w.finish();
        let root = unpickle(&bytes).unwrap();
        let person = root
            .get("1")
            .expect("integer key found by its decimal text");
        let poses = person.get("pose").unwrap().items().unwrap();
        let a = to_array(poses[0]).unwrap();
        assert_eq!(
            (a.shape.clone(), a.values.clone()),
            (vec![2, 3], vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.5])
        );
        assert_eq!(to_array(poses[1]).unwrap().values, vec![7.25]);
        assert_eq!(person.get("x").unwrap().as_f64(), Some(2.5));
        // Cut inside the array data: an error, not a short array.
        let cut = &bytes[..bytes.len() - 12];
        assert!(unpickle(cut).is_err(), "joblib {joblib}");
    }
    let dir = tempfile::tempdir().unwrap();
    let mut w = Writer::new(false);
    w.begin_object_scalar()
        .begin_dict()
        .str("ims")
        .begin_list()
        .begin_dict()
        .str("ims")
        .begin_list()
        .str("Camera_B1/000000.jpg")
        .end_list()
        .end_dict()
        .end_list()
        .end_dict()
        .end_object_scalar();
    let path = dir.path().join("annots.npy");
    std::fs::write(
        &path,
        splatzoo_models::pickle::npy_object_bytes(&w.finish()),
    )
    .unwrap();
    let annots = load_npy_object(&path).unwrap();
    let first = annots.get("ims").unwrap().items().unwrap()[0]
        .get("ims")
        .unwrap()
        .items()
        .unwrap()[0]
        .as_str();
    assert_eq!(first.as_deref(), Some("Camera_B1/000000.jpg"));
}

/// Torch tensors as plain pickle / joblib write them (a legacy `torch.save` blob per storage),
/// for the three storage types drivestudio's `smpl.pkl` holds.
#[test]
fn torch_tensors_read_back() {
    use splatzoo_models::pickle::{Writer, to_array, unpickle};
    for (storage, values) in [
        ("FloatStorage", vec![1.5, -2.0, 3.25, 4.0, 5.0, 6.0]),
        ("LongStorage", vec![0.0, -1.0, 7.0, 3.0, 2.0, 1.0]),
        ("BoolStorage", vec![1.0, 0.0, 1.0, 1.0, 0.0, 0.0]),
    ] {
        let mut w = Writer::new(true);
        w.begin_dict()
            .str("t")
            .torch_tensor(&[2, 3], &values, storage)
            .end_dict();
        let root = unpickle(&w.finish()).unwrap();
        let a = to_array(root.get("t").unwrap()).unwrap_or_else(|e| panic!("{storage}: {e}"));
        assert_eq!((a.shape, a.values), (vec![2, 3], values), "{storage}");
    }
}

/// Lists of paths and numpy string arrays (`np.array(paths)`, `<U…`) read as the same strings;
/// numeric arrays are refused, not read as text.
#[test]
fn string_lists_and_numpy_string_arrays_read_alike() {
    use splatzoo_models::pickle::{Writer, to_strings, unpickle};
    let paths = ["Camera_B1/000000.jpg", "Camera_B12/000000.jpg", "é/1.jpg"];
    let mut w = Writer::new(false);
    w.begin_dict().str("list").begin_list();
    for p in paths {
        w.str(p);
    }
    w.end_list()
        .str("array")
        .string_array(&[3], &paths)
        .str("grid")
        .string_array(&[1, 3], &paths)
        .str("numbers")
        .array(&[2], &[1.0, 2.0], true)
        .end_dict();
    let root = unpickle(&w.finish()).unwrap();
    for key in ["list", "array", "grid"] {
        assert_eq!(to_strings(root.get(key).unwrap()).unwrap(), paths, "{key}");
    }
    let e = to_strings(root.get("numbers").unwrap()).unwrap_err();
    assert!(e.contains("numeric"), "{e}");
}
