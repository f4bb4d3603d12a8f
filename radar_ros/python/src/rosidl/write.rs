//! A rosidl object written as CDR: its slots read in the definition's order, numeric arrays in one copy.

use pyo3::{
    prelude::*,
    types::{PyBytes, PyString},
};
use radar_ros::codec::CdrWriter;

use super::{repr, At, Kind, Plan, Shape};

pub(super) fn write_message(
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
            w.elements(element_size(&f.kind), bytes.as_bytes());
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

fn int_name(bytes: usize, signed: bool) -> String {
    format!("{}int{}", if signed { "" } else { "u" }, 8 * bytes)
}

pub(super) fn element_size(kind: &Kind) -> usize {
    match kind {
        Kind::Int { bytes, .. } => *bytes,
        Kind::F32 => 4,
        Kind::F64 => 8,
        _ => 1,
    }
}

/// The `n` elements of a numeric array as their bytes (`tobytes()`, the one copy made), when `v` is a one-dimensional numpy array
/// or an `array.array` whose elements are exactly the field's type (what rosidl stores), on a little-endian
/// host; None for anything else (each element is then written one by one).
fn numeric_bytes<'py>(kind: &Kind, v: &Bound<'py, PyAny>, n: usize) -> Option<Bound<'py, PyBytes>> {
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
    let b = v
        .call_method0("tobytes")
        .ok()?
        .cast_into::<PyBytes>()
        .ok()?;
    (b.as_bytes().len() == n * size).then_some(b)
}
