//! Payloads as people write them: YAML in (as `ros2 topic pub` takes them), JSON or YAML out (the `codec`
//! feature; the `radar` command line and the Python package use it): for the message types radar_ros knows, and
//! for any other whose definition is found at run time ([`Interfaces`]: `AMENT_PREFIX_PATH` as ROS 2 tools
//! read it). A type whose definition is nowhere is shown as its size in bytes.

mod cdr;
mod interfaces;
mod primitives;

pub use cdr::{Reader as CdrReader, Writer as CdrWriter};
pub use interfaces::Interfaces;
pub use primitives::At;

use crate::{
    action::{FibonacciFeedback, FibonacciGoal, FibonacciResult},
    msg::{
        Bool, Connection, ConnectionList, Empty, EventState, Float64, Header, Int32, Int64, Point,
        Pose, PoseStamped, Quaternion, ResponseState, RosMessage, StringMsg, Time,
    },
    wire::raw::RawMessage,
};
use serde_json::Value;

/// Calls `$m!(Type)` for every known message type.
macro_rules! known_types {
    ($m:ident) => {
        $m!(Empty);
        $m!(StringMsg);
        $m!(Bool);
        $m!(Int32);
        $m!(Int64);
        $m!(Float64);
        $m!(Time);
        $m!(Header);
        $m!(Point);
        $m!(Quaternion);
        $m!(Pose);
        $m!(PoseStamped);
        $m!(ResponseState);
        $m!(EventState);
        $m!(Connection);
        $m!(ConnectionList);
        $m!(FibonacciGoal);
        $m!(FibonacciResult);
        $m!(FibonacciFeedback);
    };
}

/// The ROS names of the types the command line can read and write.
pub fn known() -> Vec<String> {
    let mut v = Vec::new();
    macro_rules! name {
        ($t:ty) => {
            v.push(<$t>::ros_type_name());
        };
    }
    known_types!(name);
    v
}

/// `yaml` (empty: the type's default) as a CDR message of `ros_type`.
pub fn encode(ros_type: &str, yaml: &str) -> Result<RawMessage, String> {
    let yaml = if yaml.trim().is_empty() { "{}" } else { yaml };
    macro_rules! try_type {
        ($t:ty) => {
            if ros_type == <$t>::ros_type_name() {
                if <$t>::ros_type_name() == Empty::ros_type_name() {
                    if !matches!(yaml.trim(), "{}" | "") {
                        return Err(format!("{ros_type} carries nothing; leave the payload out"));
                    }
                    return RawMessage::encode(&Empty::default()).map_err(|e| e.to_string());
                }
                let m: $t = from_yaml(yaml).map_err(|e| {
                    format!("the payload is not a {ros_type}: {e} (write it as YAML, e.g. \"{{data: kitchen}}\")")
                })?;
                return RawMessage::encode(&m).map_err(|e| e.to_string());
            }
        };
    }
    known_types!(try_type);
    let given: yaml_serde::Value = yaml_serde::from_str(yaml)
        .map_err(|e| format!("the payload is not YAML: {e} (e.g. \"{{data: kitchen}}\")"))?;
    run_time_types().encode(ros_type, &given)
}

/// Whether payloads of `ros_type` convert to and from YAML and JSON here: a known type, or one whose definition
/// is found ([`Interfaces`]).
pub fn has_dict_form(ros_type: &str) -> bool {
    known().iter().any(|t| t == ros_type) || run_time_types().definition(ros_type).is_ok()
}

/// Looks for definitions in `dir` too (holding `<pkg>/msg/<Name>.msg`, `srv/`, `action/`), before
/// `AMENT_PREFIX_PATH`: a package of a program's own that is not installed (`radar --interfaces DIR`).
pub fn add_interfaces_dir(dir: impl Into<std::path::PathBuf>) {
    run_time_types().add_dir(dir);
}

/// The `ros2msg` schema (as rosbag2 stores it in MCAP) of a type found at run time ([`radar_idl::Interfaces::schema`]).
pub fn schema(ros_type: &str) -> Result<String, String> {
    run_time_types().schema(ros_type)
}

/// The types found at run time ([`Interfaces`]: known, shipped, or on `AMENT_PREFIX_PATH` as it was when first
/// asked, plus the directories given to [`add_interfaces_dir`]): what [`encode`] and [`decode`] use for any
/// type they do not know, read once per type.
pub fn run_time_types() -> &'static Interfaces {
    static TYPES: std::sync::OnceLock<Interfaces> = std::sync::OnceLock::new();
    TYPES.get_or_init(Interfaces::from_env)
}

