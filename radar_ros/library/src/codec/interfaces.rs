//! Message types known at run time: their definitions found as every ROS 2 tool finds them
//! (`AMENT_PREFIX_PATH`: `<prefix>/share/<pkg>/msg/<Name>.msg`, `srv/<Name>.srv`, `action/<Name>.action`), or in
//! directories given (`<dir>/<pkg>/msg/<Name>.msg`), read with the `ros2msg` parser, with their nested types
//! across packages. [`Interfaces::encode`] and [`Interfaces::decode`] walk a definition to write and read the
//! payload as CDR (what ROS 2 sends, without the 4-byte encapsulation header, as [`RawMessage`] holds it).
//!
//! ```no_run
//! use radar_ros::codec::Interfaces;
//! let types = Interfaces::from_env();
//! let raw = types.encode("geometry_msgs/msg/Point", &serde_yaml::from_str("{x: 1.0}").unwrap()).unwrap();
//! assert_eq!(types.decode("geometry_msgs/msg/Point", &raw).unwrap()["x"], 1.0);
//! ```

use std::{
    collections::HashMap,
    path::PathBuf,
    sync::{Arc, Mutex},
};

use ros2msg::{Field, MessageSpecification, PrimitiveValue, Type, Value as Default};
use serde_json::Value;
use serde_yaml::Value as Yaml;

use super::cdr::{Reader, Writer};
use crate::RawMessage;

/// Where definitions are looked for, and those read so far.
pub struct Interfaces {
    /// Directories holding `<pkg>/msg/<Name>.msg` (and `srv/`, `action/`), in the order looked in.
    roots: std::sync::RwLock<Vec<PathBuf>>,
    /// Each type read so far: its definition, and its text as written (for schemas).
    read: Mutex<HashMap<String, Read>>,
}

/// A type read: its definition, and its text as written.
type Read = (Arc<MessageSpecification>, Arc<str>);

impl std::fmt::Debug for Interfaces {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Interfaces")
            .field("roots", &*self.roots.read().unwrap())
            .finish()
    }
}

/// A type name taken apart: `pkg/msg/Name`, `pkg/srv/Name_Request`, `pkg/action/Name_Goal`, or a field's
/// `pkg/Name` (a message).
struct TypeName<'a> {
    pkg: &'a str,
    kind: &'a str,
    name: &'a str,
}

fn split(ros_type: &str) -> Result<TypeName<'_>, String> {
    let parts: Vec<&str> = ros_type.split('/').collect();
    match parts[..] {
        [pkg, kind @ ("msg" | "srv" | "action"), name] => Ok(TypeName { pkg, kind, name }),
        [pkg, name] => Ok(TypeName {
            pkg,
            kind: "msg",
            name,
        }),
        _ => Err(format!(
            "{ros_type} is no ROS type name: write it as pkg/msg/Name (or pkg/srv/Name_Request, pkg/action/Name_Goal)"
        )),
    }
}

impl Interfaces {
    /// Definitions looked for as ROS 2 tools look: in `share/` of every prefix of `AMENT_PREFIX_PATH`.
    pub fn from_env() -> Interfaces {
        let roots = std::env::var_os("AMENT_PREFIX_PATH")
            .map(|p| {
                std::env::split_paths(&p)
                    .map(|prefix| prefix.join("share"))
                    .collect()
            })
            .unwrap_or_default();
        Interfaces {
            roots: std::sync::RwLock::new(roots),
            read: Mutex::new(HashMap::new()),
        }
    }

    /// Also looks in `dir` (holding `<pkg>/msg/<Name>.msg`, ...), before the others.
    #[must_use]
    pub fn with_dir(self, dir: impl Into<PathBuf>) -> Interfaces {
        self.add_dir(dir);
        self
    }

    /// Looks in `dir` too (holding `<pkg>/msg/<Name>.msg`, ...), before the others, from now on. Types read
    /// already stay as they were read.
    pub fn add_dir(&self, dir: impl Into<PathBuf>) {
        self.roots.write().unwrap().insert(0, dir.into());
    }

    /// The definition of `ros_type`, read once.
    pub fn definition(&self, ros_type: &str) -> Result<Arc<MessageSpecification>, String> {
        self.read_once(ros_type).map(|(spec, _)| spec)
    }

