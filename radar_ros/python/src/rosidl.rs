//! rosidl message objects (`std_msgs.msg.Header()`, any generated class) written as CDR and read from it
//! without rclpy.
//!
//! rclpy's `serialize_message` converts the object to a C struct and serializes that, `deserialize_message` the
//! reverse: 40-60 us each for a `Header` between signals on this machine (`docs/benchmarks.md`), most of a
//! Python event's extra cost over a Rust one and a stage of a Python response's start. A [`RosidlCodec`] reads
//! the fields straight from the object (its rosidl slots), in the order the type's definition lists them, and
//! writes them as [`radar_ros::codec`] writes a payload (`CdrWriter`); it reads a body into a new object of the
//! class as rclpy would make it (numpy arrays for fixed numeric arrays, `array.array` for numeric sequences,
//! lists otherwise, a one-byte `bytes` for a `byte`). Numeric arrays are copied whole either way.
//!
//! A codec is made only for a class whose fields, in rosidl's words (`get_fields_and_field_types()`), are
//! exactly those of the definition found here (known, shipped, or on `AMENT_PREFIX_PATH`), nested types too,
//! each kept in a slot of its own: any other class (another version of the package, no definition) is left to
//! rclpy.

use std::{collections::HashMap, sync::Arc};

use pyo3::{
    prelude::*,
    types::{PyBool, PyByteArray, PyBytes, PyDict, PyList, PyString},
};
use radar_idl::{is_primitive, ros2msg::Field};
use radar_ros::codec::{run_time_types, CdrReader, CdrWriter};

/// Writes objects of one rosidl class as the CDR body of their message, and reads them back
/// (`_native.rosidl_codec`).
#[pyclass(frozen, module = "radar_ros._native")]
pub(crate) struct RosidlCodec {
    plan: Arc<Plan>,
}

#[pymethods]
impl RosidlCodec {
    /// `obj` (of the class this encoder was made for) as the CDR body of its message, without the 4-byte
    /// encapsulation header; `PayloadTypeError` naming the field when a value is not what its type says.
    fn encode<'py>(
        &self,
        py: Python<'py>,
        obj: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyBytes>> {
        let mut w = CdrWriter::default();
        write_message(&self.plan, obj, &mut w, &At::Root(&self.plan.ros_type))
            .map_err(crate::payload_error)?;
        Ok(PyBytes::new(py, &w.finish()))
    }

    /// The CDR body `body` (without the encapsulation header) as a new object of the class;
    /// `PayloadTypeError` saying where a malformed body ends short or what it holds that is not its type's.
    fn decode<'py>(&self, py: Python<'py>, body: &[u8]) -> PyResult<Bound<'py, PyAny>> {
        let mut r = CdrReader::new(body);
        read_message(py, &self.plan, &mut r, &At::Root(&self.plan.ros_type)).map_err(|e| match e {
            Failed::Python(e) => e,
            Failed::Payload(m) => crate::payload_error(m),
        })
    }
}

/// A codec for the rosidl class `cls` of `ros_type`, or None when the definition found here is not the
/// class's (or there is none, or a nested type's class cannot be imported, or the class keeps a field in no
/// slot of its own): rclpy serializes and deserializes those.
#[pyfunction]
pub(crate) fn rosidl_codec(
    py: Python<'_>,
    ros_type: &str,
    cls: &Bound<'_, PyAny>,
) -> Option<RosidlCodec> {
    plan(py, ros_type, cls, &mut HashMap::new()).map(|plan| RosidlCodec { plan })
}

/// How to write and read one message type: its fields in order, and how to make an object of its class.
struct Plan {
    ros_type: String,
    fields: Vec<FieldPlan>,
    cls: Py<PyAny>,
    /// The class's slots that hold no field (`_check_fields`), as a new object of the class has them.
    extras: Vec<(Py<PyString>, Py<PyAny>)>,
    /// numpy's `frombuffer` (imported only for a type with a fixed numeric array) and `array.array`, for the
    /// numeric arrays a read object holds.
    frombuffer: Option<Py<PyAny>>,
    array: Py<PyAny>,
}

