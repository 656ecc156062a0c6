//! Sparse points from a PLY file: the initialisation point clouds nerfstudio names in
//! `ply_file_path` (`ns-process-data` writes `sparse_pc.ply` from COLMAP's points, as ASCII;
//! Open3D writes binary), read as [`SparsePoint`]s.
//!
//! Read: the header (`ply`, `format ascii 1.0` | `binary_little_endian 1.0` |
//! `binary_big_endian 1.0`, `comment` / `obj_info` lines, `element <name> <count>`,
//! `property <type> <name>` and `property list <count type> <item type> <name>`, with PLY's
//! types `char uchar short ushort int uint float double` and their `int8 … float64` aliases),
//! then the rows of the elements before `vertex` (skipped), then the `vertex` rows; what follows
//! (faces, …) is not read. A vertex needs scalar `x y z` (any type); `red green blue` are its
//! colour where all three are there (`uchar` / `ushort` scaled to [0, 1], `float` / `double`
//! taken as they are), mid grey (0.5) otherwise. A list property in `vertex` is refused.
//!
//! Errors name the file and the problem: a missing property, a header line not understood, a
//! row cut short. A binary file's row count is checked against the bytes left before anything
//! is allocated for it.

use crate::DatasetError;
use crate::formats::SparsePoint;
use std::path::Path;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Encoding {
    Ascii,
    LittleEndian,
    BigEndian,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(name: &str) -> Option<Self> {
        Some(match name {
            "char" | "int8" => Self::I8,
            "uchar" | "uint8" => Self::U8,
            "short" | "int16" => Self::I16,
            "ushort" | "uint16" => Self::U16,
            "int" | "int32" => Self::I32,
            "uint" | "uint32" => Self::U32,
            "float" | "float32" => Self::F32,
            "double" | "float64" => Self::F64,
            _ => return None,
        })
    }

    fn name(self) -> &'static str {
        match self {
            Self::I8 => "char",
            Self::U8 => "uchar",
            Self::I16 => "short",
            Self::U16 => "ushort",
            Self::I32 => "int",
            Self::U32 => "uint",
            Self::F32 => "float",
            Self::F64 => "double",
        }
    }

    fn size(self) -> usize {
        match self {
            Self::I8 | Self::U8 => 1,
            Self::I16 | Self::U16 => 2,
            Self::I32 | Self::U32 | Self::F32 => 4,
            Self::F64 => 8,
        }
    }

    /// The value of `b` (exactly [`Self::size`] bytes).
    fn decode(self, b: &[u8], encoding: Encoding) -> f64 {
        fn bytes<const N: usize>(b: &[u8], encoding: Encoding) -> [u8; N] {
            let mut a = [0u8; N];
            a.copy_from_slice(&b[..N]);
            if encoding == Encoding::BigEndian {
                a.reverse();
            }
            a
        }
        match self {
            Self::I8 => f64::from(b[0] as i8),
            Self::U8 => f64::from(b[0]),
            Self::I16 => f64::from(i16::from_le_bytes(bytes(b, encoding))),
            Self::U16 => f64::from(u16::from_le_bytes(bytes(b, encoding))),
            Self::I32 => f64::from(i32::from_le_bytes(bytes(b, encoding))),
            Self::U32 => f64::from(u32::from_le_bytes(bytes(b, encoding))),
            Self::F32 => f64::from(f32::from_le_bytes(bytes(b, encoding))),
            Self::F64 => f64::from_le_bytes(bytes(b, encoding)),
        }
    }
}

#[derive(Debug, Clone)]
enum Property {
    Scalar(String, Scalar),
    /// Name, count type, item type.
    List(String, Scalar, Scalar),
}

#[derive(Debug, Clone)]
struct Element {
    name: String,
    count: u64,
    properties: Vec<Property>,
}

