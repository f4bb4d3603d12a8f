//! The standalone `radar_manager` binary serves a manager node: its `connections` topic appears with the
//! node's name, and its services answer; SIGTERM ends it normally with no error line. Domain 93. Runs inside `tests/isolated.sh` like every DDS test.

use std::time::Duration;

use radar_ros::{msg::ConnectionList, settings::DiscoveryRange, Radar};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_radar_manager_binary_serves_a_manager_node() {
    assert!(
        std::env::var("RADAR_ISOLATED").as_deref() == Ok("1")
            || std::env::var("RADAR_ALLOW_NETWORK").is_ok(),
        "run inside tests/isolated.sh (see README.md)"
    );
    let child = tokio::process::Command::new(env!("CARGO_BIN_EXE_radar_manager"))
        .arg("shared_manager")
        .env("ROS_DOMAIN_ID", "93")
        .env_remove("RUST_LOG")
        .stderr(std::process::Stdio::piped())
        .kill_on_drop(true)
        .spawn()
        .expect("start radar_manager");
    let me = Radar::builder()
        .domain_id(93)
        .discovery_range(DiscoveryRange::Subnet)
        .build()
        .unwrap();
    let list = me
        .state_subscription::<ConnectionList>("/shared_manager/connections")
        .unwrap();
    let first = list.recv().timeout(Duration::from_secs(20)).await.unwrap();
    assert_eq!(first.manager, "/shared_manager");
    assert!(first.connections.is_empty());
    // and a wrong ROS_DOMAIN_ID stops it with a clear error
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_radar_manager"))
        .env("ROS_DOMAIN_ID", "x")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("invalid ROS_DOMAIN_ID \"x\""));
    // SIGTERM ends it normally, with no error line
    drop(list);
    assert!(std::process::Command::new("kill")
        .args(["-TERM", &child.id().unwrap().to_string()])
        .status()
        .unwrap()
        .success());
    let out = tokio::time::timeout(Duration::from_secs(10), child.wait_with_output())
        .await
        .expect("radar_manager to exit on SIGTERM")
        .unwrap();
    assert!(out.status.success(), "{:?}", out.status);
    let stderr = String::from_utf8_lossy(&out.stderr);
    let errors: Vec<&str> = stderr.lines().filter(|l| l.contains("ERROR")).collect();
    assert!(
        errors.is_empty(),
        "error lines on a normal exit: {errors:#?}"
    );
}
