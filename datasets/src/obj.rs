//! Wavefront OBJ output: positions, optional per-corner texture coordinates, triangles.

use crate::DatasetError;
use crate::files::write_bytes;
use std::fmt::Write;
use std::path::Path;

/// Texture coordinates for an OBJ: `[T, 2]` and `[F, 3]` corner indices.
pub struct ObjUv<'a> {
    pub coords: &'a [[f32; 2]],
    pub corners: &'a [[u32; 3]],
}

/// The OBJ text of a triangle mesh.
pub fn obj_text(positions: &[[f32; 3]], faces: &[[u32; 3]], uv: Option<&ObjUv>) -> String {
    let mut s = String::with_capacity(positions.len() * 40 + faces.len() * 30);
    s.push_str("# written by splatzoo\n");
    for p in positions {
        let _ = writeln!(s, "v {} {} {}", p[0], p[1], p[2]);
    }
    if let Some(uv) = uv {
        for t in uv.coords {
            let _ = writeln!(s, "vt {} {}", t[0], t[1]);
        }
    }
    for (i, f) in faces.iter().enumerate() {
        match uv {
            Some(uv) => {
                let t = uv.corners[i];
                let _ = writeln!(
                    s,
                    "f {}/{} {}/{} {}/{}",
                    f[0] + 1,
                    t[0] + 1,
                    f[1] + 1,
                    t[1] + 1,
                    f[2] + 1,
                    t[2] + 1
                );
            }
            None => {
                let _ = writeln!(s, "f {} {} {}", f[0] + 1, f[1] + 1, f[2] + 1);
            }
        }
    }
    s
}

/// Writes a triangle mesh as OBJ, atomically.
pub fn write_obj(
    path: &Path,
    positions: &[[f32; 3]],
    faces: &[[u32; 3]],
    uv: Option<&ObjUv>,
) -> Result<(), DatasetError> {
    write_bytes(path, obj_text(positions, faces, uv).as_bytes())
}