struct FieldPlan {
    name: String,
    /// The field's slot (`_stamp`): read, and set on an object read, without the property's checks.
    attr: Py<PyString>,
    kind: Kind,
    shape: Shape,
}

#[derive(Clone, Copy, PartialEq)]
enum Shape {
    One,
    Fixed(usize),
    Bounded(usize),
    Unbounded,
}

enum Kind {
    Bool,
    /// `byte`: rosidl gives a one-byte `bytes`.
    Octet,
    Int {
        bytes: usize,
        signed: bool,
    },
    F32,
    F64,
    Str {
        wide: bool,
        bound: Option<usize>,
    },
    Msg(Arc<Plan>),
}

fn plan(
    py: Python<'_>,
    ros_type: &str,
    cls: &Bound<'_, PyAny>,
    made: &mut HashMap<String, Arc<Plan>>,
) -> Option<Arc<Plan>> {
    if let Some(p) = made.get(ros_type) {
        return Some(p.clone());
    }
    let types = run_time_types();
    let spec = types.definition(ros_type).ok()?;
    let theirs: Vec<(String, String)> = cls
        .call_method0("get_fields_and_field_types")
        .ok()?
        .cast::<PyDict>()
        .ok()?
        .iter()
        .map(|(k, v)| Some((k.extract().ok()?, v.extract().ok()?)))
        .collect::<Option<_>>()?;
    if theirs.len() != spec.fields.len() {
        return None;
    }
    let slots = slot_names(cls);
    let mut fields = Vec::with_capacity(spec.fields.len());
    for (f, (name, rosidl_type)) in spec.fields.iter().zip(&theirs) {
        let (kind, base) = kind_of(py, f, &spec.pkg_name, made)?;
        let t = &f.field_type;
        let (shape, ty) = match (t.is_array, t.array_size, t.is_upper_bound) {
            (false, _, _) => (Shape::One, base),
            (true, Some(n), false) => (Shape::Fixed(n as usize), format!("{base}[{n}]")),
            (true, Some(n), true) => (Shape::Bounded(n as usize), format!("sequence<{base}, {n}>")),
            (true, None, _) => (Shape::Unbounded, format!("sequence<{base}>")),
        };
        if *name != f.name || *rosidl_type != ty {
            return None;
        }
        let slot = format!("_{name}");
        if !slots.contains(&slot) {
            return None;
        }
        fields.push(FieldPlan {
            name: name.clone(),
            attr: PyString::intern(py, &slot).unbind(),
            kind,
            shape,
        });
    }
    let needs_numpy = fields
        .iter()
        .any(|f| matches!(f.shape, Shape::Fixed(_)) && numeric_names(&f.kind).is_some());
    let template = cls.call0().ok()?;
    let mut extras = Vec::new();
    for slot in &slots {
        if fields
            .iter()
            .any(|f| f.attr.bind(py).to_cow().is_ok_and(|a| a == *slot))
        {
            continue;
        }
        if let Ok(v) = template.getattr(slot.as_str()) {
            extras.push((PyString::intern(py, slot).unbind(), v.unbind()));
        }
    }
    let p = Arc::new(Plan {
        ros_type: ros_type.to_owned(),
        fields,
        cls: cls.clone().unbind(),
        extras,
        frombuffer: match needs_numpy {
            true => Some(
                py.import("numpy")
                    .and_then(|m| m.getattr("frombuffer"))
                    .ok()?
                    .unbind(),
            ),
            false => None,
        },
        array: py
            .import("array")
            .and_then(|m| m.getattr("array"))
            .ok()?
            .unbind(),
    });
    made.insert(ros_type.to_owned(), p.clone());
    Some(p)
}

