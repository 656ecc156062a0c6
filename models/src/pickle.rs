//! A small Python pickle reader (protocols 2–5) for what scientific data files hold: dicts,
//! tuples, lists, scalars, strings, numpy arrays (`numpy.core.multiarray._reconstruct` + state),
//! numpy string arrays ([`to_strings`]), scipy sparse matrices (densified), numpy object arrays
//! saved with `np.save(allow_pickle)` (`.npy` files holding a dict, as ZJU-MoCap's `annots.npy`
//! and NeuMan's `alignments.npy` do), and joblib dumps (NeuMan's `smpl_output_*.pkl`), whose
//! arrays are raw bytes placed after each `NumpyArrayWrapper` rather than pickle opcodes. Nothing
//! is executed: classes are only recognised by name. [`Writer`] writes the same subset, for test
//! fixtures and interop.

use crate::body::npz::{Array, fortran_to_c};
use std::collections::HashMap;
use std::path::Path;
use std::rc::Rc;

const JOBLIB_WRAPPER: &str = "joblib.numpy_pickle.NumpyArrayWrapper";

/// What the reader rebuilds.
#[derive(Debug, Clone)]
pub enum Value {
    None,
    Bool(bool),
    Int(i64),
    Float(f64),
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
    /// A numpy array read by [`to_array`] out of a joblib stream (joblib writes array bytes
    /// outside the pickle opcodes).
    Array(Array),
    /// An integer wider than 64 bits (its little-endian bytes; e.g. torch's magic number).
    BigInt(Vec<u8>),
    /// A persistent id (`BINPERSID`): what torch's legacy format uses for storages.
    Persistent(Rc<Value>),
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

/// Runs the pickle program in `data` and returns its result (errors say what and where).
pub fn unpickle(data: &[u8]) -> Result<Rc<Value>, String> {
    run(&mut Reader { data, pos: 0 })
}

/// Runs one pickle program from `r`'s position to its STOP.
fn run(r: &mut Reader) -> Result<Rc<Value>, String> {
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
                    stack.push(Rc::new(Value::BigInt(bytes.to_vec())));
                    continue;
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
                let b = r.take(8)?;
                let v = f64::from_be_bytes(b.try_into().expect("8 bytes"));
                stack.push(Rc::new(Value::Float(v)));
            }
            b'F' => {
                let line = r.line()?;
                let v = line
                    .trim()
                    .parse()
                    .map_err(|_| format!("bad FLOAT {line}"))?;
                stack.push(Rc::new(Value::Float(v)));
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
                let built = if class_of(&built).as_deref() == Some(JOBLIB_WRAPPER) {
                    Value::Array(read_joblib_array(&built, r)?)
                } else {
                    built
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
            b'Q' => {
                let id = pop(&mut stack)?;
                stack.push(Rc::new(Value::Persistent(id)));
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

pub(crate) fn dict_get<'v>(
    items: &'v [(Rc<Value>, Rc<Value>)],
    key: &str,
) -> Option<&'v Rc<Value>> {
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

/// A numpy array (pickled, or read from a joblib stream) or a scipy sparse matrix as a dense
/// C-order array.
pub fn to_array(v: &Value) -> Result<Array, String> {
    if let Value::Array(a) = v {
        return Ok(a.clone());
    }
    let class = class_of(v).unwrap_or_default();
    if class.ends_with("multiarray.scalar")
        && let Value::Object { args, .. } = v
        && let Value::Tuple(a) = &**args
        && let (Some(dtype), Some(raw)) = (a.first(), a.get(1))
    {
        // A numpy scalar: scalar(dtype, raw bytes).
        let (kind, size, little) = dtype_of(dtype)?;
        let raw: Vec<u8> = match &**raw {
            Value::Bytes(b) => b.clone(),
            Value::Str(t) => t.chars().map(|c| c as u32 as u8).collect(),
            _ => return Err("malformed numpy scalar".into()),
        };
        let values = decode(&raw, kind, size, little)?;
        return Ok(Array {
            shape: Vec::new(),
            values,
        });
    }
    if class == "torch._utils._rebuild_tensor_v2" {
        return torch_tensor(v);
    }
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

/// The strings of a list or tuple of `str`, or of a numpy array of strings in C order, whatever
/// its shape: fixed-width unicode (`<U…`: UTF-32 code points, NUL-padded to the width), bytes
/// (`|S…`, NUL-padded) or objects holding `str`. `np.array(paths)` of Python strings pickles as
/// the first, so a data file may hold either a list or such an array where it means a list of
/// paths (ZJU-MoCap's `annots.npy` does both).
pub fn to_strings(v: &Value) -> Result<Vec<String>, String> {
    if let Some(items) = v.items() {
        return items
            .iter()
            .enumerate()
            .map(|(i, item)| {
                item.as_str()
                    .ok_or_else(|| format!("item {i} is not a string"))
            })
            .collect();
    }
    let class = class_of(v).unwrap_or_default();
    let state = match v {
        Value::Object {
            state: Some(state), ..
        } if class.ends_with("_reconstruct") => state,
        _ => return Err(format!("is neither a list nor a numpy array ({class})")),
    };
    let Value::Tuple(s) = &**state else {
        return Err("malformed ndarray state".into());
    };
    let shape =
        as_usize_tuple(s.get(1).ok_or("ndarray state without shape")?).ok_or("bad shape")?;
    let (kind, size, little) = dtype_of(s.get(2).ok_or("ndarray state without dtype")?)?;
    let fortran = matches!(s.get(3).map(|x| &**x), Some(Value::Bool(true)));
    let count: usize = shape.iter().product();
    let raw = || -> Result<Vec<u8>, String> {
        match s.get(4).map(|x| &**x) {
            Some(Value::Bytes(b)) => Ok(b.clone()),
            // Python 2 `str` read as text: code points are the bytes (latin-1).
            Some(Value::Str(t)) => Ok(t.chars().map(|c| c as u32 as u8).collect()),
            _ => Err("malformed string array data".into()),
        }
    };
    let strings: Vec<String> = match kind {
        'U' => {
            let raw = raw()?;
            if raw.len() != count * size * 4 {
                return Err(format!(
                    "holds {} bytes for {count} strings of {size} characters",
                    raw.len()
                ));
            }
            raw.chunks_exact(4 * size.max(1))
                .take(count)
                .map(|item| {
                    item.chunks_exact(4)
                        .map(|c| {
                            let b = [c[0], c[1], c[2], c[3]];
                            if little {
                                u32::from_le_bytes(b)
                            } else {
                                u32::from_be_bytes(b)
                            }
                        })
                        .take_while(|&c| c != 0)
                        .map(|c| char::from_u32(c).unwrap_or(char::REPLACEMENT_CHARACTER))
                        .collect::<String>()
                })
                .collect()
        }
        'S' => {
            let raw = raw()?;
            if raw.len() != count * size {
                return Err(format!(
                    "holds {} bytes for {count} strings of {size} bytes",
                    raw.len()
                ));
            }
            raw.chunks_exact(size.max(1))
                .take(count)
                .map(|item| {
                    let end = item.iter().position(|&b| b == 0).unwrap_or(item.len());
                    String::from_utf8_lossy(&item[..end]).into_owned()
                })
                .collect()
        }
        'O' => match s.get(4).map(|x| &**x) {
            Some(Value::List(items)) if items.len() == count => items
                .iter()
                .enumerate()
                .map(|(i, item)| {
                    item.as_str()
                        .ok_or_else(|| format!("item {i} is not a string"))
                })
                .collect::<Result<Vec<String>, String>>()?,
            _ => return Err("malformed object array data".into()),
        },
        other => {
            return Err(format!(
                "is a numeric array (dtype {other}{size}), not strings"
            ));
        }
    };
    if strings.len() != count {
        return Err(format!(
            "holds {} strings for shape {shape:?}",
            strings.len()
        ));
    }
    if fortran && shape.len() > 1 {
        // The Fortran position of each C-order element, by reordering the positions themselves.
        let order = fortran_to_c((0..count).map(|i| i as f64).collect(), &shape);
        return Ok(order.iter().map(|&i| strings[i as usize].clone()).collect());
    }
    Ok(strings)
}

/// Reads the bytes joblib wrote after a `NumpyArrayWrapper` (state: shape, order, dtype and,
/// since joblib 1.2, `numpy_array_alignment_bytes`: a padding-length byte and that much padding
/// precede the data).
fn read_joblib_array(wrapper: &Value, r: &mut Reader) -> Result<Array, String> {
    let Value::Object {
        state: Some(state), ..
    } = wrapper
    else {
        return Err("joblib array wrapper without state".into());
    };
    let Value::Dict(items) = &**state else {
        return Err("joblib array wrapper state is not a dict".into());
    };
    let shape = dict_get(items, "shape")
        .and_then(|s| as_usize_tuple(s))
        .ok_or("joblib array without a shape")?;
    let (kind, size, little) =
        dtype_of(dict_get(items, "dtype").ok_or("joblib array without dtype")?)?;
    if kind == 'O' {
        return Err("joblib object arrays are not supported".into());
    }
    let fortran = matches!(dict_get(items, "order").map(|o| &**o), Some(Value::Str(o)) if o == "F");
    if matches!(
        dict_get(items, "numpy_array_alignment_bytes").map(|v| &**v),
        Some(Value::Int(_))
    ) {
        let padding = r.u8()? as usize;
        r.take(padding)?;
    }
    let count: usize = shape.iter().product();
    let raw = r.take(count * size)?;
    let values = decode(raw, kind, size, little)?;
    let values = if fortran && shape.len() > 1 {
        fortran_to_c(values, &shape)
    } else {
        values
    };
    Ok(Array { shape, values })
}

impl Value {
    /// The value under `key` of a dict (string or integer keys, e.g. `"1"` finds `{1: …}`).
    pub fn get(&self, key: &str) -> Option<&Value> {
        let Value::Dict(items) = self else {
            return None;
        };
        dict_get(items, key).map(|v| &**v).or_else(|| {
            let k: i64 = key.parse().ok()?;
            items.iter().find_map(|(kk, v)| match **kk {
                Value::Int(i) if i == k => Some(&**v),
                _ => None,
            })
        })
    }

    /// A dict's keys as text (ints written in decimal).
    pub fn keys(&self) -> Vec<String> {
        match self {
            Value::Dict(items) => items
                .iter()
                .filter_map(|(k, _)| match &**k {
                    Value::Str(s) => Some(s.clone()),
                    Value::Bytes(b) => Some(String::from_utf8_lossy(b).into_owned()),
                    Value::Int(i) => Some(i.to_string()),
                    _ => None,
                })
                .collect(),
            _ => Vec::new(),
        }
    }

    /// Items of a list or tuple.
    pub fn items(&self) -> Option<Vec<&Value>> {
        match self {
            Value::List(v) | Value::Tuple(v) => Some(v.iter().map(|x| &**x).collect()),
            _ => None,
        }
    }

    pub fn as_str(&self) -> Option<String> {
        match self {
            Value::Str(s) => Some(s.clone()),
            Value::Bytes(b) => Some(String::from_utf8_lossy(b).into_owned()),
            _ => None,
        }
    }

    pub fn as_f64(&self) -> Option<f64> {
        match self {
            Value::Int(i) => Some(*i as f64),
            Value::Float(f) => Some(*f),
            Value::Bool(b) => Some(*b as u8 as f64),
            _ => None,
        }
    }

    /// The element of a 0-d numpy object array (what `np.load(…, allow_pickle=True).item()`
    /// returns), or the value itself.
    pub fn item(&self) -> &Value {
        if let Value::Object {
            state: Some(state), ..
        } = self
            && class_of(self).is_some_and(|c| c.ends_with("_reconstruct"))
            && let Value::Tuple(s) = &**state
            && let Some(Value::List(objects)) = s.get(4).map(|x| &**x)
            && objects.len() == 1
        {
            return &objects[0];
        }
        self
    }
}

/// A torch tensor pickled by plain `pickle`/`joblib`:
/// `_rebuild_tensor_v2(storage, offset, size, stride, …)` with the storage as
/// `torch.storage._load_from_bytes(blob)`, `blob` being torch's legacy (non-zip) `torch.save`
/// of that storage: pickles of the magic number, protocol version and system info, then the
/// storage as a persistent id `('storage', <type>, key, location, numel)`, then the list of
/// keys, then per key an `i64` element count and the raw little-endian elements.
fn torch_tensor(v: &Value) -> Result<Array, String> {
    let Value::Object { args, .. } = v else {
        return Err("malformed torch tensor".into());
    };
    let Value::Tuple(a) = &**args else {
        return Err("malformed torch tensor".into());
    };
    let storage = a.first().ok_or("torch tensor without storage")?;
    let offset = match a.get(1).map(|x| &**x) {
        Some(Value::Int(o)) if *o >= 0 => *o as usize,
        _ => return Err("torch tensor without a storage offset".into()),
    };
    let size = a
        .get(2)
        .and_then(|x| as_usize_tuple(x))
        .ok_or("torch tensor without size")?;
    let stride = a
        .get(3)
        .and_then(|x| as_usize_tuple(x))
        .ok_or("torch tensor without stride")?;
    if stride.len() != size.len() {
        return Err("torch tensor size and stride differ in length".into());
    }
    let Value::Object { class, args, .. } = &**storage else {
        return Err("torch storage is not `_load_from_bytes(…)`".into());
    };
    if global_name(class).as_deref() != Some("torch.storage._load_from_bytes") {
        return Err(format!(
            "torch storage built by {:?}, expected torch.storage._load_from_bytes",
            global_name(class)
        ));
    }
    let blob = match &**args {
        Value::Tuple(b) => match b.first().map(|x| &**x) {
            Some(Value::Bytes(bytes)) => bytes.clone(),
            _ => return Err("torch storage without bytes".into()),
        },
        _ => return Err("torch storage without bytes".into()),
    };
    let storage = legacy_storage(&blob)?;
    let count: usize = size.iter().product();
    let mut values = Vec::with_capacity(count);
    let mut index = vec![0usize; size.len()];
    for _ in 0..count {
        let at = offset + index.iter().zip(&stride).map(|(i, s)| i * s).sum::<usize>();
        values.push(
            *storage
                .get(at)
                .ok_or("torch tensor reaches past its storage")?,
        );
        for axis in (0..size.len()).rev() {
            index[axis] += 1;
            if index[axis] < size[axis] {
                break;
            }
            index[axis] = 0;
        }
    }
    Ok(Array {
        shape: size,
        values,
    })
}

/// The elements of one storage saved in torch's legacy format (see [`torch_tensor`]).
fn legacy_storage(blob: &[u8]) -> Result<Vec<f64>, String> {
    let mut r = Reader { data: blob, pos: 0 };
    for _ in 0..3 {
        run(&mut r)?; // magic number, protocol version, system info
    }
    let main = run(&mut r)?;
    let Value::Persistent(id) = &*main else {
        return Err("legacy torch file does not hold a storage".into());
    };
    let Value::Tuple(id) = &**id else {
        return Err("malformed storage id".into());
    };
    let kind = id
        .get(1)
        .and_then(|t| global_name(t))
        .ok_or("storage id without a type")?;
    let (code, size) = match kind.rsplit('.').next().unwrap_or("") {
        "FloatStorage" => ('f', 4),
        "DoubleStorage" => ('f', 8),
        "LongStorage" => ('i', 8),
        "IntStorage" => ('i', 4),
        "ByteStorage" | "BoolStorage" => ('u', 1),
        other => return Err(format!("torch storage type {other} is not read")),
    };
    run(&mut r)?; // the storage keys
    let numel = r.u64()? as usize;
    let raw = r.take(numel.checked_mul(size).ok_or("storage too large")?)?;
    decode(raw, code, size, true)
}

/// Reads a pickle file (plain or joblib).
pub fn load(path: &Path) -> Result<Rc<Value>, String> {
    let data = std::fs::read(path).map_err(|e| format!("cannot read ({e})"))?;
    unpickle(&data).map_err(|e| format!("not a readable pickle: {e}"))
}

/// Reads a `.npy` file whose dtype is `object` (a pickled array follows the header), as
/// `np.save` writes a dict; returns the array's single element for 0-d arrays.
pub fn load_npy_object(path: &Path) -> Result<Rc<Value>, String> {
    let data = std::fs::read(path).map_err(|e| format!("cannot read ({e})"))?;
    if data.len() < 10 || &data[..6] != b"\x93NUMPY" {
        return Err("not a .npy file".into());
    }
    let (header_len, start) = match data[6] {
        1 => (u16::from_le_bytes([data[8], data[9]]) as usize, 10),
        2 | 3 if data.len() >= 12 => (
            u32::from_le_bytes([data[8], data[9], data[10], data[11]]) as usize,
            12,
        ),
        v => return Err(format!("unsupported .npy version {v}")),
    };
    let header = data
        .get(start..start + header_len)
        .ok_or("truncated .npy header")?;
    let header = String::from_utf8_lossy(header);
    if !header.contains("'|O'") {
        return Err(format!(
            "holds a plain array ({}), not a pickled object",
            header.trim()
        ));
    }
    let root =
        unpickle(&data[start + header_len..]).map_err(|e| format!("not a readable pickle: {e}"))?;
    Ok(Rc::new(root.item().clone()))
}

/// A protocol-2 pickle writer for dicts, lists, scalars, strings and numpy arrays, in the form
/// Python's `pickle.dump` gives them; `joblib_arrays` writes arrays as joblib does instead
/// (a `NumpyArrayWrapper` followed by the raw bytes, 16-byte aligned).
pub struct Writer {
    pub bytes: Vec<u8>,
    pub joblib_arrays: bool,
}

impl Writer {
    pub fn new(joblib_arrays: bool) -> Self {
        Self {
            bytes: vec![0x80, 2],
            joblib_arrays,
        }
    }

    fn op(&mut self, b: &[u8]) -> &mut Self {
        self.bytes.extend_from_slice(b);
        self
    }

    fn global(&mut self, module: &str, name: &str) -> &mut Self {
        self.op(b"c")
            .op(module.as_bytes())
            .op(b"\n")
            .op(name.as_bytes())
            .op(b"\n")
    }

    pub fn str(&mut self, s: &str) -> &mut Self {
        let n = (s.len() as u32).to_le_bytes();
        self.op(b"X").op(&n).op(s.as_bytes())
    }

    pub fn int(&mut self, v: i32) -> &mut Self {
        self.op(b"J").op(&v.to_le_bytes())
    }

    pub fn float(&mut self, v: f64) -> &mut Self {
        self.op(b"G").op(&v.to_be_bytes())
    }

    pub fn none(&mut self) -> &mut Self {
        self.op(b"N")
    }

    /// Starts a dict; follow with key/value pairs, then [`Self::end_dict`].
    pub fn begin_dict(&mut self) -> &mut Self {
        self.op(b"}(")
    }

    pub fn end_dict(&mut self) -> &mut Self {
        self.op(b"u")
    }

    /// Starts a list; follow with items, then [`Self::end_list`].
    pub fn begin_list(&mut self) -> &mut Self {
        self.op(b"](")
    }

    pub fn end_list(&mut self) -> &mut Self {
        self.op(b"e")
    }

    fn dtype(&mut self, code: &str) -> &mut Self {
        if code == "O8" {
            self.dtype_with(code, "|", -1, -1, 63)
        } else {
            self.dtype_with(code, "<", -1, -1, 0)
        }
    }

    /// `dtype(code, False, True)` with the state numpy pickles: (3, byte order, None, None,
    /// None, item size, alignment, flags); -1 sizes for fixed-size types.
    fn dtype_with(
        &mut self,
        code: &str,
        order: &str,
        item_size: i32,
        alignment: i32,
        flags: i32,
    ) -> &mut Self {
        self.global("numpy", "dtype")
            .str(code)
            .op(&[0x89, 0x88, 0x87, b'R']) // (code, False, True) → dtype(...)
            .op(b"(")
            .int(3)
            .str(order)
            .op(b"NNN")
            .int(item_size)
            .int(alignment)
            .int(flags)
            .op(b"tb")
    }

    /// `_reconstruct(ndarray, (0,), b'b')`: the empty array numpy's pickles fill by BUILD.
    fn empty_ndarray(&mut self) -> &mut Self {
        self.global("numpy.core.multiarray", "_reconstruct")
            .global("numpy", "ndarray")
            .op(b"(")
            .int(0)
            .op(b"t")
            .str("b")
            .op(&[0x87, b'R'])
    }

    /// Starts a 0-d numpy object array (what `np.save` of a dict pickles); write its one
    /// element, then [`Self::end_object_scalar`].
    pub fn begin_object_scalar(&mut self) -> &mut Self {
        self.empty_ndarray()
            .op(b"(")
            .int(1)
            .op(b")")
            .dtype("O8")
            .op(&[0x89])
            .begin_list()
    }

    pub fn end_object_scalar(&mut self) -> &mut Self {
        self.end_list().op(b"tb")
    }

    /// A numpy float64 scalar (`np.float64(v)`).
    pub fn numpy_scalar(&mut self, v: f64) -> &mut Self {
        self.global("numpy.core.multiarray", "scalar").dtype("f8");
        let raw = v.to_le_bytes();
        self.op(b"B")
            .op(&(raw.len() as u32).to_le_bytes())
            .op(&raw)
            .op(&[0x86, b'R'])
    }

    /// A torch tensor of `shape` (C-contiguous) whose storage is `FloatStorage`, `LongStorage`
    /// or `BoolStorage`, as plain pickle and joblib write one (see `torch_tensor`).
    pub fn torch_tensor(&mut self, shape: &[usize], values: &[f64], storage: &str) -> &mut Self {
        assert_eq!(
            shape.iter().product::<usize>(),
            values.len(),
            "values fill the shape"
        );
        let mut blob = Vec::new();
        let mut small = |f: &dyn Fn(&mut Writer)| {
            let mut w = Writer::new(false);
            f(&mut w);
            blob.extend(w.finish());
        };
        // Magic number 0x1950a86a20f9469cfc6c (LONG1, 10 bytes), protocol 1001, system info.
        small(&|w| {
            w.op(&[
                0x8a, 10, 0x6c, 0xfc, 0x9c, 0x46, 0xf9, 0x20, 0x6a, 0xa8, 0x50, 0x19,
            ]);
        });
        small(&|w| {
            w.int(1001);
        });
        small(&|w| {
            w.begin_dict().str("little_endian").op(&[0x88]).end_dict();
        });
        let numel = values.len();
        small(&|w| {
            w.op(b"(")
                .str("storage")
                .global("torch", storage)
                .str("0")
                .str("cpu");
            w.int(numel as i32).op(b"tQ");
        });
        small(&|w| {
            w.begin_list().str("0").end_list();
        });
        blob.extend((numel as u64).to_le_bytes());
        match storage {
            "FloatStorage" => blob.extend(values.iter().flat_map(|&v| (v as f32).to_le_bytes())),
            "LongStorage" => blob.extend(values.iter().flat_map(|&v| (v as i64).to_le_bytes())),
            "BoolStorage" => blob.extend(values.iter().map(|&v| (v != 0.0) as u8)),
            other => panic!("the writer does not write {other}"),
        }
        let mut stride = vec![1usize; shape.len()];
        for axis in (0..shape.len().saturating_sub(1)).rev() {
            stride[axis] = stride[axis + 1] * shape[axis + 1];
        }
        self.global("torch._utils", "_rebuild_tensor_v2")
            .op(b"(")
            .global("torch.storage", "_load_from_bytes")
            .op(b"B")
            .op(&(blob.len() as u32).to_le_bytes())
            .op(&blob)
            .op(&[0x85, b'R']) // _load_from_bytes((blob,))
            .int(0)
            .op(b"(");
        for &d in shape {
            self.int(d as i32);
        }
        self.op(b"t(");
        for &d in &stride {
            self.int(d as i32);
        }
        self.op(b"t")
            .op(&[0x89])
            .global("collections", "OrderedDict")
            .op(b")R")
            .op(b"tR")
    }

    /// A float32 (`f4`) or float64 (`f8`) array of `shape`.
    pub fn array(&mut self, shape: &[usize], values: &[f64], f64_dtype: bool) -> &mut Self {
        assert_eq!(
            shape.iter().product::<usize>(),
            values.len(),
            "values fill the shape"
        );
        let raw: Vec<u8> = if f64_dtype {
            values.iter().flat_map(|v| v.to_le_bytes()).collect()
        } else {
            values
                .iter()
                .flat_map(|&v| (v as f32).to_le_bytes())
                .collect()
        };
        let code = if f64_dtype { "f8" } else { "f4" };
        let shape_tuple = |w: &mut Self| {
            w.op(b"(");
            for &s in shape {
                w.int(s as i32);
            }
            w.op(b"t");
        };
        if self.joblib_arrays {
            // NumpyArrayWrapper() via NEWOBJ, its state dict, BUILD, then the raw bytes.
            self.global("joblib.numpy_pickle", "NumpyArrayWrapper")
                .op(b")")
                .op(&[0x81])
                .begin_dict()
                .str("subclass")
                .global("numpy", "ndarray")
                .str("shape");
            shape_tuple(self);
            self.str("order").str("C").str("dtype").dtype(code);
            self.str("allow_mmap")
                .op(&[0x89])
                .str("numpy_array_alignment_bytes")
                .int(16)
                .end_dict()
                .op(b"b");
            // joblib: padding length (1–16) so that the data starts 16-byte aligned.
            let padding = 16 - (self.bytes.len() + 1) % 16;
            self.op(&[padding as u8]).op(&vec![0xff; padding]);
            return self.op(&raw);
        }
        self.empty_ndarray().op(b"(").int(1);
        shape_tuple(self);
        self.dtype(code)
            .op(&[0x89]) // not Fortran order
            .op(b"B")
            .op(&(raw.len() as u32).to_le_bytes())
            .op(&raw)
            .op(b"tb")
    }

    /// A numpy unicode string array of `shape` (`<U{width}`, the width of the longest value), as
    /// numpy pickles `np.array(list_of_str)`: UTF-32 code points, NUL-padded to the width.
    pub fn string_array(&mut self, shape: &[usize], values: &[&str]) -> &mut Self {
        assert_eq!(
            shape.iter().product::<usize>(),
            values.len(),
            "values fill the shape"
        );
        let width = values
            .iter()
            .map(|v| v.chars().count())
            .max()
            .unwrap_or(0)
            .max(1);
        let mut raw = Vec::with_capacity(values.len() * width * 4);
        for v in values {
            raw.extend(v.chars().flat_map(|c| (c as u32).to_le_bytes()));
            raw.resize(raw.len() + 4 * (width - v.chars().count()), 0);
        }
        self.empty_ndarray().op(b"(").int(1).op(b"(");
        for &s in shape {
            self.int(s as i32);
        }
        self.op(b"t")
            .dtype_with(&format!("U{width}"), "<", 4 * width as i32, 4, 8)
            .op(&[0x89]) // not Fortran order
            .op(b"B")
            .op(&(raw.len() as u32).to_le_bytes())
            .op(&raw)
            .op(b"tb")
    }

    /// The finished pickle.
    pub fn finish(mut self) -> Vec<u8> {
        self.op(b".");
        self.bytes
    }
}

/// Writes `pickle` (from [`Writer`], holding one object array) as a `.npy` file of dtype object,
/// as `np.save(path, value, allow_pickle=True)` does.
pub fn npy_object_bytes(pickle: &[u8]) -> Vec<u8> {
    let mut header = "{'descr': '|O', 'fortran_order': False, 'shape': (), }".to_owned();
    while !(10 + header.len() + 1).is_multiple_of(64) {
        header.push(' ');
    }
    header.push('\n');
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    out.extend_from_slice(&(header.len() as u16).to_le_bytes());
    out.extend_from_slice(header.as_bytes());
    out.extend_from_slice(pickle);
    out
}
