//! Issue 70: a second distro. ROS 2 Kilted's rclpy on Fast DDS 3 (the `ros-kilted-*` wheels, in the venv
//! `python_env.sh` builds beside Jazzy's) talks to radar_ros as Jazzy's does: a Kilted node starts and
//! interrupts a RADAR response and reads its signals in order, and a Kilted rclpy event (found by name) drives a
//! Rust response through a `whenever`, checking only while it is listened to. Part of the `interop` binary;
//! domains 137, 138.

use radar_test_util::{kilted_python, radar};

/// `ros2 topic pub`'s start and interrupt from a Kilted node: the response runs, is interrupted and exits, and
/// the Kilted node reads `started`, `interrupted`, `exited` in that order.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_kilted_rclpy_node_starts_and_interrupts_a_response() {
    // the peer is Kilted's rclpy on Fast DDS 3, not Jazzy's
    let v = std::process::Command::new(kilted_python())
        .args([
            "-c",
            "import importlib.metadata as m; print(m.version('ros-kilted-rclpy'), m.version('ros-fastdds'))",
        ])
        .output()
        .expect("the Kilted venv's python");
    let versions = String::from_utf8_lossy(&v.stdout);
    assert!(
        versions.starts_with("9.") && versions.contains(" 3."),
        "{versions}"
    );
    let r = radar(137);
    super::rclpy_starts_and_interrupts(&r, &kilted_python(), 137, "/kilted/slow").await;
}

/// A Kilted rclpy event (`examples/python/radar_event.py`) found by name drives a Rust response; when the
/// connection is gone, the event sees no listener and stops checking (E1): `interop.rs`'s scenario 3a.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_kilted_rclpy_event_drives_a_rust_response() {
    super::rclpy_event_drives_a_rust_response(&kilted_python(), 138, "/kilted").await;
}