/// The field's base type as written, and in rosidl's words (`get_fields_and_field_types()`); a nested type's
/// plan made from its class.
fn kind_of(
    py: Python<'_>,
    f: &Field,
    pkg: &str,
    made: &mut HashMap<String, Arc<Plan>>,
) -> Option<(Kind, String)> {
    let b = &f.field_type.base_type;
    let int = |bytes, signed| Kind::Int { bytes, signed };
    let bound = b.string_upper_bound.map(|n| n as usize);
    let (kind, word) = match b.type_name.as_str() {
        "bool" => (Kind::Bool, "boolean"),
        "byte" => (Kind::Octet, "octet"),
        "char" => (int(1, false), "uint8"),
        "uint8" => (int(1, false), "uint8"),
        "int8" => (int(1, true), "int8"),
        "uint16" => (int(2, false), "uint16"),
        "int16" => (int(2, true), "int16"),
        "uint32" => (int(4, false), "uint32"),
        "int32" => (int(4, true), "int32"),
        "uint64" => (int(8, false), "uint64"),
        "int64" => (int(8, true), "int64"),
        "float32" => (Kind::F32, "float"),
        "float64" => (Kind::F64, "double"),
        s @ ("string" | "wstring") => {
            let word = match bound {
                Some(n) => format!("{s}<{n}>"),
                None => s.to_owned(),
            };
            let wide = s == "wstring";
            return Some((Kind::Str { wide, bound }, word));
        }
        p if is_primitive(p) => return None,
        name => {
            let full = run_time_types().nested_type(f, pkg);
            let nested_pkg = full.split('/').next().unwrap_or_default().to_owned();
            let cls = py
                .import(format!("{nested_pkg}.msg"))
                .and_then(|m| m.getattr(name))
                .ok()?;
            let p = plan(py, &full, &cls, made)?;
            return Some((Kind::Msg(p), format!("{nested_pkg}/{name}")));
        }
    };
    Some((kind, word.to_owned()))
}

/// The names in the `__slots__` of `cls` and its bases.
fn slot_names(cls: &Bound<'_, PyAny>) -> Vec<String> {
    let mut names = Vec::new();
    let Ok(mro) = cls.getattr("__mro__").and_then(|m| m.try_iter()) else {
        return names;
    };
    for c in mro.flatten() {
        if let Ok(slots) = c.getattr("__slots__").and_then(|s| s.try_iter()) {
            names.extend(slots.flatten().filter_map(|s| s.extract::<String>().ok()));
        }
    }
    names
}

fn write_message(
    plan: &Plan,
    obj: &Bound<'_, PyAny>,
    w: &mut CdrWriter,
    at: &At<'_>,
) -> Result<(), String> {
    if plan.fields.is_empty() {
        w.u8(0); // an empty structure is one byte on the wire
        return Ok(());
    }
    for f in &plan.fields {
        let here = At::Field(at, &f.name);
        let v = obj
            .getattr(f.attr.bind(obj.py()))
            .map_err(|e| format!("{here}: {e}"))?;
        if f.shape == Shape::One {
            write_one(&f.kind, &v, w, &here)?;
            continue;
        }
        let n = v
            .len()
            .map_err(|_| format!("{here}: {} is not a sequence", repr(&v)))?;
        match f.shape {
            Shape::Fixed(k) if n != k => {
                return Err(format!("{here}: exactly {k} elements, not {n}"))
            }
            Shape::Bounded(b) if n > b => {
                return Err(format!("{here}: at most {b} elements, not {n}"))
            }
            Shape::Fixed(_) => {}
            _ => w.u32(n as u32),
        }
        if let Some(bytes) = numeric_bytes(&f.kind, &v, n) {
            w.elements(element_size(&f.kind), &bytes);
            continue;
        }
        let items = v
            .try_iter()
            .map_err(|_| format!("{here}: {} is not a sequence", repr(&v)))?;
        for (i, item) in items.enumerate() {
            let item = item.map_err(|e| format!("{here}[{i}]: {e}"))?;
            write_one(&f.kind, &item, w, &At::Index(&here, i))?;
        }
    }
    Ok(())
}