/// Fields left out of the YAML take their default (as `ros2 topic pub` does).
fn from_yaml<T: serde::de::DeserializeOwned + serde::Serialize + Default>(
    yaml: &str,
) -> Result<T, String> {
    let given: yaml_serde::Value = yaml_serde::from_str(yaml).map_err(|e| e.to_string())?;
    let mut full = yaml_serde::to_value(T::default()).map_err(|e| e.to_string())?;
    merge(&mut full, given)?;
    yaml_serde::from_value(full).map_err(|e| e.to_string())
}

fn merge(into: &mut yaml_serde::Value, given: yaml_serde::Value) -> Result<(), String> {
    match (into, given) {
        (yaml_serde::Value::Mapping(a), yaml_serde::Value::Mapping(b)) => {
            for (k, v) in b {
                match a.get_mut(&k) {
                    Some(slot) => merge(slot, v)?,
                    None => {
                        return Err(format!(
                            "no field {}",
                            yaml_serde::to_string(&k).unwrap_or_default().trim()
                        ))
                    }
                }
            }
            Ok(())
        }
        (slot, v) => {
            *slot = v;
            Ok(())
        }
    }
}

/// A CDR message of `ros_type` as JSON (`{"bytes": n}` for a type radar does not know).
pub fn decode(ros_type: &str, raw: &RawMessage) -> Value {
    macro_rules! try_type {
        ($t:ty) => {
            if ros_type == <$t>::ros_type_name() {
                return match raw.decode::<$t>() {
                    Ok(m) if <$t>::ros_type_name() == Empty::ros_type_name() => {
                        let _ = m;
                        Value::Object(Default::default())
                    }
                    Ok(m) => serde_json::to_value(&m).unwrap_or(Value::Null),
                    Err(e) => serde_json::json!({ "undecodable": e.to_string(), "bytes": raw.len() }),
                };
            }
        };
    }
    known_types!(try_type);
    let types = run_time_types();
    match types.definition(ros_type) {
        Err(_) => serde_json::json!({ "bytes": raw.len() }),
        Ok(_) => types
            .decode(ros_type, raw)
            .unwrap_or_else(|e| serde_json::json!({ "undecodable": e, "bytes": raw.len() })),
    }
}

/// A JSON payload as one line of flow-style YAML, as the timeline prints it.
pub fn inline(v: &Value) -> String {
    match v {
        Value::Object(m) if m.is_empty() => String::new(),
        _ => v.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn yaml_payloads_encode_and_decode_back() {
        let raw = encode("std_msgs/msg/String", "{data: kitchen}").unwrap();
        assert_eq!(decode("std_msgs/msg/String", &raw)["data"], "kitchen");
        let raw = encode("test_msgs/action/Fibonacci_Goal", "{order: 5}").unwrap();
        assert_eq!(decode("test_msgs/action/Fibonacci_Goal", &raw)["order"], 5);
        // fields left out take their defaults
        let raw = encode(
            "geometry_msgs/msg/PoseStamped",
            "{pose: {position: {x: 1.5}}}",
        )
        .unwrap();
        let v = decode("geometry_msgs/msg/PoseStamped", &raw);
        assert_eq!(v["pose"]["position"]["x"], 1.5);
        assert_eq!(v["header"]["frame_id"], "");
        assert_eq!(encode("std_msgs/msg/Empty", "").unwrap().len(), 1);
        assert!(encode("std_msgs/msg/Empty", "{data: 3}").is_err());
    }

    #[test]
    fn bad_payloads_say_what_to_write() {
        let e = encode("std_msgs/msg/Int32", "{data: many}").unwrap_err();
        assert!(e.contains("not a std_msgs/msg/Int32"), "{e}");
        let e = encode("std_msgs/msg/Int32", "{value: 3}").unwrap_err();
        assert!(e.contains("no field value"), "{e}");
        // a type found nowhere: named, with every place looked in and the packages radar_ros ships
        let e = encode("nav2_msgs/msg/Costmap", "{}").unwrap_err();
        assert!(
            e.contains("nav2_msgs/msg/Costmap") && e.contains("sensor_msgs"),
            "{e}"
        );
        // one radar_ros ships, though not one of its hand-written types
        assert!(encode(
            "nav_msgs/msg/Path",
            "{poses: [{pose: {position: {x: 1.0}}}]}"
        )
        .is_ok());
    }
}
