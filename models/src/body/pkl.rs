//! SMPL-family models from a Python pickle (`.pkl`) holding plain numpy arrays, as released for
//! SMPL-H/SMPL-X and as `pickle.dump` of converted SMPL files. A small pickle reader (protocols
//! 2–5) rebuilds what such files contain: dicts, tuples, lists, scalars, strings, numpy arrays
//! (`numpy.core.multiarray._reconstruct` + state) and scipy sparse matrices (densified; SMPL's
//! `J_regressor` is one). The original SMPL release pickles `chumpy` objects, which cannot be
//! read without Python: that gets an error saying how to convert the file.

use super::model::{BodyModel, BodyModelError};
use super::npz::{Array, assemble, field_err, fortran_to_c};
use std::collections::HashMap;
use std::path::Path;
use std::rc::Rc;

/// What the reader rebuilds.
#[derive(Debug, Clone)]
enum Value {
    None,
    Bool(bool),
    Int(i64),
    /// A float (its value is never needed by the loader).
    Float,
    Str(String),
    Bytes(Vec<u8>),
    Tuple(Vec<Rc<Value>>),
    List(Vec<Rc<Value>>),
    Dict(Vec<(Rc<Value>, Rc<Value>)>),
    Global(String, String),
    /// A constructed object: its class (or callable), arguments, and `__setstate__` state.
    Object {
        class: Rc<Value>,
        args: Rc<Value>,
        state: Option<Rc<Value>>,
    },
    Mark,
}

struct Reader<'a> {
    data: &'a [u8],
    pos: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8], String> {
        let end = self.pos.checked_add(n).filter(|&e| e <= self.data.len());
        let end = end.ok_or_else(|| format!("truncated at byte {}", self.pos))?;
        let out = &self.data[self.pos..end];
        self.pos = end;
        Ok(out)
    }
    fn u8(&mut self) -> Result<u8, String> {
        Ok(self.take(1)?[0])
    }
    fn u32(&mut self) -> Result<u32, String> {
        Ok(u32::from_le_bytes(self.take(4)?.try_into().unwrap()))
    }
    fn u64(&mut self) -> Result<u64, String> {
        Ok(u64::from_le_bytes(self.take(8)?.try_into().unwrap()))
    }
    fn line(&mut self) -> Result<String, String> {
        let rest = &self.data[self.pos..];
        let n = rest
            .iter()
            .position(|&b| b == b'\n')
            .ok_or("unterminated line")?;
        let s = String::from_utf8_lossy(&rest[..n]).into_owned();
        self.pos += n + 1;
        Ok(s)
    }
}

fn pop(stack: &mut Vec<Rc<Value>>) -> Result<Rc<Value>, String> {
    stack.pop().ok_or_else(|| "stack underflow".to_owned())
}

fn pop_mark(stack: &mut Vec<Rc<Value>>) -> Result<Vec<Rc<Value>>, String> {
    let at = stack
        .iter()
        .rposition(|v| matches!(**v, Value::Mark))
        .ok_or("MARK missing")?;
    let items = stack.split_off(at + 1);
    stack.pop();
    Ok(items)
}

fn add_to(target: Rc<Value>, items: Vec<Rc<Value>>) -> Result<Rc<Value>, String> {
    let mut v = Rc::unwrap_or_clone(target);
    match &mut v {
        Value::List(list) => list.extend(items),
        Value::Dict(dict) => {
            if !items.len().is_multiple_of(2) {
                return Err("odd number of dict items".into());
            }
            let mut it = items.into_iter();
            while let (Some(k), Some(x)) = (it.next(), it.next()) {
                dict.push((k, x));
            }
        }
        _ => return Err("items added to a value that is neither list nor dict".into()),
    }
    Ok(Rc::new(v))
}