fn write_one(
    kind: &Kind,
    v: &Bound<'_, PyAny>,
    w: &mut CdrWriter,
    at: &At<'_>,
) -> Result<(), String> {
    let wrong = |what: &str| format!("{at}: {} is no {what}", repr(v));
    match kind {
        Kind::Bool => w.u8(u8::from(v.extract::<bool>().map_err(|_| wrong("bool"))?)),
        Kind::Octet => match v.cast::<PyBytes>().map(|b| b.as_bytes()) {
            Ok([b]) => w.u8(*b),
            _ => w.u8(v.extract::<u8>().map_err(|_| wrong("byte"))?),
        },
        Kind::Int { bytes, signed } => {
            let name = int_name(*bytes, *signed);
            let n: i128 = match v.extract::<i64>() {
                Ok(n) => n.into(),
                Err(_) => v.extract::<u64>().map_err(|_| wrong(&name))?.into(),
            };
            let bits = 8 * *bytes as u32;
            let (lo, hi) = if *signed {
                (-(1i128 << (bits - 1)), (1i128 << (bits - 1)) - 1)
            } else {
                (0, (1i128 << bits) - 1)
            };
            if n < lo || n > hi {
                return Err(format!("{at}: {n} is out of a {name}'s range {lo}..={hi}"));
            }
            match bytes {
                1 => w.u8(n as u8),
                2 => w.u16(n as u16),
                4 => w.u32(n as u32),
                _ => w.u64(n as u64),
            }
        }
        Kind::F32 => w.u32((v.extract::<f64>().map_err(|_| wrong("float32"))? as f32).to_bits()),
        Kind::F64 => w.u64(v.extract::<f64>().map_err(|_| wrong("float64"))?.to_bits()),
        Kind::Str { wide, bound } => {
            let s = v
                .cast::<PyString>()
                .map_err(|_| wrong(if *wide { "wstring" } else { "string" }))?
                .to_cow()
                .map_err(|e| format!("{at}: {e}"))?;
            let len = if *wide { s.chars().count() } else { s.len() };
            if let Some(b) = bound.filter(|b| len > *b) {
                return Err(format!("{at}: at most {b} characters, not {len}"));
            }
            if *wide {
                w.wstring(&s);
            } else {
                w.string(&s);
            }
        }
        Kind::Msg(p) => write_message(p, v, w, at)?,
    }
    Ok(())
}

/// Why a body was not read: Python refused something (an object not made), or the bytes are not the type's.
enum Failed {
    Python(PyErr),
    Payload(String),
}

impl From<PyErr> for Failed {
    fn from(e: PyErr) -> Failed {
        Failed::Python(e)
    }
}

impl From<std::convert::Infallible> for Failed {
    fn from(e: std::convert::Infallible) -> Failed {
        match e {}
    }
}

impl From<String> for Failed {
    fn from(m: String) -> Failed {
        Failed::Payload(m)
    }
}

fn read_message<'py>(
    py: Python<'py>,
    plan: &Plan,
    r: &mut CdrReader<'_>,
    at: &At<'_>,
) -> Result<Bound<'py, PyAny>, Failed> {
    let cls = plan.cls.bind(py);
    let obj = cls.call_method1("__new__", (cls,))?;
    for (slot, v) in &plan.extras {
        obj.setattr(slot.bind(py), v.bind(py))?;
    }
    if plan.fields.is_empty() {
        r.u8().map_err(|e| format!("{at}: {e}"))?;
    }
    for f in &plan.fields {
        let here = At::Field(at, &f.name);
        let v = match f.shape {
            Shape::One => read_one(py, &f.kind, r, &here)?,
            shape => {
                let n = match shape {
                    Shape::Fixed(k) => k,
                    _ => r.u32().map_err(|e| format!("{here}: {e}"))? as usize,
                };
                if let Shape::Bounded(b) = shape {
                    if n > b {
                        return Err(format!("{here}: {n} elements, at most {b}").into());
                    }
                }
                read_array(py, plan, f, n, r, &here)?
            }
        };
        obj.setattr(f.attr.bind(py), v)?;
    }
    Ok(obj)
}