    fn read_once(&self, ros_type: &str) -> Result<Read, String> {
        if let Some(s) = self.read.lock().unwrap().get(ros_type) {
            return Ok(s.clone());
        }
        let t = split(ros_type)?;
        let (spec, text) = self.read_definition(ros_type, &t)?;
        let read = (Arc::new(spec), Arc::<str>::from(text));
        self.read
            .lock()
            .unwrap()
            .insert(ros_type.to_owned(), read.clone());
        Ok(read)
    }

    /// The `ros2msg` schema of `ros_type` as rosbag2 stores it in MCAP: its definition as written, then each
    /// type it uses (at any depth, once), after a separator line and `MSG: pkg/Name`.
    pub fn schema(&self, ros_type: &str) -> Result<String, String> {
        const SEPARATOR: &str =
            "================================================================================";
        let (_, text) = self.read_once(ros_type)?;
        let mut out = text.to_string();
        let mut seen = std::collections::BTreeSet::new();
        let mut todo = self.nested_of(ros_type)?;
        while let Some(t) = todo.pop() {
            if !seen.insert(t.clone()) {
                continue;
            }
            let (_, text) = self.read_once(&t)?;
            let short = t.replacen("/msg/", "/", 1);
            out.push_str(&format!("{SEPARATOR}\nMSG: {short}\n{text}"));
            let mut more = self.nested_of(&t)?;
            more.reverse();
            todo.extend(more);
        }
        Ok(out)
    }

    /// The message types the fields of `ros_type` use, in field order (last first, to pop).
    fn nested_of(&self, ros_type: &str) -> Result<Vec<String>, String> {
        let spec = self.definition(ros_type)?;
        let mut v: Vec<String> = spec
            .fields
            .iter()
            .filter(|f| !is_primitive(&f.field_type.base_type.type_name))
            .map(|f| self.nested_type(f, &spec.pkg_name))
            .collect();
        v.reverse();
        Ok(v)
    }

    fn read_definition(
        &self,
        ros_type: &str,
        t: &TypeName<'_>,
    ) -> Result<(MessageSpecification, String), String> {
        let (file, part) = match t.kind {
            "srv" => split_part(t.name, &["_Request", "_Response"], "srv", ros_type)?,
            "action" => split_part(
                t.name,
                &["_Goal", "_Result", "_Feedback"],
                "action",
                ros_type,
            )?,
            _ => (format!("{}.msg", t.name), ""),
        };
        let looked: Vec<PathBuf> = self
            .roots
            .read()
            .unwrap()
            .iter()
            .map(|r| r.join(t.pkg).join(t.kind).join(&file))
            .collect();
        let Some(path) = looked.iter().find(|p| p.is_file()) else {
            return Err(format!(
                "no definition of {ros_type}: looked in {} (source the ROS 2 installation that has {}, set \
                 AMENT_PREFIX_PATH, or give the directory that holds {}/{}/{file})",
                if looked.is_empty() {
                    "no directory: AMENT_PREFIX_PATH is not set".to_owned()
                } else {
                    looked
                        .iter()
                        .map(|p| p.display().to_string())
                        .collect::<Vec<_>>()
                        .join(", ")
                },
                t.pkg,
                t.pkg,
                t.kind
            ));
        };
        let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
        let bad = |e: ros2msg::ParseError| format!("{}: {e}", path.display());
        let base = file.rsplit_once('.').map_or(file.as_str(), |(b, _)| b);
        let section = |i: usize| {
            text.split("\n---")
                .nth(i)
                .map(|s| s.trim_start_matches('\n').to_owned())
                .unwrap_or_default()
        };
        Ok(match (t.kind, part) {
            ("srv", p) => {
                let s = ros2msg::parse_service_string(t.pkg, base, &text).map_err(bad)?;
                if p == "_Request" {
                    (s.request, section(0))
                } else {
                    (s.response, section(1))
                }
            }
            ("action", p) => {
                let a = ros2msg::parse_action_string(t.pkg, base, &text).map_err(bad)?;
                match p {
                    "_Goal" => (a.goal, section(0)),
                    "_Result" => (a.result, section(1)),
                    _ => (a.feedback, section(2)),
                }
            }
            _ => (
                ros2msg::parse_message_string(t.pkg, t.name, &text).map_err(bad)?,
                text.clone(),
            ),
        })
    }

