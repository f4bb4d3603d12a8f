//! Logs on `/rosout` as rclpy's: with `radar_ros::rosout::layer()` in the program's subscriber, a line logged in
//! a response's start slot, and the library's own line about that response, reach a real rclpy listener on
//! `/rosout` named after the response's node (rcl's logger name), at their level; debug lines do not (info and
//! above unless `--log-level` says otherwise). Domain 105.

use std::time::Duration;

use radar_ros::{msg::StringMsg, FnResponse};
use radar_test_util::{radar, Py};
use serde_json::json;
use tracing_subscriber::prelude::*;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn component_logs_reach_rclpy_on_rosout_with_the_nodes_name() {
    // this test binary's own subscriber: stderr and /rosout
    tracing_subscriber::registry()
        .with(tracing_subscriber::fmt::layer().with_writer(std::io::stderr))
        .with(radar_ros::rosout::layer())
        .init();
    let r = radar(105);
    assert_eq!(r.namespace(), "/");
    let mut echo = Py::start(105, "tests/python/rosout_echo.py", &["marker-7", "3"]);
    assert_eq!(echo.json().await, json!({"ready": true}));
    let talker = r
        .spawn_response(
            "talker",
            FnResponse::new(|s: StringMsg| async move {
                tracing::debug!("not sent: marker-7 debug");
                tracing::info!("start slot says {} marker-7", s.data);
                tracing::warn!("a warning marker-7");
                Ok(StringMsg::default())
            }),
        )
        .unwrap();
    r.inject(
        talker.reference().start_slot(),
        StringMsg {
            data: "hello".into(),
        },
    )
    .timeout(Duration::from_secs(10))
    .await
    .unwrap();
    // a library line naming the component, from outside its task
    tracing::info!(response = "/talker", "library line marker-7");
    let mut lines = Vec::new();
    for _ in 0..3 {
        lines.push(echo.json().await);
    }
    let want = [
        json!({"name": "talker", "level": 20, "msg": "start slot says hello marker-7"}),
        json!({"name": "talker", "level": 30, "msg": "a warning marker-7"}),
        json!({"name": "talker", "level": 20, "msg": "library line marker-7 response=/talker"}),
    ];
    for w in &want {
        assert!(lines.contains(w), "{w} on /rosout: {lines:?}");
    }
}