/// Runs the pickle program and returns its result.
fn unpickle(data: &[u8]) -> Result<Rc<Value>, String> {
    let mut r = Reader { data, pos: 0 };
    let mut stack: Vec<Rc<Value>> = Vec::new();
    let mut memo: HashMap<u32, Rc<Value>> = HashMap::new();
    loop {
        let op = r.u8()?;
        match op {
            0x80 => {
                r.u8()?; // PROTO
            }
            0x95 => {
                r.u64()?; // FRAME
            }
            b'.' => return pop(&mut stack),
            b'(' => stack.push(Rc::new(Value::Mark)),
            b'}' => stack.push(Rc::new(Value::Dict(Vec::new()))),
            b']' => stack.push(Rc::new(Value::List(Vec::new()))),
            b')' => stack.push(Rc::new(Value::Tuple(Vec::new()))),
            b't' => {
                let items = pop_mark(&mut stack)?;
                stack.push(Rc::new(Value::Tuple(items)));
            }
            b'l' => {
                let items = pop_mark(&mut stack)?;
                stack.push(Rc::new(Value::List(items)));
            }
            b'd' => {
                let items = pop_mark(&mut stack)?;
                stack.push(add_to(Rc::new(Value::Dict(Vec::new())), items)?);
            }
            0x85..=0x87 => {
                let n = (op - 0x84) as usize;
                if stack.len() < n {
                    return Err("stack underflow".into());
                }
                let items = stack.split_off(stack.len() - n);
                stack.push(Rc::new(Value::Tuple(items)));
            }
            b'N' => stack.push(Rc::new(Value::None)),
            0x88 => stack.push(Rc::new(Value::Bool(true))),
            0x89 => stack.push(Rc::new(Value::Bool(false))),
            b'J' => stack.push(Rc::new(Value::Int(r.u32()? as i32 as i64))),
            b'K' => stack.push(Rc::new(Value::Int(r.u8()? as i64))),
            b'M' => {
                let b = r.take(2)?;
                stack.push(Rc::new(Value::Int(u16::from_le_bytes([b[0], b[1]]) as i64)));
            }
            0x8a => {
                let n = r.u8()? as usize;
                let bytes = r.take(n)?;
                if n > 8 {
                    return Err("integer wider than 64 bits".into());
                }
                let mut v: i64 = 0;
                for (i, b) in bytes.iter().enumerate() {
                    v |= (*b as i64) << (8 * i);
                }
                if n > 0 && n < 8 && bytes[n - 1] & 0x80 != 0 {
                    v -= 1i64 << (8 * n);
                }
                stack.push(Rc::new(Value::Int(v)));
            }
            b'I' => {
                let line = r.line()?;
                let v = match line.as_str() {
                    "01" => Value::Bool(true),
                    "00" => Value::Bool(false),
                    s => Value::Int(s.trim().parse().map_err(|_| format!("bad INT {s}"))?),
                };
                stack.push(Rc::new(v));
            }
            b'G' => {
                r.take(8)?;
                stack.push(Rc::new(Value::Float));
            }
            b'F' => {
                r.line()?;
                stack.push(Rc::new(Value::Float));
            }
            b'U' | b'T' | b'C' | b'B' | 0x8e | 0x96 => {
                let n = match op {
                    b'U' | b'C' => r.u8()? as usize,
                    b'T' | b'B' => r.u32()? as usize,
                    _ => r.u64()? as usize,
                };
                stack.push(Rc::new(Value::Bytes(r.take(n)?.to_vec())));
            }
            b'X' | 0x8c | 0x8d => {
                let n = match op {
                    0x8c => r.u8()? as usize,
                    b'X' => r.u32()? as usize,
                    _ => r.u64()? as usize,
                };
                let s = String::from_utf8_lossy(r.take(n)?).into_owned();
                stack.push(Rc::new(Value::Str(s)));
            }
            b'c' => {
                let module = r.line()?;
                let name = r.line()?;
                stack.push(Rc::new(Value::Global(module, name)));
            }
            0x93 => {
                let name = pop(&mut stack)?;
                let module = pop(&mut stack)?;
                match (&*module, &*name) {
                    (Value::Str(m), Value::Str(n)) => {
                        stack.push(Rc::new(Value::Global(m.clone(), n.clone())))
                    }
                    _ => return Err("STACK_GLOBAL needs two strings".into()),
                }
            }
            b'R' | 0x81 => {
                let args = pop(&mut stack)?;
                let class = pop(&mut stack)?;
                stack.push(Rc::new(Value::Object {
                    class,
                    args,
                    state: None,
                }));
            }
            b'b' => {
                let state = pop(&mut stack)?;
                let target = pop(&mut stack)?;
                let built = match Rc::unwrap_or_clone(target) {
                    Value::Object { class, args, .. } => Value::Object {
                        class,
                        args,
                        state: Some(state),
                    },
                    other => return Err(format!("BUILD on {other:?}")),
                };
                stack.push(Rc::new(built));
            }
            b's' => {
                let value = pop(&mut stack)?;
                let key = pop(&mut stack)?;
                let dict = pop(&mut stack)?;
                stack.push(add_to(dict, vec![key, value])?);
            }
            b'u' | b'e' => {
                let items = pop_mark(&mut stack)?;
                let target = pop(&mut stack)?;
                stack.push(add_to(target, items)?);
            }
            b'a' => {
                let item = pop(&mut stack)?;
                let list = pop(&mut stack)?;
                stack.push(add_to(list, vec![item])?);
            }
            b'q' | b'r' | 0x94 => {
                let key = match op {
                    b'q' => r.u8()? as u32,
                    b'r' => r.u32()?,
                    _ => memo.len() as u32,
                };
                let top = stack.last().ok_or("memoize on empty stack")?.clone();
                memo.insert(key, top);
            }
            b'h' | b'j' => {
                let key = if op == b'h' { r.u8()? as u32 } else { r.u32()? };
                stack.push(
                    memo.get(&key)
                        .ok_or_else(|| format!("memo {key} missing"))?
                        .clone(),
                );
            }
            b'0' => {
                pop(&mut stack)?;
            }
            b'1' => {
                pop_mark(&mut stack)?;
            }
            b'2' => {
                let top = stack.last().ok_or("DUP on empty stack")?.clone();
                stack.push(top);
            }
            other => {
                return Err(format!(
                    "unsupported pickle opcode 0x{other:02x} at byte {}",
                    r.pos - 1
                ));
            }
        }
    }
}

