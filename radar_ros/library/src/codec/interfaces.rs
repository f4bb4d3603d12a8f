//! Message types known at run time: their definitions found as every ROS 2 tool finds them
//! (`AMENT_PREFIX_PATH`: `<prefix>/share/<pkg>/msg/<Name>.msg`, `srv/<Name>.srv`, `action/<Name>.action`), or in
//! directories given (`<dir>/<pkg>/msg/<Name>.msg`), read with the `ros2msg` parser, with their nested types
//! across packages. [`Interfaces::encode`] and [`Interfaces::decode`] walk a definition to write and read the
//! payload as CDR (what ROS 2 sends, without the 4-byte encapsulation header, as [`RawMessage`] holds it).
//!
//! ```no_run
//! use radar_ros::codec::Interfaces;
//! let types = Interfaces::from_env();
//! let raw = types.encode("geometry_msgs/msg/Point", &yaml_serde::from_str("{x: 1.0}").unwrap()).unwrap();
//! assert_eq!(types.decode("geometry_msgs/msg/Point", &raw).unwrap()["x"], 1.0);
//! ```

use std::path::PathBuf;

use ros2msg::{Field, Value as Default};
use serde_json::Value;
use yaml_serde::Value as Yaml;

use super::{
    cdr::{Reader, Writer},
    primitives::{
        check_len, fixed, is_octet, is_primitive, primitive_yaml, read_primitive, write_primitive,
        At,
    },
};
use crate::wire::raw::RawMessage;

/// Where definitions are looked for, and those read so far ([`radar_idl::Interfaces`], which it derefs to),
/// with the CDR encoding and decoding of payloads of any type found.
#[derive(Debug)]
pub struct Interfaces {
    defs: radar_idl::Interfaces,
}

impl std::ops::Deref for Interfaces {
    type Target = radar_idl::Interfaces;
    fn deref(&self) -> &radar_idl::Interfaces {
        &self.defs
    }
}

impl Interfaces {
    /// Definitions looked for as ROS 2 tools look: in `share/` of every prefix of `AMENT_PREFIX_PATH`, then in
    /// the interfaces radar_ros ships (std_msgs, builtin_interfaces, geometry_msgs, sensor_msgs, nav_msgs,
    /// std_srvs, action_msgs, unique_identifier_msgs, diagnostic_msgs, service_msgs).
    pub fn from_env() -> Interfaces {
        Interfaces {
            defs: radar_idl::Interfaces::from_env(),
        }
    }

    /// Definitions of the interfaces radar_ros ships only, whatever the environment says.
    pub fn empty() -> Interfaces {
        Interfaces {
            defs: radar_idl::Interfaces::empty(),
        }
    }

    /// Also looks in `dir` (holding `<pkg>/msg/<Name>.msg`, ...), before the others.
    #[must_use]
    pub fn with_dir(self, dir: impl Into<PathBuf>) -> Interfaces {
        self.defs.add_dir(dir);
        self
    }

    /// `value` (a YAML mapping; fields left out take their defaults, as `ros2 topic pub` does) as a CDR message
    /// of `ros_type`. A field that does not exist, or a value of the wrong kind, is an error naming it.
    pub fn encode(&self, ros_type: &str, value: &Yaml) -> Result<RawMessage, String> {
        let mut w = Writer::default();
        self.write_message(&mut w, ros_type, value, &At::Root(ros_type))?;
        Ok(RawMessage::from_bytes(w.finish()))
    }

    /// A CDR message of `ros_type` as JSON.
    pub fn decode(&self, ros_type: &str, raw: &RawMessage) -> Result<Value, String> {
        let mut r = Reader::new(raw.as_bytes());
        let v = self.read_message(&mut r, ros_type)?;
        Ok(v)
    }

    fn write_message(
        &self,
        w: &mut Writer,
        ros_type: &str,
        value: &Yaml,
        path: &At<'_>,
    ) -> Result<(), String> {
        let spec = self.definition(ros_type)?;
        let none = yaml_serde::Mapping::new();
        let given = match value {
            Yaml::Mapping(m) => m,
            Yaml::Null => &none,
            other => {
                return Err(format!(
                    "{path}: a {ros_type} is a mapping of its fields, not {}",
                    yaml_serde::to_string(other).unwrap_or_default().trim()
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
            let at = At::Field(path, &f.name);
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
        at: &At<'_>,
    ) -> Result<(), String> {
        let t = &f.field_type;
        if !t.is_array {
            return self.write_one(w, f, pkg, v, at);
        }
        let items: std::borrow::Cow<'_, [Yaml]> = match v {
            Yaml::Sequence(s) => s.into(),
            // bytes given as a string of characters (byte[] and uint8[] fields)
            Yaml::String(s) if is_octet(t) => s.bytes().map(Yaml::from).collect::<Vec<_>>().into(),
            other => {
                return Err(format!(
                    "{at}: give a list, not {}",
                    yaml_serde::to_string(other).unwrap_or_default().trim()
                ))
            }
        };
        check_len(t, items.len(), at)?;
        if !fixed(t) {
            w.u32(items.len() as u32);
        }
        for (i, item) in items.iter().enumerate() {
            self.write_one(w, f, pkg, item, &At::Index(at, i))?;
        }
        Ok(())
    }

    fn write_default(
        &self,
        w: &mut Writer,
        f: &Field,
        pkg: &str,
        at: &At<'_>,
    ) -> Result<(), String> {
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
                    self.write_one(w, f, pkg, &Yaml::Null, &At::Index(at, i as usize))?;
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
        at: &At<'_>,
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
            let yaml = yaml_serde::from_str("{}").unwrap();
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
