//! The primitive values of a definition: what each ROS type is on the wire and in YAML and JSON, with the
//! range and length checks that say which field is wrong.

use ros2msg::{PrimitiveValue, Type};
use serde_json::Value;
use yaml_serde::Value as Yaml;

use super::cdr::{Reader, Writer};

/// Where in a payload a value is (`geometry_msgs/msg/Pose.position.x`, `...ranges[3]`), for error messages;
/// written out only when one is made. Public for encoders of other value shapes (the Python package's).
#[derive(Clone, Copy, Debug)]
pub enum At<'a> {
    /// The message's type.
    Root(&'a str),
    /// A field of the value at the first.
    Field(&'a At<'a>, &'a str),
    /// An element of the sequence at the first.
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

pub(super) fn fixed(t: &Type) -> bool {
    t.is_array && t.array_size.is_some() && !t.is_upper_bound
}

pub(super) fn is_octet(t: &Type) -> bool {
    matches!(t.base_type.type_name.as_str(), "byte" | "uint8" | "char")
}

pub(super) fn check_len(t: &Type, n: usize, at: &At<'_>) -> Result<(), String> {
    match t.array_size {
        Some(size) if fixed(t) && n != size as usize => {
            Err(format!("{at}: exactly {size} elements, not {n}"))
        }
        Some(bound) if t.is_upper_bound && n > bound as usize => {
            Err(format!("{at}: at most {bound} elements, not {n}"))
        }
        _ => Ok(()),
    }
}

pub(super) use radar_idl::is_primitive;

pub(super) fn primitive_yaml(v: &PrimitiveValue) -> Yaml {
    match v {
        PrimitiveValue::Bool(b) => Yaml::from(*b),
        PrimitiveValue::Int8(x) => Yaml::from(*x),
        PrimitiveValue::UInt8(x) => Yaml::from(*x),
        PrimitiveValue::Int16(x) => Yaml::from(*x),
        PrimitiveValue::UInt16(x) => Yaml::from(*x),
        PrimitiveValue::Int32(x) => Yaml::from(*x),
        PrimitiveValue::UInt32(x) => Yaml::from(*x),
        PrimitiveValue::Int64(x) => Yaml::from(*x),
        PrimitiveValue::UInt64(x) => Yaml::from(*x),
        PrimitiveValue::Float32(x) => Yaml::from(f64::from(*x)),
        PrimitiveValue::Float64(x) => Yaml::from(*x),
        PrimitiveValue::String(s) => Yaml::from(s.clone()),
    }
}

pub(super) fn write_primitive(
    w: &mut Writer,
    ty: &str,
    v: &Yaml,
    at: &At<'_>,
) -> Result<(), String> {
    let wrong = || {
        format!(
            "{at}: {} is no {ty}",
            yaml_serde::to_string(v).unwrap_or_default().trim()
        )
    };
    let int = |lo: i128, hi: i128| -> Result<i128, String> {
        let n: i128 = match v {
            Yaml::Null => 0,
            Yaml::Bool(b) => i128::from(*b),
            Yaml::Number(n) => n
                .as_i64()
                .map(i128::from)
                .or_else(|| n.as_u64().map(i128::from))
                .ok_or_else(wrong)?,
            // a one-character string for a char or byte
            Yaml::String(s) if s.chars().count() == 1 && matches!(ty, "char" | "byte") => {
                i128::from(s.chars().next().map_or(0, |c| c as u32))
            }
            _ => return Err(wrong()),
        };
        if n < lo || n > hi {
            return Err(format!("{at}: {n} is out of a {ty}'s range {lo}..={hi}"));
        }
        Ok(n)
    };
    let float = || -> Result<f64, String> {
        match v {
            Yaml::Null => Ok(0.0),
            Yaml::Number(n) => n.as_f64().ok_or_else(wrong),
            _ => Err(wrong()),
        }
    };
    match ty {
        "bool" => match v {
            Yaml::Null => w.u8(0),
            Yaml::Bool(b) => w.u8(u8::from(*b)),
            _ => return Err(wrong()),
        },
        "byte" | "char" | "uint8" => w.u8(int(0, 255)? as u8),
        "int8" => w.u8(int(-128, 127)? as i8 as u8),
        "int16" => w.u16(int(i16::MIN.into(), i16::MAX.into())? as i16 as u16),
        "uint16" => w.u16(int(0, u16::MAX.into())? as u16),
        "int32" => w.u32(int(i32::MIN.into(), i32::MAX.into())? as i32 as u32),
        "uint32" => w.u32(int(0, u32::MAX.into())? as u32),
        "int64" => w.u64(int(i64::MIN.into(), i64::MAX.into())? as i64 as u64),
        "uint64" => w.u64(int(0, u64::MAX.into())? as u64),
        "float32" => w.u32((float()? as f32).to_bits()),
        "float64" => w.u64(float()?.to_bits()),
        "string" | "wstring" => {
            let s: std::borrow::Cow<'_, str> = match v {
                Yaml::Null => "".into(),
                Yaml::String(s) => s.as_str().into(),
                Yaml::Number(n) => n.to_string().into(),
                Yaml::Bool(b) => b.to_string().into(),
                _ => return Err(wrong()),
            };
            if ty == "string" {
                w.string(&s);
            } else {
                w.wstring(&s);
            }
        }
        _ => return Err(wrong()),
    }
    Ok(())
}

pub(super) fn read_primitive(r: &mut Reader<'_>, ty: &str) -> Result<Value, String> {
    Ok(match ty {
        "bool" => Value::from(r.u8()? != 0),
        "byte" | "char" | "uint8" => Value::from(r.u8()?),
        "int8" => Value::from(r.u8()? as i8),
        "int16" => Value::from(r.u16()? as i16),
        "uint16" => Value::from(r.u16()?),
        "int32" => Value::from(r.u32()? as i32),
        "uint32" => Value::from(r.u32()?),
        "int64" => Value::from(r.u64()? as i64),
        "uint64" => Value::from(r.u64()?),
        "float32" => Value::from(f64::from(f32::from_bits(r.u32()?))),
        "float64" => Value::from(f64::from_bits(r.u64()?)),
        "string" => Value::from(r.string()?),
        "wstring" => Value::from(r.wstring()?),
        other => return Err(format!("{other} is no primitive type")),
    })
}
