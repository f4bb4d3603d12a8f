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

mod read;
mod write;

use std::{collections::HashMap, sync::Arc};

use pyo3::{
    prelude::*,
    types::{PyBytes, PyDict, PyString},
};
use radar_idl::{is_primitive, ros2msg::Field};
use radar_ros::codec::{run_time_types, At, CdrReader, CdrWriter};

use read::{numeric_names, read_message, Failed};
use write::write_message;

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
    /// Whether a new object of the class checks what its setters are given (`_check_fields`, on with
    /// `ROS_PYTHON_CHECK_FIELDS=1`): then a bounded string read longer than its bound is refused, as rclpy's
    /// reading refuses it through the setter; read whole otherwise, as rclpy reads it.
    checks: bool,
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
    let theirs = rosidl_fields(cls)?;
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
    let extras = extras(py, cls, &slots, &fields)?;
    let checks = extras.iter().any(|(slot, v)| {
        slot.bind(py).to_cow().is_ok_and(|s| s == "_check_fields")
            && v.bind(py).is_truthy().unwrap_or(false)
    });
    let p = Arc::new(Plan {
        ros_type: ros_type.to_owned(),
        fields,
        cls: cls.clone().unbind(),
        extras,
        checks,
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

/// The fields of the class `cls` as it lists them (`get_fields_and_field_types()`: name, type in rosidl's words).
fn rosidl_fields(cls: &Bound<'_, PyAny>) -> Option<Vec<(String, String)>> {
    cls.call_method0("get_fields_and_field_types")
        .ok()?
        .cast::<PyDict>()
        .ok()?
        .iter()
        .map(|(k, v)| Some((k.extract().ok()?, v.extract().ok()?)))
        .collect()
}

/// The slots of `cls` that hold none of `fields`, with their values in a new object of the class.
fn extras(
    py: Python<'_>,
    cls: &Bound<'_, PyAny>,
    slots: &[String],
    fields: &[FieldPlan],
) -> Option<Vec<(Py<PyString>, Py<PyAny>)>> {
    let template = cls.call0().ok()?;
    let mut extras = Vec::new();
    for slot in slots {
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
    Some(extras)
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

fn repr(v: &Bound<'_, PyAny>) -> String {
    v.repr().map(|r| r.to_string()).unwrap_or_default()
}