/// The header: encoding, elements, and where the body starts.
fn parse_header(
    path: &Path,
    bytes: &[u8],
) -> Result<(Encoding, Vec<Element>, usize), DatasetError> {
    let bad = |line: usize, problem: String| {
        DatasetError::file(path, format!("header line {line}: {problem}"))
    };
    if !(bytes.starts_with(b"ply\n") || bytes.starts_with(b"ply\r\n")) {
        return Err(DatasetError::file(
            path,
            "not a PLY file (expected `ply` on the first line)",
        ));
    }
    let mut encoding = None;
    let mut elements: Vec<Element> = Vec::new();
    let mut pos = 0;
    let mut line_number = 0;
    loop {
        line_number += 1;
        let Some(end) = bytes[pos..].iter().position(|&b| b == b'\n') else {
            return Err(DatasetError::file(
                path,
                "no `end_header` line (truncated header?)",
            ));
        };
        let raw = &bytes[pos..pos + end];
        pos += end + 1;
        let line = std::str::from_utf8(raw)
            .map_err(|_| bad(line_number, "not ASCII text".into()))?
            .trim();
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.as_slice() {
            ["ply"] if line_number == 1 => {}
            ["comment", ..] | ["obj_info", ..] | [] => {}
            ["format", name, "1.0"] => {
                encoding = Some(match *name {
                    "ascii" => Encoding::Ascii,
                    "binary_little_endian" => Encoding::LittleEndian,
                    "binary_big_endian" => Encoding::BigEndian,
                    other => return Err(bad(line_number, format!("unknown format `{other}`"))),
                });
            }
            ["element", name, count] => {
                let count = count.parse::<u64>().map_err(|_| {
                    bad(
                        line_number,
                        format!("element `{name}` count `{count}` is not a count"),
                    )
                })?;
                elements.push(Element {
                    name: (*name).to_owned(),
                    count,
                    properties: Vec::new(),
                });
            }
            ["property", rest @ ..] => {
                let element = elements
                    .last_mut()
                    .ok_or_else(|| bad(line_number, "a property before any `element`".into()))?;
                let scalar = |name: &str| {
                    Scalar::parse(name)
                        .ok_or_else(|| bad(line_number, format!("unknown property type `{name}`")))
                };
                let property = match rest {
                    ["list", count, item, name] => {
                        Property::List((*name).to_owned(), scalar(count)?, scalar(item)?)
                    }
                    [ty, name] => Property::Scalar((*name).to_owned(), scalar(ty)?),
                    _ => {
                        return Err(bad(
                            line_number,
                            format!("expected `property <type> <name>`, found `{line}`"),
                        ));
                    }
                };
                element.properties.push(property);
            }
            ["end_header"] => break,
            _ => return Err(bad(line_number, format!("not understood: `{line}`"))),
        }
    }
    let encoding =
        encoding.ok_or_else(|| DatasetError::file(path, "no `format` line in the header"))?;
    Ok((encoding, elements, pos))
}

/// The body's values in row order, from ASCII tokens or binary bytes.
enum Body<'a> {
    Ascii(std::str::SplitAsciiWhitespace<'a>),
    Binary {
        bytes: &'a [u8],
        pos: usize,
        encoding: Encoding,
    },
}

impl Body<'_> {
    /// The next value of type `ty`, or `None` at the end of the data.
    fn next(&mut self, ty: Scalar) -> Result<Option<f64>, String> {
        match self {
            Body::Ascii(tokens) => match tokens.next() {
                None => Ok(None),
                Some(t) => t
                    .parse::<f64>()
                    .map(Some)
                    .map_err(|_| format!("`{t}` is not a number")),
            },
            Body::Binary {
                bytes,
                pos,
                encoding,
            } => {
                let size = ty.size();
                if bytes.len() - *pos < size {
                    return Ok(None);
                }
                let v = ty.decode(&bytes[*pos..*pos + size], *encoding);
                *pos += size;
                Ok(Some(v))
            }
        }
    }

    /// Bytes left in a binary body (`None` for ASCII).
    fn bytes_left(&self) -> Option<usize> {
        match self {
            Body::Ascii(_) => None,
            Body::Binary { bytes, pos, .. } => Some(bytes.len() - *pos),
        }
    }
}