/// `n` elements of the field `f`: numeric ones as rosidl holds them (a numpy array for a fixed array, an
/// `array.array` for a sequence), others as a list.
fn read_array<'py>(
    py: Python<'py>,
    plan: &Plan,
    f: &FieldPlan,
    n: usize,
    r: &mut CdrReader<'_>,
    at: &At<'_>,
) -> Result<Bound<'py, PyAny>, Failed> {
    if let Some((dtype, code)) = numeric_names(&f.kind) {
        let size = element_size(&f.kind);
        let bytes = r.elements(size, n).map_err(|e| format!("{at}: {e}"))?;
        return Ok(if matches!(f.shape, Shape::Fixed(_)) {
            // over a bytearray of its own: writable, as rclpy's arrays are
            let frombuffer = plan
                .frombuffer
                .as_ref()
                .expect("imported for a fixed numeric array");
            frombuffer
                .bind(py)
                .call1((PyByteArray::new(py, bytes), dtype))?
        } else {
            plan.array.bind(py).call1((code, PyBytes::new(py, bytes)))?
        });
    }
    // every element takes a byte at least: a length beyond the body is an error, not an allocation
    if n > r.remaining() {
        return Err(format!("{at}: {n} elements in {} bytes", r.remaining()).into());
    }
    let list = PyList::empty(py);
    for i in 0..n {
        list.append(read_one(py, &f.kind, r, &At::Index(at, i))?)?;
    }
    Ok(list.into_any())
}

fn read_one<'py>(
    py: Python<'py>,
    kind: &Kind,
    r: &mut CdrReader<'_>,
    at: &At<'_>,
) -> Result<Bound<'py, PyAny>, Failed> {
    let short = |e: String| format!("{at}: {e}");
    Ok(match kind {
        Kind::Bool => PyBool::new(py, r.u8().map_err(short)? != 0)
            .to_owned()
            .into_any(),
        Kind::Octet => PyBytes::new(py, &[r.u8().map_err(short)?]).into_any(),
        Kind::Int { bytes, signed } => {
            let bits = match bytes {
                1 => u64::from(r.u8().map_err(short)?),
                2 => u64::from(r.u16().map_err(short)?),
                4 => u64::from(r.u32().map_err(short)?),
                _ => r.u64().map_err(short)?,
            };
            if *signed {
                let shift = 64 - 8 * *bytes as u32;
                (((bits << shift) as i64) >> shift)
                    .into_pyobject(py)?
                    .into_any()
            } else {
                bits.into_pyobject(py)?.into_any()
            }
        }
        Kind::F32 => f64::from(f32::from_bits(r.u32().map_err(short)?))
            .into_pyobject(py)?
            .into_any(),
        Kind::F64 => f64::from_bits(r.u64().map_err(short)?)
            .into_pyobject(py)?
            .into_any(),
        Kind::Str { wide, .. } => {
            let s = if *wide { r.wstring() } else { r.string() }.map_err(short)?;
            PyString::new(py, &s).into_any()
        }
        Kind::Msg(p) => read_message(py, p, r, at)?,
    })
}