fn global_name(v: &Value) -> Option<String> {
    match v {
        Value::Global(m, n) => Some(format!("{m}.{n}")),
        Value::Object { class, .. } => global_name(class),
        _ => None,
    }
}

/// The class of an object built by `copyreg._reconstructor(cls, base, state)` or `cls(...)`.
fn class_of(v: &Value) -> Option<String> {
    let Value::Object { class, args, .. } = v else {
        return None;
    };
    let constructor = global_name(class);
    let via_copyreg = matches!(
        constructor.as_deref(),
        Some("copy_reg._reconstructor" | "copyreg._reconstructor")
    );
    if via_copyreg && let Value::Tuple(a) = &**args {
        return a.first().and_then(|c| global_name(c));
    }
    constructor
}

fn dict_get<'v>(items: &'v [(Rc<Value>, Rc<Value>)], key: &str) -> Option<&'v Rc<Value>> {
    items.iter().find_map(|(k, v)| match &**k {
        Value::Str(s) if s == key => Some(v),
        Value::Bytes(b) if b == key.as_bytes() => Some(v),
        _ => None,
    })
}

fn as_usize_tuple(v: &Value) -> Option<Vec<usize>> {
    match v {
        Value::Tuple(items) | Value::List(items) => items
            .iter()
            .map(|x| match **x {
                Value::Int(i) if i >= 0 => Some(i as usize),
                _ => None,
            })
            .collect(),
        _ => None,
    }
}

/// Decodes a numpy dtype object to (kind, item size, little-endian).
fn dtype_of(v: &Value) -> Result<(char, usize, bool), String> {
    let Value::Object { args, state, .. } = v else {
        return Err("array dtype is not a numpy dtype".into());
    };
    let Value::Tuple(a) = &**args else {
        return Err("malformed dtype".into());
    };
    let code = match a.first().map(|x| &**x) {
        Some(Value::Str(s)) => s.clone(),
        Some(Value::Bytes(b)) => String::from_utf8_lossy(b).into_owned(),
        _ => return Err("malformed dtype".into()),
    };
    let little = match state.as_deref() {
        Some(Value::Tuple(s)) => !matches!(s.get(1).map(|x| &**x), Some(Value::Str(e)) if e == ">"),
        _ => true,
    };
    let kind = code.chars().next().ok_or("empty dtype")?;
    let size: usize = code[1..]
        .parse()
        .map_err(|_| format!("unsupported dtype {code}"))?;
    Ok((kind, size, little))
}

fn decode(raw: &[u8], kind: char, size: usize, little: bool) -> Result<Vec<f64>, String> {
    let word = |c: &[u8]| -> [u8; 8] {
        let mut w = [0u8; 8];
        if little {
            w[..size].copy_from_slice(c);
        } else {
            for (i, b) in c.iter().rev().enumerate() {
                w[i] = *b;
            }
        }
        w
    };
    let chunks = raw.chunks_exact(size);
    Ok(match (kind, size) {
        ('f', 8) => chunks.map(|c| f64::from_le_bytes(word(c))).collect(),
        ('f', 4) => chunks
            .map(|c| f32::from_le_bytes(word(c)[..4].try_into().unwrap()) as f64)
            .collect(),
        ('i', 8) => chunks.map(|c| i64::from_le_bytes(word(c)) as f64).collect(),
        ('i', 4) => chunks
            .map(|c| i32::from_le_bytes(word(c)[..4].try_into().unwrap()) as f64)
            .collect(),
        ('u', 8) => chunks.map(|c| u64::from_le_bytes(word(c)) as f64).collect(),
        ('u', 4) => chunks
            .map(|c| u32::from_le_bytes(word(c)[..4].try_into().unwrap()) as f64)
            .collect(),
        ('u', 1) | ('b', 1) => raw.iter().map(|&b| b as f64).collect(),
        _ => return Err(format!("unsupported dtype {kind}{size}")),
    })
}

