//! The interface definitions radar_ros ships (`radar_ros/idl/interfaces/`: std_msgs, builtin_interfaces,
//! geometry_msgs, sensor_msgs, nav_msgs, std_srvs, action_msgs, unique_identifier_msgs, diagnostic_msgs,
//! service_msgs, as the ROS 2 Jazzy packages install them), for a machine without a ROS installation: looked in after
//! `AMENT_PREFIX_PATH` and the directories given.

include!(concat!(env!("OUT_DIR"), "/bundled_interfaces.rs"));

/// The text of `pkg/kind/Name.ext`, if radar_ros ships it.
pub(crate) fn find(path: &str) -> Option<&'static str> {
    BUNDLED
        .binary_search_by(|(p, _)| (*p).cmp(path))
        .ok()
        .map(|i| BUNDLED[i].1)
}

/// The packages shipped: std_msgs, builtin_interfaces, geometry_msgs, ... (sorted).
pub fn packages() -> Vec<&'static str> {
    let mut v: Vec<&str> = BUNDLED
        .iter()
        .filter_map(|(p, _)| p.split('/').next())
        .collect();
    v.dedup();
    v
}

/// The interfaces of `pkg` shipped, as `(kind, Name)`, sorted.
pub(crate) fn interfaces_of(pkg: &str) -> Vec<(String, String)> {
    BUNDLED
        .iter()
        .filter_map(|(p, _)| {
            let mut parts = p.splitn(3, '/');
            let (in_pkg, kind, file) = (parts.next()?, parts.next()?, parts.next()?);
            let name = file.rsplit_once('.')?.0;
            (in_pkg == pkg).then(|| (kind.to_owned(), name.to_owned()))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_bundled_table_is_sorted_and_holds_the_common_interfaces() {
        assert!(
            super::BUNDLED.windows(2).all(|w| w[0].0 < w[1].0),
            "sorted, for the search"
        );
        for p in [
            "std_msgs/msg/Header.msg",
            "geometry_msgs/msg/Twist.msg",
            "sensor_msgs/msg/LaserScan.msg",
            "nav_msgs/msg/Odometry.msg",
            "std_srvs/srv/Trigger.srv",
            "action_msgs/msg/GoalInfo.msg",
            "diagnostic_msgs/msg/DiagnosticArray.msg",
        ] {
            assert!(super::find(p).is_some_and(|t| !t.is_empty()), "{p}");
        }
        assert!(super::find("nav2_msgs/action/NavigateToPose.action").is_none());
    }
}
