//! Issue 34: radar_ros's endpoints announce their type hash as ROS 2 Jazzy does (`typehash=RIHS01_...;` in the
//! DDS USER_DATA of each topic endpoint, REP 2011; RustDDS patch 43), so `ros2 topic info -v` shows it. The
//! oracle: rclpy (rmw_fastrtps) reading it from discovery, against the hash rosidl wrote into the venv's
//! `share/geometry_msgs/msg/PoseStamped.json` (and `radar_msgs/msg/ResponseState.json`, which rosidl built from
//! `msgs/radar_msgs`). Domain 119.

use radar_ros::{msg::PoseStamped, FnResponse};
use radar_test_util::{python, radar, require_isolation, Py};
use serde_json::Value;

/// rosidl's hash of `pkg/msg/Name`, from the wheel's `share/<pkg>/msg/<Name>.json`.
fn rosidl_hash(pkg: &str, name: &str) -> String {
    let venv = python().parent().unwrap().parent().unwrap().to_owned();
    let path = venv.join(format!("share/{pkg}/msg/{name}.json"));
    let doc: Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    doc["type_hashes"][0]["hash_string"]
        .as_str()
        .unwrap()
        .to_owned()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn rclpy_reads_the_type_hash_of_radar_ros_endpoints_from_discovery() {
    require_isolation();
    const DOMAIN: u16 = 119;
    let radar = radar(DOMAIN);
    let go_to = radar
        .spawn_response(
            "go_to",
            FnResponse::new(|goal: PoseStamped| async move { Ok(goal) }),
        )
        .unwrap();
    // an endpoint typed at run time (as relays and the tools make them) of a type radar_ros ships
    let _raw = radar
        .raw_subscription("/raw/odom", "nav_msgs/msg/Odometry")
        .unwrap();
    let mut py = Py::start(
        DOMAIN,
        "tests/python/type_hashes.py",
        &["/go_to/start", "/go_to/exited", "/go_to/state", "/raw/odom"],
    );
    let mut seen = Vec::new();
    loop {
        let v = py.json().await;
        if v.get("done").is_some() {
            break;
        }
        seen.push(v);
    }
    py.succeeds().await;
    let expected = rosidl_hash("geometry_msgs", "PoseStamped");
    let start = seen
        .iter()
        .find(|v| v["topic"] == "/go_to/start" && v["kind"] == "subscription")
        .unwrap_or_else(|| panic!("the start slot's subscription: {seen:#?}"));
    assert_eq!(start["type"], "geometry_msgs/msg/PoseStamped", "{start}");
    assert_eq!(start["hash"], expected.as_str(), "{start}");
    let exited = seen
        .iter()
        .find(|v| v["topic"] == "/go_to/exited" && v["kind"] == "publisher")
        .unwrap_or_else(|| panic!("exited's publisher: {seen:#?}"));
    assert_eq!(exited["hash"], expected.as_str(), "{exited}");
    // radar_ros's own state messages carry theirs too (radar_msgs, as rosidl built it into the venv from msgs/)
    let state = seen
        .iter()
        .find(|v| v["topic"] == "/go_to/state" && v["kind"] == "publisher")
        .unwrap_or_else(|| panic!("state's publisher: {seen:#?}"));
    assert_eq!(state["type"], "radar_msgs/msg/ResponseState", "{state}");
    assert_eq!(
        state["hash"],
        rosidl_hash("radar_msgs", "ResponseState").as_str(),
        "{state}"
    );
    let raw = seen
        .iter()
        .find(|v| v["topic"] == "/raw/odom" && v["kind"] == "subscription")
        .unwrap_or_else(|| panic!("the raw subscription: {seen:#?}"));
    assert_eq!(
        raw["hash"],
        rosidl_hash("nav_msgs", "Odometry").as_str(),
        "{raw}"
    );
    go_to.shutdown().await.unwrap();
}
