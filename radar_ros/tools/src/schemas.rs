//! ROS 2 message definitions (`ros2msg`, as rosbag2 stores them in MCAP) for the types the command line
//! records: the definition of the type itself, then each type it uses, after a separator line. Written here for
//! the types radar knows without a ROS installation; any other (radar_msgs too: radar_ros ships its definitions)
//! is read from its definition files ([`radar_ros::codec::schema`]).

const SEPARATOR: &str =
    "================================================================================";

const TIME: &str = "int32 sec\nuint32 nanosec\n";
const HEADER: &str = "builtin_interfaces/Time stamp\nstring frame_id\n";
const POINT: &str = "float64 x\nfloat64 y\nfloat64 z\n";
const QUATERNION: &str = "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n";
const POSE: &str = "Point position\nQuaternion orientation\n";

/// The `ros2msg` schema of `ros_type`, if the command line knows it or finds its definition.
pub fn definition(ros_type: &str) -> Option<String> {
    let (main, deps): (&str, Vec<(&str, &str)>) = match ros_type {
        "std_msgs/msg/Empty" => ("", vec![]),
        "std_msgs/msg/String" => ("string data\n", vec![]),
        "std_msgs/msg/Bool" => ("bool data\n", vec![]),
        "std_msgs/msg/Int32" => ("int32 data\n", vec![]),
        "std_msgs/msg/Int64" => ("int64 data\n", vec![]),
        "std_msgs/msg/Float64" => ("float64 data\n", vec![]),
        "builtin_interfaces/msg/Time" => (TIME, vec![]),
        "std_msgs/msg/Header" => (HEADER, vec![("builtin_interfaces/Time", TIME)]),
        "geometry_msgs/msg/Point" => (POINT, vec![]),
        "geometry_msgs/msg/Quaternion" => (QUATERNION, vec![]),
        "geometry_msgs/msg/Pose" => (
            POSE,
            vec![
                ("geometry_msgs/Point", POINT),
                ("geometry_msgs/Quaternion", QUATERNION),
            ],
        ),
        "geometry_msgs/msg/PoseStamped" => (
            "std_msgs/Header header\nPose pose\n",
            vec![
                ("std_msgs/Header", HEADER),
                ("builtin_interfaces/Time", TIME),
                ("geometry_msgs/Pose", POSE),
                ("geometry_msgs/Point", POINT),
                ("geometry_msgs/Quaternion", QUATERNION),
            ],
        ),
        "test_msgs/action/Fibonacci_Goal" => ("int32 order\n", vec![]),
        "test_msgs/action/Fibonacci_Result" | "test_msgs/action/Fibonacci_Feedback" => {
            ("int32[] sequence\n", vec![])
        }
        _ => return radar_ros::codec::schema(ros_type).ok(),
    };
    let mut text = main.to_owned();
    for (name, def) in deps {
        text.push_str(&format!("{SEPARATOR}\nMSG: {name}\n{def}"));
    }
    Some(text)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_known_type_has_a_definition_with_its_dependencies() {
        for t in crate::codec::known() {
            let d = definition(&t).unwrap_or_else(|| panic!("{t} has no definition"));
            // every type it names is defined after it
            for line in d.lines() {
                let ty = line.split_whitespace().next().unwrap_or("");
                if ty.contains('/') && !line.starts_with("MSG:") {
                    let ty = ty.trim_end_matches("[]");
                    assert!(d.contains(&format!("MSG: {ty}\n")), "{t}: {ty} undefined");
                }
            }
        }
        // a type radar ships the definition of: read from it, every type it uses after it
        let path = definition("nav_msgs/msg/Path").expect("shipped with radar_ros");
        assert!(path.contains("MSG: geometry_msgs/PoseStamped\n"), "{path}");
        assert!(definition("nav2_msgs/msg/Costmap").is_none());
    }
}