    /// `value` (a YAML mapping; fields left out take their defaults, as `ros2 topic pub` does) as a CDR message
    /// of `ros_type`. A field that does not exist, or a value of the wrong kind, is an error naming it.
    pub fn encode(&self, ros_type: &str, value: &Yaml) -> Result<RawMessage, String> {
        let mut w = Writer::default();
        self.write_message(&mut w, ros_type, value, ros_type)?;
        Ok(RawMessage::from_bytes(w.finish()))
    }

    /// A CDR message of `ros_type` as JSON.
    pub fn decode(&self, ros_type: &str, raw: &RawMessage) -> Result<Value, String> {
        let mut r = Reader::new(raw.as_bytes());
        let v = self.read_message(&mut r, ros_type)?;
        Ok(v)
    }

    pub(super) fn nested_type(&self, field: &Field, in_pkg: &str) -> String {
        let b = &field.field_type.base_type;
        format!(
            "{}/msg/{}",
            b.pkg_name.as_deref().unwrap_or(in_pkg),
            b.type_name
        )
    }

    fn write_message(
        &self,
        w: &mut Writer,
        ros_type: &str,
        value: &Yaml,
        path: &str,
    ) -> Result<(), String> {
        let spec = self.definition(ros_type)?;
        let given = match value {
            Yaml::Mapping(m) => m.clone(),
            Yaml::Null => serde_yaml::Mapping::new(),
            other => {
                return Err(format!(
                    "{path}: a {ros_type} is a mapping of its fields, not {}",
                    serde_yaml::to_string(other).unwrap_or_default().trim()
                ))
            }
        };
        for k in given.keys() {
            let k = k.as_str().unwrap_or_default();
            if !spec.fields.iter().any(|f| f.name == k) {
                return Err(format!(
                    "{path}: {ros_type} has no field {k:?}; its fields: {}",
                    spec.fields
                        .iter()
                        .map(|f| f.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ));
            }
        }
        if spec.fields.is_empty() {
            w.u8(0); // an empty structure is one byte on the wire
        }
        for f in &spec.fields {
            let at = format!("{path}.{}", f.name);
            match given.get(f.name.as_str()) {
                Some(v) => self.write_field(w, f, &spec.pkg_name, v, &at)?,
                None => self.write_default(w, f, &spec.pkg_name, &at)?,
            }
        }
        Ok(())
    }

    fn write_field(
        &self,
        w: &mut Writer,
        f: &Field,
        pkg: &str,
        v: &Yaml,
        at: &str,
    ) -> Result<(), String> {
        let t = &f.field_type;
        if !t.is_array {
            return self.write_one(w, f, pkg, v, at);
        }
        let items: Vec<Yaml> = match v {
            Yaml::Sequence(s) => s.clone(),
            // bytes given as a string of characters (byte[] and uint8[] fields)
            Yaml::String(s) if is_octet(t) => s.bytes().map(Yaml::from).collect(),
            other => {
                return Err(format!(
                    "{at}: give a list, not {}",
                    serde_yaml::to_string(other).unwrap_or_default().trim()
                ))
            }
        };
        check_len(t, items.len(), at)?;
        if !fixed(t) {
            w.u32(items.len() as u32);
        }
        for (i, item) in items.iter().enumerate() {
            self.write_one(w, f, pkg, item, &format!("{at}[{i}]"))?;
        }
        Ok(())
    }

    fn write_default(&self, w: &mut Writer, f: &Field, pkg: &str, at: &str) -> Result<(), String> {
        let t = &f.field_type;
        match (&f.default_value, t.is_array) {
            (Some(Default::Array(values)), true) => {
                if !fixed(t) {
                    w.u32(values.len() as u32);
                }
                for v in values {
                    write_primitive(w, &t.base_type.type_name, &primitive_yaml(v), at)?;
                }
                Ok(())
            }
            (Some(Default::Primitive(v)), false) => {
                write_primitive(w, &t.base_type.type_name, &primitive_yaml(v), at)
            }
            (_, true) if fixed(t) => {
                for i in 0..t.array_size.unwrap_or(0) {
                    self.write_one(w, f, pkg, &Yaml::Null, &format!("{at}[{i}]"))?;
                }
                Ok(())
            }
            (_, true) => {
                w.u32(0);
                Ok(())
            }
            (_, false) => self.write_one(w, f, pkg, &Yaml::Null, at),
        }
    }

    /// One value of the field's base type; `Null`: its zero value.
    fn write_one(
        &self,
        w: &mut Writer,
        f: &Field,
        pkg: &str,
        v: &Yaml,
        at: &str,
    ) -> Result<(), String> {
        let b = &f.field_type.base_type;
        if is_primitive(&b.type_name) {
            if let (Some(bound), Yaml::String(s)) = (b.string_upper_bound, v) {
                let len = if b.type_name == "wstring" {
                    s.chars().count()
                } else {
                    s.len()
                };
                if len > bound as usize {
                    return Err(format!("{at}: at most {bound} characters, not {len}"));
                }
            }
            return write_primitive(w, &b.type_name, v, at);
        }
        self.write_message(w, &self.nested_type(f, pkg), v, at)
    }

    fn read_message(&self, r: &mut Reader<'_>, ros_type: &str) -> Result<Value, String> {
        let spec = self.definition(ros_type)?;
        let mut out = serde_json::Map::new();
        if spec.fields.is_empty() {
            r.u8()?;
        }
        for f in &spec.fields {
            let t = &f.field_type;
            let v = if t.is_array {
                let n = if fixed(t) {
                    t.array_size.unwrap_or(0) as usize
                } else {
                    r.u32()? as usize
                };
                if n > r.remaining() {
                    return Err(format!(
                        "{}: {n} elements in {} bytes",
                        f.name,
                        r.remaining()
                    ));
                }
                let mut items = Vec::with_capacity(n);
                for _ in 0..n {
                    items.push(self.read_one(r, f, &spec.pkg_name)?);
                }
                Value::Array(items)
            } else {
                self.read_one(r, f, &spec.pkg_name)?
            };
            out.insert(f.name.clone(), v);
        }
        Ok(Value::Object(out))
    }

    fn read_one(&self, r: &mut Reader<'_>, f: &Field, pkg: &str) -> Result<Value, String> {
        let b = &f.field_type.base_type;
        if is_primitive(&b.type_name) {
            return read_primitive(r, &b.type_name);
        }
        self.read_message(r, &self.nested_type(f, pkg))
    }
}

/// `Name_Request` -> (`Name.srv`, `_Request`).
fn split_part<'a>(
    name: &str,
    parts: &[&'a str],
    ext: &str,
    ros_type: &str,
) -> Result<(String, &'a str), String> {
    parts
        .iter()
        .find_map(|p| {
            name.strip_suffix(p)
                .map(|base| (format!("{base}.{ext}"), *p))
        })
        .ok_or_else(|| {
            format!(
                "{ros_type}: a {ext} type is one of its parts ({})",
                parts.join(", ")
            )
        })
}

fn fixed(t: &Type) -> bool {
    t.is_array && t.array_size.is_some() && !t.is_upper_bound
}

fn is_octet(t: &Type) -> bool {
    matches!(t.base_type.type_name.as_str(), "byte" | "uint8" | "char")
}

fn check_len(t: &Type, n: usize, at: &str) -> Result<(), String> {
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

pub(super) fn is_primitive(name: &str) -> bool {
    matches!(
        name,
        "bool"
            | "byte"
            | "char"
            | "float32"
            | "float64"
            | "int8"
            | "uint8"
            | "int16"
            | "uint16"
            | "int32"
            | "uint32"
            | "int64"
            | "uint64"
            | "string"
            | "wstring"
    )
}

fn primitive_yaml(v: &PrimitiveValue) -> Yaml {
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

fn write_primitive(w: &mut Writer, ty: &str, v: &Yaml, at: &str) -> Result<(), String> {
    let wrong = || {
        format!(
            "{at}: {} is no {ty}",
            serde_yaml::to_string(v).unwrap_or_default().trim()
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
            let s = match v {
                Yaml::Null => String::new(),
                Yaml::String(s) => s.clone(),
                Yaml::Number(n) => n.to_string(),
                Yaml::Bool(b) => b.to_string(),
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

fn read_primitive(r: &mut Reader<'_>, ty: &str) -> Result<Value, String> {
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
