//! Issue 37, step 3's first half: radar_ros's own signal endpoints over Zenoh (`radar_ros::topics::ZenohSignals`), the
//! `SignalPublisher`, `SignalSubscription` and raw ones a `Radar` makes over DDS, with their waits.
//!
//! The oracle is the peer written from rmw_zenoh's design document (tests/python/zenoh_peer.py: the
//! eclipse-zenoh wheel, rclpy's CDR), through a router in rmw_zenoh's default layout; radar_ros's side is
//! configured only by `ROS_DOMAIN_ID`, as a ROS 2 program under rmw_zenoh. Checked, with no settling sleeps:
//! `wait_for_subscribers(1)` returns once the peer's subscription is there and a message published then
//! reaches it; `wait_for_publishers(1)`, then the peer's samples arrive through `recv_stamped` (with the
//! peer's source time) and through a raw subscription (decoded here); the peer SIGKILLed,
//! `wait_for_no_subscribers` returns and both counts are zero; a sample of the same type name and another hash
//! (put by hand on the key the design document gives) is not heard, one of this hash is (ros2-client patch
//! 16); a bad topic or type name is refused, saying so.
//!
//! Domain 139. Needs the venv (RADAR_VENV) and the tests' own network namespace (tests/isolated.sh); run by `cargo test --workspace`, whose build has the feature (tests/Cargo.toml).
#![cfg(feature = "zenoh")]

mod zenoh_util;

use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use radar_ros::{
    msg::{PoseStamped, RosMessage},
    topics::RawMessage,
    topics::ZenohSignals,
    Error,
};
use ros2_client::zenoh::{Context, ContextOptions};
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

    // a publisher of the same type name and another hash (another definition of the type) is not heard, as
    // rmw_zenoh's subscriptions do not hear it (they listen on their hash's key; ros2-client patch 16): samples
    // put by hand on the keys the design document gives, `<domain>/<topic>/<type>/<hash>`, CDR with its header
    let other = Context::with_options(ContextOptions::new().domain_id(DOMAIN)).unwrap();
    let key = |hash: &str| {
        format!("{DOMAIN}/zenoh_probe/from_peer/geometry_msgs::msg::dds_::PoseStamped_/{hash}")
    };
    let right = key(PoseStamped::TYPE_HASH.unwrap());
    let wrong = key(&format!("RIHS01_{}1", "0".repeat(63)));
    let cdr = |x: f64| {
        let mut bytes = vec![0, 1, 0, 0];
        bytes.extend(
            RawMessage::encode(&pose("by hand", x))
                .unwrap()
                .into_bytes(),
        );
        bytes
    };
    let next_x = || async {
        let (body, _) = raw_from_peer
            .recv_stamped()
            .timeout(Duration::from_millis(100))
            .await
            .ok()?;
        Some(body.decode::<PoseStamped>().unwrap().pose.position.x)
    };
    // until the hand-made session's samples reach the subscription, then nothing left in flight
    let started = Instant::now();
    loop {
        assert!(started.elapsed() < WAIT, "nothing put by hand arrived");
        other.session().put(&right, cdr(1.0)).await.unwrap();
        if next_x().await.is_some() {
            break;
        }
    }
    while next_x().await.is_some() {}
    other.session().put(&wrong, cdr(2.0)).await.unwrap();
    other.session().put(&right, cdr(3.0)).await.unwrap();
    assert_eq!(
        next_x().await,
        Some(3.0),
        "the sample of another hash is not heard; the one after it, of this hash, is"
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