/// A numeric kind's numpy dtype and `array.array` type code.
fn numeric_names(kind: &Kind) -> Option<(&'static str, &'static str)> {
    Some(match kind {
        Kind::Int {
            bytes: 1,
            signed: true,
        } => ("int8", "b"),
        Kind::Int {
            bytes: 1,
            signed: false,
        } => ("uint8", "B"),
        Kind::Int {
            bytes: 2,
            signed: true,
        } => ("int16", "h"),
        Kind::Int {
            bytes: 2,
            signed: false,
        } => ("uint16", "H"),
        Kind::Int {
            bytes: 4,
            signed: true,
        } => ("int32", "i"),
        Kind::Int {
            bytes: 4,
            signed: false,
        } => ("uint32", "I"),
        Kind::Int { signed: true, .. } => ("int64", "q"),
        Kind::Int { signed: false, .. } => ("uint64", "Q"),
        Kind::F32 => ("float32", "f"),
        Kind::F64 => ("float64", "d"),
        _ => return None,
    })
}

fn int_name(bytes: usize, signed: bool) -> String {
    format!("{}int{}", if signed { "" } else { "u" }, 8 * bytes)
}

fn element_size(kind: &Kind) -> usize {
    match kind {
        Kind::Int { bytes, .. } => *bytes,
        Kind::F32 => 4,
        Kind::F64 => 8,
        _ => 1,
    }
}

/// The `n` elements of a numeric array as their bytes in one copy, when `v` is a one-dimensional numpy array
/// or an `array.array` whose elements are exactly the field's type (what rosidl stores), on a little-endian
/// host; None for anything else (each element is then written one by one).
fn numeric_bytes(kind: &Kind, v: &Bound<'_, PyAny>, n: usize) -> Option<Vec<u8>> {
    if !cfg!(target_endian = "little") || n == 0 {
        return None;
    }
    let (class, size) = match kind {
        Kind::Int { bytes, signed } => (if *signed { 'i' } else { 'u' }, *bytes),
        Kind::F32 => ('f', 4),
        Kind::F64 => ('f', 8),
        _ => return None,
    };
    let ty = v.get_type();
    let (module, qualname) = (ty.module().ok()?, ty.qualname().ok()?);
    let same = match (
        module.to_cow().ok()?.as_ref(),
        qualname.to_cow().ok()?.as_ref(),
    ) {
        ("numpy", "ndarray") => {
            let dtype = v.getattr("dtype").ok()?;
            let kind: String = dtype.getattr("kind").ok()?.extract().ok()?;
            let order: String = dtype.getattr("byteorder").ok()?.extract().ok()?;
            v.getattr("ndim").ok()?.extract::<usize>().ok()? == 1
                && kind.starts_with(class)
                && dtype.getattr("itemsize").ok()?.extract::<usize>().ok()? == size
                && matches!(order.as_str(), "=" | "<" | "|")
        }
        ("array", "array") => {
            let code: String = v.getattr("typecode").ok()?.extract().ok()?;
            let code_class = match code.as_str() {
                "b" | "h" | "i" | "l" | "q" => 'i',
                "B" | "H" | "I" | "L" | "Q" => 'u',
                "f" | "d" => 'f',
                _ => return None,
            };
            code_class == class && v.getattr("itemsize").ok()?.extract::<usize>().ok()? == size
        }
        _ => false,
    };
    if !same {
        return None;
    }
    let b: Vec<u8> = v.call_method0("tobytes").ok()?.extract().ok()?;
    (b.len() == n * size).then_some(b)
}

/// Where in the payload a value is (`std_msgs/msg/Header.stamp.sec`, `...data[3]`), for errors; written out
/// only when one is made.
enum At<'a> {
    Root(&'a str),
    Field(&'a At<'a>, &'a str),
    Index(&'a At<'a>, usize),
}

impl std::fmt::Display for At<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            At::Root(t) => f.write_str(t),
            At::Field(up, name) => write!(f, "{up}.{name}"),
            At::Index(up, i) => write!(f, "{up}[{i}]"),
        }
    }
}

fn repr(v: &Bound<'_, PyAny>) -> String {
    v.repr().map(|r| r.to_string()).unwrap_or_default()
}
