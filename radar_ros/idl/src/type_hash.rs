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
    /// `share/<pkg>/msg/<Name>.json` and ROS 2 Jazzy announces it in discovery: a message, a part of a service
    /// or action, or a type rosidl makes up around them (`pkg/srv/Name` as a whole, `Name_Event`,
    /// `pkg/action/Name`, `Name_SendGoal`, `Name_FeedbackMessage`, ...).
    ///
    /// ```
    /// let shipped = radar_idl::Interfaces::empty();
    /// assert!(shipped.type_hash("std_srvs/srv/SetBool").unwrap().starts_with("RIHS01_"));
    /// ```
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
        if let Some(made_up) = made_up(ros_type) {
            let mut fields = Vec::new();
            for (name, type_id, capacity, nested) in made_up {
                if !nested.is_empty() {
                    self.reference(&nested, referenced)?;
                }
                fields.push(field(name, type_id, capacity, 0, &nested));
            }
            return Ok(format!(
                "{{\"type_name\": {}, \"fields\": [{}]}}",
                quoted(ros_type),
                fields.join(", ")
            ));
        }
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

    /// Adds the description of `nested` (and of what it uses) to `referenced`, once.
    fn reference(
        &self,
        nested: &str,
        referenced: &mut BTreeMap<String, String>,
    ) -> Result<(), String> {
        if !referenced.contains_key(nested) {
            // placeholder first: a type met again while its own description is made is not made twice
            referenced.insert(nested.to_owned(), String::new());
            let d = self.description(nested, referenced)?;
            referenced.insert(nested.to_owned(), d);
        }
        Ok(())
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
            self.reference(&nested, referenced)?;
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

/// A field of a type rosidl makes up around a service or an action: its name, type id, capacity and nested type.
type MadeUpField = (&'static str, u8, u32, String);

/// The fields of a type that no file defines but rosidl makes up (rosidl_generator_type_description), if
/// `ros_type` is one: a service as a whole (`pkg/srv/Name`: its request, response and event messages), a
/// service's event (`Name_Event`: `service_msgs/msg/ServiceEventInfo` and at most one request and one response),
/// an action as a whole (`pkg/action/Name`), its two services (`Name_SendGoal`, `Name_GetResult`) with their
/// requests, responses and events, and its feedback message (`Name_FeedbackMessage`). Each is as the JSON
/// rosidl writes beside the definition has it (`share/<pkg>/<srv|action>/<Name>.json`).
fn made_up(ros_type: &str) -> Option<Vec<MadeUpField>> {
    let (pkg, kind, name) = {
        let mut parts = ros_type.split('/');
        (parts.next()?, parts.next()?, parts.next()?)
    };
    match kind {
        "srv" if name.ends_with("_Request") || name.ends_with("_Response") => None,
        "srv" => Some(match name.strip_suffix("_Event") {
            Some(base) => made_up_event(&format!("{pkg}/srv/{base}")),
            None => made_up_service(&format!("{pkg}/srv/{name}")),
        }),
        "action" => made_up_action(pkg, name),
        _ => None,
    }
}

/// A field of a nested type (type id 1).
const NESTED: u8 = 1;
/// What a type id adds for a bounded sequence.
const BOUNDED_SEQUENCE: u8 = 96;
const UUID: &str = "unique_identifier_msgs/msg/UUID";

fn nested(field: &'static str, ty: String) -> MadeUpField {
    (field, NESTED, 0, ty)
}

/// A service as a whole (`prefix` is `pkg/srv/Name` or `pkg/action/Name_SendGoal`): its request, response and
/// event messages.
fn made_up_service(prefix: &str) -> Vec<MadeUpField> {
    vec![
        nested("request_message", format!("{prefix}_Request")),
        nested("response_message", format!("{prefix}_Response")),
        nested("event_message", format!("{prefix}_Event")),
    ]
}

/// A service's event: `service_msgs/msg/ServiceEventInfo` and at most one request and one response.
fn made_up_event(prefix: &str) -> Vec<MadeUpField> {
    let at_most_one = |field, ty| (field, NESTED + BOUNDED_SEQUENCE, 1, ty);
    vec![
        nested("info", "service_msgs/msg/ServiceEventInfo".to_owned()),
        at_most_one("request", format!("{prefix}_Request")),
        at_most_one("response", format!("{prefix}_Response")),
    ]
}

/// An action's made-up types: the action as a whole, its two services with their requests, responses and
/// events, its feedback message (`None` for the .action file's own parts: `_Goal`, `_Result`, `_Feedback`).
fn made_up_action(pkg: &str, name: &str) -> Option<Vec<MadeUpField>> {
    const PARTS: [&str; 12] = [
        "_SendGoal_Request",
        "_SendGoal_Response",
        "_SendGoal_Event",
        "_GetResult_Request",
        "_GetResult_Response",
        "_GetResult_Event",
        "_SendGoal",
        "_GetResult",
        "_FeedbackMessage",
        "_Goal",
        "_Result",
        "_Feedback",
    ];
    let own = |suffix: &str| format!("{pkg}/action/{name}{suffix}");
    let (base, part) = PARTS
        .iter()
        .find_map(|p| Some((name.strip_suffix(p)?, *p)))
        .unwrap_or((name, ""));
    let of = |suffix: &str| format!("{pkg}/action/{base}{suffix}");
    Some(match part {
        "" => vec![
            nested("goal", own("_Goal")),
            nested("result", own("_Result")),
            nested("feedback", own("_Feedback")),
            nested("send_goal_service", own("_SendGoal")),
            nested("get_result_service", own("_GetResult")),
            nested("feedback_message", own("_FeedbackMessage")),
        ],
        "_SendGoal" | "_GetResult" => made_up_service(&own("")),
        "_SendGoal_Event" | "_GetResult_Event" => {
            made_up_event(&format!("{pkg}/action/{}", name.strip_suffix("_Event")?))
        }
        "_SendGoal_Request" => {
            vec![nested("goal_id", UUID.into()), nested("goal", of("_Goal"))]
        }
        "_SendGoal_Response" => vec![
            ("accepted", 15, 0, String::new()),
            nested("stamp", "builtin_interfaces/msg/Time".into()),
        ],
        "_GetResult_Request" => vec![nested("goal_id", UUID.into())],
        "_GetResult_Response" => vec![
            ("status", 2, 0, String::new()),
            nested("result", of("_Result")),
        ],
        "_FeedbackMessage" => vec![
            nested("goal_id", UUID.into()),
            nested("feedback", of("_Feedback")),
        ],
        // _Goal, _Result, _Feedback: the .action file's parts
        _ => return None,
    })
}

fn field(name: &str, type_id: u8, capacity: u32, string_capacity: u32, nested: &str) -> String {
    format!(
        "{{\"name\": {}, \"type\": {{\"type_id\": {type_id}, \"capacity\": {capacity}, \"string_capacity\": \
         {string_capacity}, \"nested_type_name\": {}}}}}",
        quoted(name),
        quoted(nested)
    )
}