/// Reads the vertices of the PLY at `path` as (position, colour in [0, 1]).
pub fn read_points(path: &Path) -> Result<Vec<SparsePoint>, DatasetError> {
    let bytes =
        std::fs::read(path).map_err(|e| DatasetError::file(path, format!("cannot read ({e})")))?;
    let (encoding, elements, start) = parse_header(path, &bytes)?;
    let vertex_at = elements
        .iter()
        .position(|e| e.name == "vertex")
        .ok_or_else(|| DatasetError::file(path, "no `element vertex` in the header"))?;
    let vertex = &elements[vertex_at];
    let mut types = Vec::with_capacity(vertex.properties.len());
    let mut names = Vec::with_capacity(vertex.properties.len());
    for property in &vertex.properties {
        match property {
            Property::Scalar(name, ty) => {
                names.push(name.as_str());
                types.push(*ty);
            }
            Property::List(name, ..) => {
                return Err(DatasetError::field(
                    path,
                    &format!("vertex.{name}"),
                    "a list property: expected scalar vertex properties",
                ));
            }
        }
    }
    let index = |name: &str| names.iter().position(|n| *n == name);
    let mut position = [0usize; 3];
    for (slot, axis) in position.iter_mut().zip(["x", "y", "z"]) {
        *slot = index(axis).ok_or_else(|| {
            DatasetError::field(
                path,
                &format!("vertex.{axis}"),
                format!("missing: expected `property float {axis}` (or any scalar type)"),
            )
        })?;
    }
    // Where the colour channels are, and what each is divided by.
    let colour = match (index("red"), index("green"), index("blue")) {
        (Some(r), Some(g), Some(b)) => {
            let mut divisors = [1.0; 3];
            let channels = [(r, "red"), (g, "green"), (b, "blue")];
            for (divisor, (i, name)) in divisors.iter_mut().zip(channels) {
                *divisor = match types[i] {
                    Scalar::U8 => 255.0,
                    Scalar::U16 => 65535.0,
                    Scalar::F32 | Scalar::F64 => 1.0,
                    other => {
                        return Err(DatasetError::field(
                            path,
                            &format!("vertex.{name}"),
                            format!(
                                "type {}: expected uchar, ushort, float or double",
                                other.name()
                            ),
                        ));
                    }
                };
            }
            Some(([r, g, b], divisors))
        }
        _ => None,
    };

    let mut body = match encoding {
        Encoding::Ascii => Body::Ascii(
            std::str::from_utf8(&bytes[start..])
                .map_err(|_| DatasetError::file(path, "ASCII PLY body is not text"))?
                .split_ascii_whitespace(),
        ),
        _ => Body::Binary {
            bytes: &bytes[start..],
            pos: 0,
            encoding,
        },
    };
    let truncated = |element: &str, row: u64| {
        DatasetError::file(path, format!("truncated in element `{element}` row {row}"))
    };
    let not_number = |element: &str, row: u64, p: String| {
        DatasetError::file(path, format!("element `{element}` row {row}: {p}"))
    };
    // Elements before `vertex`: skipped row by row (a list's length read from its count).
    for element in &elements[..vertex_at] {
        let name = element.name.as_str();
        if element.properties.is_empty() {
            continue;
        }
        for row in 0..element.count {
            for property in &element.properties {
                let (count, item) = match property {
                    Property::Scalar(_, ty) => (1.0, *ty),
                    Property::List(_, count_ty, item) => {
                        let n = body
                            .next(*count_ty)
                            .map_err(|p| not_number(name, row, p))?
                            .ok_or_else(|| truncated(name, row))?;
                        (n, *item)
                    }
                };
                if count < 0.0 || count.fract() != 0.0 {
                    return Err(not_number(name, row, format!("list length {count}")));
                }
                for _ in 0..count as u64 {
                    body.next(item)
                        .map_err(|p| not_number(name, row, p))?
                        .ok_or_else(|| truncated(name, row))?;
                }
            }
        }
    }
    let row_size: usize = types.iter().map(|t| t.size()).sum();
    let capacity = match body.bytes_left() {
        Some(left) => {
            let needed = u128::from(vertex.count) * row_size as u128;
            if needed > left as u128 {
                return Err(DatasetError::file(
                    path,
                    format!(
                        "truncated: {} vertices of {row_size} bytes need {needed} bytes, \
                         {left} remain",
                        vertex.count
                    ),
                ));
            }
            vertex.count as usize
        }
        // At least two characters a value.
        None => (vertex.count as usize).min((bytes.len() - start) / (2 * types.len()).max(1)),
    };
    let mut points = Vec::with_capacity(capacity);
    let mut row_values = vec![0.0; types.len()];
    for row in 0..vertex.count {
        for (value, ty) in row_values.iter_mut().zip(&types) {
            *value = body
                .next(*ty)
                .map_err(|p| not_number("vertex", row, p))?
                .ok_or_else(|| truncated("vertex", row))?;
        }
        let x = position.map(|i| row_values[i]);
        if x.iter().any(|v| !v.is_finite()) {
            return Err(not_number(
                "vertex",
                row,
                format!("position {x:?} is not finite"),
            ));
        }
        let rgb: [f32; 3] = match &colour {
            Some((at, divisors)) => {
                std::array::from_fn(|c| (row_values[at[c]] / divisors[c]) as f32)
            }
            None => [0.5; 3],
        };
        points.push((x, rgb));
    }
    Ok(points)
}
