//! The QoS of RADAR topics, for code that makes its own ROS 2 endpoints on them (ros2-client, rclpy).
//!
//! ```
//! let q = radar_ros::qos::signal_qos();   // reliable, volatile, keep-last 10: rclpy's default
//! let s = radar_ros::qos::state_qos();    // reliable, transient-local, keep-last 1: "latched"
//! # let _ = (q, s);
//! ```

use ros2_client::{
    qos::{Durability, History},
    QosProfile,
};

/// History depth of signal and slot endpoints: rclpy's default.
pub const SIGNAL_DEPTH: usize = 10;

/// QoS of every signal and slot topic: reliable, volatile, keep-last 10 (rclpy's and `ros2 topic pub`'s
/// default, so command-line tools match it).
pub fn signal_qos() -> QosProfile {
    signal_qos_depth(SIGNAL_DEPTH)
}

/// [`signal_qos`] with another history depth (a connection's relay may ask for one).
///
/// ```
/// let deeper = radar_ros::qos::signal_qos_depth(100);
/// # let _ = deeper;
/// ```
pub fn signal_qos_depth(depth: usize) -> QosProfile {
    QosProfile::publisher_default()
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth })
}

/// QoS of `state` topics: reliable, transient-local, keep-last 1, so a late subscriber gets the current state
/// and only that.
pub fn state_qos() -> QosProfile {
    QosProfile::publisher_default()
        .durability(Durability::TransientLocal)
        .history(History::KeepLast { depth: 1 })
}

/// QoS of `/rosout`, as rcl makes it: reliable, transient-local, keep-last 1000, lines older than 10 s dropped.
pub fn rosout_qos() -> QosProfile {
    QosProfile::publisher_default()
        .durability(Durability::TransientLocal)
        .history(History::KeepLast { depth: 1000 })
        .lifespan(Some(std::time::Duration::from_secs(10)))
}
