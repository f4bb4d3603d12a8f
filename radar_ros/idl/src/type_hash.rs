//! RIHS01 type hashes (REP 2011), computed from a message's definition as rosidl computes them: the type's
//! description (its fields, each with a type id, a capacity, a string capacity and a nested type's name) and the
//! description of every type it uses at any depth (sorted by name), without default values, as JSON with
//! `", "` and `": "` separators, hashed with SHA-256.

use std::collections::BTreeMap;

use ros2msg::{Field, MessageSpecification};
use sha2::{Digest, Sha256};

use crate::{is_primitive, Interfaces};

/// `type_description_interfaces/msg/FieldType`'s id of a primitive type; a `.msg` `char` is a `uint8`
/// (rosidl maps it so).
fn primitive_id(name: &str, string_bound: Option<u32>) -> u8 {
    match (name, string_bound) {
        ("int8", _) => 2,
        ("uint8" | "char", _) => 3,
        ("int16", _) => 4,
        ("uint16", _) => 5,
        ("int32", _) => 6,
        ("uint32", _) => 7,
        ("int64", _) => 8,
        ("uint64", _) => 9,
        ("float32", _) => 10,
        ("float64", _) => 11,
        ("bool", _) => 15,
        ("byte", _) => 16,
        ("string", None) => 17,
        ("wstring", None) => 18,
        ("string", Some(_)) => 21,
        ("wstring", Some(_)) => 22,
        _ => 0,
    }
}

/// A JSON string as Python's `json.dumps` writes it (`ensure_ascii`).
fn quoted(s: &str) -> String {
    let mut out = String::from("\"");
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            c if c.is_ascii() && !c.is_ascii_control() => out.push(c),
            c => {
                let mut buf = [0u16; 2];
                for unit in c.encode_utf16(&mut buf) {
                    out.push_str(&format!("\\u{unit:04x}"));
                }
            }
        }
    }
    out.push('"');
    out
}

impl Interfaces {
    /// The RIHS01 hash of `ros_type` (`RIHS01_<64 hex digits>`), as rosidl writes it in
    /// `share/<pkg>/msg/<Name>.json` and ROS 2 Jazzy announces it in discovery.
    pub fn type_hash(&self, ros_type: &str) -> Result<String, String> {
        let mut referenced = BTreeMap::new();
        let own = self.description(ros_type, &mut referenced)?;
        let refs: Vec<String> = referenced.into_values().collect();
        let text = format!(
            "{{\"type_description\": {own}, \"referenced_type_descriptions\": [{}]}}",
            refs.join(", ")
        );
        let digest = Sha256::digest(text.as_bytes());
        Ok(format!(
            "RIHS01_{}",
            digest
                .iter()
                .map(|b| format!("{b:02x}"))
                .collect::<String>()
        ))
    }

    /// The description of `ros_type` as JSON; the types it uses (at any depth) go into `referenced`.
    fn description(
        &self,
        ros_type: &str,
        referenced: &mut BTreeMap<String, String>,
    ) -> Result<String, String> {
        let spec = self.definition(ros_type)?;
        let mut fields = Vec::new();
        if spec.fields.is_empty() {
            fields.push(field("structure_needs_at_least_one_member", 3, 0, 0, ""));
        }
        for f in &spec.fields {
            fields.push(self.field_description(f, &spec, referenced)?);
        }
        Ok(format!(
            "{{\"type_name\": {}, \"fields\": [{}]}}",
            quoted(ros_type),
            fields.join(", ")
        ))
    }

    fn field_description(
        &self,
        f: &Field,
        spec: &MessageSpecification,
        referenced: &mut BTreeMap<String, String>,
    ) -> Result<String, String> {
        let t = &f.field_type;
        let b = &t.base_type;
        let (base_id, nested) = if is_primitive(&b.type_name) {
            (
                primitive_id(&b.type_name, b.string_upper_bound),
                String::new(),
            )
        } else {
            let nested = self.nested_type(f, &spec.pkg_name);
            if !referenced.contains_key(&nested) {
                // placeholder first: a type met again while its own description is made is not made twice
                referenced.insert(nested.clone(), String::new());
                let d = self.description(&nested, referenced)?;
                referenced.insert(nested.clone(), d);
            }
            (1, nested)
        };
        let (offset, capacity) = match (t.is_array, t.array_size, t.is_upper_bound) {
            (false, _, _) => (0, 0),
            (true, Some(n), false) => (48, n),
            (true, Some(n), true) => (96, n),
            (true, None, _) => (144, 0),
        };
        Ok(field(
            &f.name,
            base_id + offset,
            capacity,
            b.string_upper_bound.unwrap_or(0),
            &nested,
        ))
    }
}

fn field(name: &str, type_id: u8, capacity: u32, string_capacity: u32, nested: &str) -> String {
    format!(
        "{{\"name\": {}, \"type\": {{\"type_id\": {type_id}, \"capacity\": {capacity}, \"string_capacity\": \
         {string_capacity}, \"nested_type_name\": {}}}}}",
        quoted(name),
        quoted(nested)
    )
}
