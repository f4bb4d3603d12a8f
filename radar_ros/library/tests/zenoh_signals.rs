//! Issue 37, step 3's first half: radar_ros's own signal endpoints over Zenoh (`radar_ros::ZenohSignals`), the
//! `SignalPublisher`, `SignalSubscription` and raw ones a `Radar` makes over DDS, with their waits.
//!
//! The oracle is the peer written from rmw_zenoh's design document (tests/python/zenoh_peer.py: the
//! eclipse-zenoh wheel, rclpy's CDR), through a router in rmw_zenoh's default layout; radar_ros's side is
//! configured only by `ROS_DOMAIN_ID`, as a ROS 2 program under rmw_zenoh. Checked, with no settling sleeps:
//! `wait_for_subscribers(1)` returns once the peer's subscription is there and a message published then
//! reaches it; `wait_for_publishers(1)`, then the peer's samples arrive through `recv_stamped` (with the
//! peer's source time) and through a raw subscription (decoded here); the peer SIGKILLed,
//! `wait_for_no_subscribers` returns and both counts are zero; a bad topic or type name is refused, saying so.
//!
//! Domain 139. Needs the venv (RADAR_VENV) and the tests' own network namespace (tests/isolated.sh); run by
//! tests/zenoh_feature.rs.
#![cfg(feature = "zenoh")]

mod zenoh_util;

use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use radar_ros::{msg::PoseStamped, Error, ZenohSignals};
use serde_json::Value;
use zenoh_util::{local_router, pose, start_peer, WAIT};

const DOMAIN: u16 = 139;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn radar_ros_signal_endpoints_over_zenoh_wait_send_and_hear_as_over_dds() {
    // the one test of this binary: its environment is its own
    std::env::set_var("ROS_DOMAIN_ID", DOMAIN.to_string());
    let mut router = local_router().await;
    let zenoh = ZenohSignals::open("radar_signals").unwrap();
    let to_peer = zenoh
        .signal_publisher::<PoseStamped>("/zenoh_probe/to_peer")
        .unwrap();
    let from_peer = zenoh
        .signal_subscription::<PoseStamped>("/zenoh_probe/from_peer")
        .unwrap();
    let raw_from_peer = zenoh
        .raw_subscription("zenoh_probe/from_peer", "geometry_msgs/msg/PoseStamped")
        .unwrap();
    assert_eq!(raw_from_peer.topic(), "/zenoh_probe/from_peer");
    assert_eq!((to_peer.subscribers(), from_peer.publishers()), (0, 0));

    let (mut peer, _, _, _) = start_peer(None, "tcp/localhost:7447", DOMAIN, "peer").await;
    let started = Instant::now();
    to_peer.wait_for_subscribers(1).timeout(WAIT).await.unwrap();
    let waited = started.elapsed();
    to_peer.publish(pose("via ZenohSignals", 3.5)).unwrap();
    let heard = loop {
        let v: Value = serde_json::from_str(&peer.line().await).unwrap();
        if v.get("received").is_some() {
            break v;
        }
    };
    assert_eq!(
        (
            heard["received"]["header"]["frame_id"].as_str(),
            heard["received"]["pose"]["position"]["x"].as_f64()
        ),
        (Some("via ZenohSignals"), Some(3.5)),
        "the message published as soon as wait_for_subscribers returned is the first the peer hears: {heard}"
    );

    from_peer
        .wait_for_publishers(1)
        .timeout(WAIT)
        .await
        .unwrap();
    raw_from_peer
        .wait_for_publishers(1)
        .timeout(WAIT)
        .await
        .unwrap();
    peer.send(r#"{"header": {"frame_id": "from_peer"}, "pose": {"position": {"x": 7.25}}}"#)
        .await;
    let (msg, stamp) = from_peer.recv_stamped().timeout(WAIT).await.unwrap();
    assert_eq!(
        (msg.header.frame_id.as_str(), msg.pose.position.x),
        ("from_peer", 7.25)
    );
    let now = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .unwrap()
        .as_nanos() as i64;
    assert!(
        (now - stamp).abs() < 60_000_000_000,
        "the peer's source time, about now: {stamp}"
    );
    let (body, _) = raw_from_peer.recv_stamped().timeout(WAIT).await.unwrap();
    let decoded: PoseStamped = body.decode().unwrap();
    assert_eq!(decoded.pose.position.x, 7.25, "the same sample, raw");

    let killed = Instant::now();
    peer.kill().await;
    to_peer
        .wait_for_no_subscribers()
        .timeout(WAIT)
        .await
        .unwrap();
    let gone = killed.elapsed();
    let started = Instant::now();
    while from_peer.publishers() != 0 {
        assert!(
            started.elapsed() < WAIT,
            "the killed peer's publisher still counted"
        );
        tokio::time::sleep(Duration::from_millis(1)).await;
    }
    println!(
        "wait_for_subscribers returned {} ms after the peer was up; the peer gone {} ms after SIGKILL",
        waited.as_millis(),
        gone.as_millis()
    );

    // bad input: refused, saying what is wrong
    for e in [
        zenoh
            .signal_publisher::<PoseStamped>("/bad topic")
            .err()
            .unwrap(),
        zenoh.raw_publisher("/t", "not a type").err().unwrap(),
    ] {
        assert!(matches!(e, Error::InvalidName { .. }), "{e}");
    }
    router.kill().await;
}
