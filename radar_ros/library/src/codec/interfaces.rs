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

use ros2msg::{Field, MessageSpecification, Value as Default};
use serde_json::Value;
use serde_yaml::Value as Yaml;

use super::{
    cdr::{Reader, Writer},
    primitives::{
        check_len, fixed, is_octet, is_primitive, primitive_yaml, read_primitive, write_primitive,
    },
};
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
    /// Definitions looked for as ROS 2 tools look: in `share/` of every prefix of `AMENT_PREFIX_PATH`, then in
    /// the interfaces radar_ros ships (std_msgs, builtin_interfaces, geometry_msgs, sensor_msgs, nav_msgs,
    /// std_srvs, action_msgs, unique_identifier_msgs, diagnostic_msgs).
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

    /// Definitions of the interfaces radar_ros ships only, whatever the environment says.
    pub fn empty() -> Interfaces {
        Interfaces {
            roots: std::sync::RwLock::new(Vec::new()),
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
        let bundled_path = format!("{}/{}/{file}", t.pkg, t.kind);
        let (text, origin) = match looked.iter().find(|p| p.is_file()) {
            Some(path) => (
                std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?,
                path.display().to_string(),
            ),
            None => match super::bundled::find(&bundled_path) {
                Some(text) => (
                    text.to_owned(),
                    format!("radar_ros's bundled {bundled_path}"),
                ),
                None => return Err(not_found(ros_type, t, &file, &looked)),
            },
        };
        let bad = |e: ros2msg::ParseError| format!("{origin}: {e}");
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

/// What to do when `ros_type`'s definition is nowhere: every place looked in, and the bundled packages.
fn not_found(ros_type: &str, t: &TypeName<'_>, file: &str, looked: &[PathBuf]) -> String {
    format!(
        "no definition of {ros_type}: looked in {} and in the interfaces radar_ros ships ({}) (source the ROS 2 \
         installation that has {}, set AMENT_PREFIX_PATH, or give the directory that holds {}/{}/{file})",
        if looked.is_empty() {
            "no directory (AMENT_PREFIX_PATH is not set)".to_owned()
        } else {
            looked
                .iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        },
        super::bundled::packages().join(", "),
        t.pkg,
        t.pkg,
        t.kind
    )
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Bytes from the network are read by this code: whatever they are, decoding ends with a value or an
    /// error, never a panic, and a length field cannot make it allocate what the message does not hold.
    #[test]
    fn hostile_bytes_end_in_an_error_never_a_panic() {
        let types = Interfaces::empty();
        let kinds = [
            "sensor_msgs/msg/LaserScan",
            "nav_msgs/msg/Odometry",
            "diagnostic_msgs/msg/DiagnosticArray",
            "sensor_msgs/msg/PointCloud2",
            "std_msgs/msg/String",
        ];
        let mut seed = 0x2545_f491_4f6c_dd1d_u64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        };
        for ty in kinds {
            // every cut of a valid message, and every byte of it flipped to each of a few values
            let yaml = serde_yaml::from_str("{}").unwrap();
            let good = types.encode(ty, &yaml).unwrap();
            let bytes = good.as_bytes().to_vec();
            for cut in 0..bytes.len() {
                let _ = types.decode(ty, &RawMessage::from_bytes(bytes[..cut].to_vec()));
            }
            for i in 0..bytes.len() {
                for v in [0x00, 0x7f, 0x80, 0xff] {
                    let mut b = bytes.clone();
                    b[i] = v;
                    let _ = types.decode(ty, &RawMessage::from_bytes(b));
                }
            }
            // random messages of random lengths, lengths that claim gigabytes among them
            for _ in 0..2000 {
                let len = (next() % 96) as usize;
                let b: Vec<u8> = (0..len).map(|_| next() as u8).collect();
                let _ = types.decode(ty, &RawMessage::from_bytes(b));
            }
            let huge = RawMessage::from_bytes(vec![0xff; 64]);
            assert!(
                types.decode(ty, &huge).is_err(),
                "{ty}: 0xff... is no message"
            );
        }
    }
}