/// A numpy array or scipy sparse matrix as a dense C-order array.
fn to_array(v: &Value) -> Result<Array, String> {
    let class = class_of(v).unwrap_or_default();
    if class.starts_with("chumpy") {
        return Err(format!("is a chumpy object ({class})"));
    }
    let Value::Object {
        state: Some(state), ..
    } = v
    else {
        return Err(format!("is not an array ({class})"));
    };
    if class.ends_with("_reconstruct") {
        // ndarray state: (version, shape, dtype, is_fortran, raw data).
        let Value::Tuple(s) = &**state else {
            return Err("malformed ndarray state".into());
        };
        let shape =
            as_usize_tuple(s.get(1).ok_or("ndarray state without shape")?).ok_or("bad shape")?;
        let (kind, size, little) = dtype_of(s.get(2).ok_or("ndarray state without dtype")?)?;
        let fortran = matches!(s.get(3).map(|x| &**x), Some(Value::Bool(true)));
        let raw: Vec<u8> = match s.get(4).map(|x| &**x) {
            Some(Value::Bytes(b)) => b.clone(),
            // Python 2 `str` read as text: code points are the bytes (latin-1).
            Some(Value::Str(t)) => t.chars().map(|c| c as u32 as u8).collect(),
            _ => return Err("object arrays are not supported".into()),
        };
        let values = decode(&raw, kind, size, little)?;
        let count: usize = shape.iter().product();
        if values.len() != count {
            return Err(format!("holds {} values for shape {shape:?}", values.len()));
        }
        let values = if fortran && shape.len() > 1 {
            fortran_to_c(values, &shape)
        } else {
            values
        };
        return Ok(Array { shape, values });
    }
    if let Value::Dict(items) = &**state
        && let (Some(data), Some(indices), Some(indptr), Some(shape)) = (
            dict_get(items, "data"),
            dict_get(items, "indices"),
            dict_get(items, "indptr"),
            dict_get(items, "_shape"),
        )
    {
        // scipy CSC/CSR matrix.
        let shape = as_usize_tuple(shape).ok_or("bad sparse shape")?;
        let (data, indices, indptr) = (
            to_array(data)?.values,
            to_array(indices)?.values,
            to_array(indptr)?.values,
        );
        let csc = class.contains("csc")
            || matches!(dict_get(items, "format").map(|f| &**f), Some(Value::Str(f)) if f == "csc");
        let (rows, cols) = (shape[0], shape[1]);
        let mut dense = vec![0.0; rows * cols];
        for outer in 0..indptr.len().saturating_sub(1) {
            for k in indptr[outer] as usize..indptr[outer + 1] as usize {
                let inner = indices[k] as usize;
                let (r, c) = if csc { (inner, outer) } else { (outer, inner) };
                if r >= rows || c >= cols {
                    return Err("sparse index out of range".into());
                }
                dense[r * cols + c] += data[k];
            }
        }
        return Ok(Array {
            shape: vec![rows, cols],
            values: dense,
        });
    }
    Err(format!("is not an array ({class})"))
}

/// Loads an SMPL-family model from a `.pkl` of numpy arrays (keys as in [`super::load_npz`]).
pub fn load_pkl(path: &Path) -> Result<BodyModel, BodyModelError> {
    let file = path.display().to_string();
    let data = std::fs::read(path).map_err(|e| BodyModelError::File {
        file: file.clone(),
        problem: format!("cannot read ({e})"),
    })?;
    let root = unpickle(&data).map_err(|problem| BodyModelError::File {
        file: file.clone(),
        problem: format!("not a readable pickle: {problem}"),
    })?;
    let Value::Dict(items) = &*root else {
        return Err(BodyModelError::File {
            file,
            problem: "the pickle does not hold a dict of arrays".into(),
        });
    };
    let mut fetch = |key: &str| -> Result<Option<Array>, BodyModelError> {
        let Some(v) = dict_get(items, key) else {
            return Ok(None);
        };
        to_array(v).map(Some).map_err(|problem| {
            let hint = if problem.contains("chumpy") {
                ". This is the original chumpy pickle: convert it once with Python (see the README, \
                 'Body models') to .npz or a pickle of plain numpy arrays"
            } else {
                ""
            };
            field_err(&file, key, format!("{problem}{hint}"))
        })
    };
    assemble(&file, &mut fetch)
}
