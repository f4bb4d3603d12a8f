//! ROS 2 interface definitions for radar_ros.
//!
//! - [`Interfaces`]: definitions (`.msg`, `.srv`, `.action`) found as every ROS 2 tool finds them
//!   (`AMENT_PREFIX_PATH`), in directories given, or among the ones shipped here (Jazzy's `std_msgs`,
//!   `builtin_interfaces`, `geometry_msgs`, `sensor_msgs`, `nav_msgs`, `std_srvs`, `action_msgs`,
//!   `unique_identifier_msgs`, `diagnostic_msgs`, `service_msgs`; `interfaces/README.md` says where they came
//!   from), with their nested types across packages, their `ros2msg` schemas as rosbag2 writes them into
//!   MCAP, and their RIHS01 type hashes ([`Interfaces::type_hash`]) as rosidl computes them, also of the types
//!   rosidl makes up around services and actions.
//! - [`rust::Generator`]: Rust types generated from definitions, in a crate's build script, for radar_ros
//!   signals (`radar_ros::msg::RosMessage`), services and actions (`radar_ros::action::Action`).
//!
//! The parser is the registry's [`ros2msg`] (rosidl's rules: constants, defaults, bounded and fixed arrays,
//! bounded strings, comments kept); this crate adds the search, the hashes and the Rust.

mod bundled;
mod definitions;
pub mod rust;
mod type_hash;

pub use bundled::packages as shipped_packages;
pub use definitions::Interfaces;
pub use ros2msg;

/// Whether `name` is a primitive type of the ROS 2 interface language (`bool`, `byte`, `char`, the integers,
/// `float32`, `float64`, `string`, `wstring`); any other field type is a message.
pub fn is_primitive(name: &str) -> bool {
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
