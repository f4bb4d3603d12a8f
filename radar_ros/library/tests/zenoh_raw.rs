//! Issue 37, what the manager's relays need over Zenoh (docs/zenoh.md, step 3): message bodies forwarded as
//! they are (`RawMessage`, a type known only by name) and the source time of the signal they forward, not the
//! time of forwarding (over DDS, ros2-client patch 1's `publish_with_options`; over Zenoh, patch 15's
//! `publish_stamped`, which writes it into rmw_zenoh's attachment).
//!
//! The oracle is the peer written from rmw_zenoh's design document (tests/python/zenoh_peer.py: the
//! eclipse-zenoh wheel, rclpy's CDR, the attachment read as the design lays it out), through a router in
//! rmw_zenoh's default layout. Checked: a raw body published with a source time an hour old reaches the peer,
//! which decodes it as the `geometry_msgs/msg/PoseStamped` it is and reads that time from the attachment; the
//! peer's sample arrives here as a raw body that decodes to what it sent, with its source time.
//!
//! Domain 138. Needs the venv (RADAR_VENV) and the tests' own network namespace (tests/isolated.sh); run by `cargo test --workspace`, whose build has the feature (tests/Cargo.toml).
#![cfg(feature = "zenoh")]

mod zenoh_util;

use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use radar_ros::{
    msg::{PoseStamped, RosMessage},
    topics::RawMessage,
};
use ros2_client::{
    qos::History,
    zenoh::{register_type_hash, Context, ContextOptions, Publisher, Subscription},
    MessageTypeName, Name, NodeName, NodeOptions, QosProfile, ROSTime,
};
use serde_json::Value;
use zenoh_util::{local_router, pose, start_peer, WAIT};

const DOMAIN: u16 = 138;

fn now_ns() -> i64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .unwrap()
        .as_nanos() as i64
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn raw_bodies_and_their_source_times_cross_zenoh_to_and_from_a_design_document_peer() {
    let mut router = local_router().await;
    let (mut peer, _, _, _) = start_peer(None, "tcp/localhost:7447", DOMAIN, "peer").await;

    let type_name = MessageTypeName::new(PoseStamped::PACKAGE, PoseStamped::NAME);
    register_type_hash(&type_name.dds_msg_type(), PoseStamped::TYPE_HASH.unwrap()).unwrap();
    let ctx = Context::with_options(ContextOptions::new().domain_id(DOMAIN)).unwrap();
    let node = ctx
        .new_node(NodeName::new("/", "raw_side").unwrap(), NodeOptions::new())
        .unwrap();
    // RADAR's signal QoS, as the peer's: reliable, volatile, keep last 10
    let qos = QosProfile::publisher_default().history(History::KeepLast { depth: 10 });
    let topic = |name| {
        node.create_topic(
            &Name::new("/zenoh_probe", name).unwrap(),
            type_name.clone(),
            &qos,
        )
    };
    let publisher: Publisher<RawMessage> = node.create_publisher(&topic("to_peer"), None).unwrap();
    let subscription: Subscription<RawMessage> =
        node.create_subscription(&topic("from_peer"), None).unwrap();

    // to the peer: a body forwarded unchanged, stamped an hour ago
    let started = Instant::now();
    while publisher.matched_subscription_count(&node) < 1 {
        assert!(
            started.elapsed() < WAIT,
            "the peer's subscription never counted"
        );
        tokio::time::sleep(Duration::from_millis(1)).await;
    }
    let body = RawMessage::encode(&pose("raw", 5.5)).unwrap();
    let stamp = now_ns() - 3_600_000_000_000;
    publisher
        .publish_stamped(body, ROSTime::from_nanos(stamp))
        .unwrap();
    let heard = loop {
        let v: Value = serde_json::from_str(&peer.line().await).unwrap();
        assert!(v.get("bad_attachment").is_none(), "{v}");
        if v.get("received").is_some() {
            break v;
        }
    };
    assert_eq!(heard["received"]["header"]["frame_id"], "raw", "{heard}");
    assert_eq!(
        heard["received"]["pose"]["position"]["x"].as_f64(),
        Some(5.5),
        "{heard}"
    );
    assert_eq!(
        heard["stamp_ns"].as_i64(),
        Some(stamp),
        "the attachment carries the source time given, not the time of publishing: {heard}"
    );

    // from the peer: its sample as a raw body, decoded here
    let started = Instant::now();
    let (raw, info) = loop {
        assert!(started.elapsed() < WAIT, "nothing from the peer");
        peer.send(r#"{"header": {"frame_id": "from_peer"}, "pose": {"position": {"x": 7.25}}}"#)
            .await;
        if let Ok(got) =
            tokio::time::timeout(Duration::from_millis(100), subscription.async_take()).await
        {
            break got.unwrap();
        }
    };
    let msg: PoseStamped = raw.decode().unwrap();
    assert_eq!(
        (msg.header.frame_id.as_str(), msg.pose.position.x),
        ("from_peer", 7.25)
    );
    let sent_at = info.source_timestamp().expect("a source time").to_nanos();
    assert!(
        (now_ns() - sent_at).abs() < 60_000_000_000,
        "the peer's source time is about now: {sent_at}"
    );
    peer.close();
    router.kill().await;
}
