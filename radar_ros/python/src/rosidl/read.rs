//! A CDR body read into a new object of the rosidl class, as rclpy makes it.

use pyo3::{
    prelude::*,
    types::{PyBool, PyByteArray, PyBytes, PyList, PyString},
};
use radar_ros::codec::CdrReader;

use super::{write::element_size, At, FieldPlan, Kind, Plan, Shape};

/// Why a body was not read: Python refused something (an object not made), or the bytes are not the type's.
pub(super) enum Failed {
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

pub(super) fn read_message<'py>(
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
            Shape::One => read_one(py, plan, &f.kind, r, &here)?,
            shape => {
                let n = match shape {
                    Shape::Fixed(k) => k,
                    _ => r.u32().map_err(|e| format!("{here}: {e}"))? as usize,
                };
                // a bounded sequence longer than its bound is read whole, as rclpy reads it (checked fields or
                // not): a faulty writer's message is not lost here; the package never writes one
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
        list.append(read_one(py, plan, &f.kind, r, &At::Index(at, i))?)?;
    }
    Ok(list.into_any())
}

/// A bounded string of `n` characters, over its bound `b`: read whole as rclpy reads it (a faulty writer's
/// message is not lost here), or refused when the class checks its fields, as rclpy's reading then fails in the
/// setter. The package never writes one.
fn beyond_bound(plan: &Plan, n: usize, b: usize, at: &At<'_>) -> Result<(), Failed> {
    if n > b && plan.checks {
        return Err(format!(
            "{at}: {n} characters, at most {b} (ROS_PYTHON_CHECK_FIELDS=1: the class refuses it; unset, it is read whole, as rclpy reads it)"
        )
        .into());
    }
    Ok(())
}

fn read_one<'py>(
    py: Python<'py>,
    plan: &Plan,
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
        Kind::Str { wide, bound } => {
            let s = if *wide { r.wstring() } else { r.string() }.map_err(short)?;
            if let Some(b) = bound {
                // in characters, as the setter's `len(value)` counts them
                beyond_bound(plan, s.chars().count(), *b, at)?;
            }
            PyString::new(py, &s).into_any()
        }
        Kind::Msg(p) => read_message(py, p, r, at)?,
    })
}

/// A numeric kind's numpy dtype and `array.array` type code.
pub(super) fn numeric_names(kind: &Kind) -> Option<(&'static str, &'static str)> {
    /// By size (1, 2, 4, 8 bytes): unsigned, then signed.
    const INTS: [[(&str, &str); 2]; 4] = [
        [("uint8", "B"), ("int8", "b")],
        [("uint16", "H"), ("int16", "h")],
        [("uint32", "I"), ("int32", "i")],
        [("uint64", "Q"), ("int64", "q")],
    ];
    match kind {
        Kind::Int { bytes, signed } => INTS
            .get(bytes.trailing_zeros() as usize)
            .map(|pair| pair[usize::from(*signed)]),
        Kind::F32 => Some(("float32", "f")),
        Kind::F64 => Some(("float64", "d")),
        _ => None,
    }
}
