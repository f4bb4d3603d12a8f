//! Issue 37, the seam radar_ros's endpoints need over Zenoh (docs/zenoh.md, step 2): a live count of the
//! peers an endpoint is matched with, as `Watched` has over DDS, here from liveliness tokens as rmw_zenoh's
//! graph cache counts them (ros2-client patch 14: same topic, type and hash, QoS compatible by rmw's rules).
//!
//! The oracle is the peer written from rmw_zenoh's design document (tests/python/zenoh_peer.py, the
//! eclipse-zenoh wheel; nothing of radar_ros or ros2-client), through rmw_zenoh's default layout (a router
//! on 7447, sessions in peer mode). Checked, for three peer processes in turn (each SIGKILLed, the next
//! started at once):
//! - radar_ros's publisher counts nothing before the peer, then exactly its subscription; radar_ros's
//!   subscription counts the peer's publisher; each count's watch (`watch_matched`) says each change as the
//!   tokens come and go, and what it says is the count then;
//! - a sample published the moment the count reaches one reaches the peer (what `wait_for_subscribers`
//!   promises over DDS: nothing sent from then on is lost to discovery), with no settling sleep;
//! - endpoints the peer's would not match count nothing beside it: another type on the same topic, a
//!   best-effort publisher (the peer's subscription is reliable), a transient-local subscription (the peer's
//!   publisher is volatile);
//! - the peer SIGKILLed, both counts fall back to zero (times printed).
//!
//! Domain 137. Needs the venv (RADAR_VENV) and the tests' own network namespace (tests/isolated.sh); run by `cargo test --workspace`, whose build has the feature (tests/Cargo.toml).
#![cfg(feature = "zenoh")]

mod zenoh_util;

use std::time::{Duration, Instant};

use radar_ros::msg::{PoseStamped, RosMessage};
use ros2_client::{
    qos::{Durability, History, Reliability},
    zenoh::{Publisher, Subscription},
    MessageTypeName, Name, QosProfile,
};
use serde_json::Value;
use zenoh_util::{local_router, pose, start_peer, Side, WAIT};

const DOMAIN: u16 = 137;

/// Reliable, volatile, keep last 10: the peer's QoS (`::,10:,:,:,,`) and RADAR's signals'.
fn reliable() -> QosProfile {
    QosProfile::publisher_default().history(History::KeepLast { depth: 10 })
}

/// Waits on `counts` (a `watch_matched` receiver) until it says `n`; how long that took. The count it says
/// must be the one asked for then (`count`).
async fn until_count(
    what: &str,
    n: usize,
    counts: &async_channel::Receiver<usize>,
    count: impl Fn() -> usize,
) -> Duration {
    let started = Instant::now();
    loop {
        let said = tokio::time::timeout_at((started + WAIT).into(), counts.recv())
            .await
            .unwrap_or_else(|_| panic!("{what}: not {n} after {WAIT:?} ({} now)", count()))
            .expect("the watch lives as long as the endpoint");
        if said == n {
            assert_eq!(count(), n, "{what}: the watch and the count agree");
            return started.elapsed();
        }
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn matched_counts_over_zenoh_follow_a_design_document_peer_as_it_comes_and_is_killed() {
    let mut router = local_router().await;
    // reliable, as the peer's endpoints and RADAR's signals are (ros2-client's default is best effort)
    let side = Side::open_with(DOMAIN, reliable());
    let publisher = &side.publisher;
    let subscription = &side.subscription;
    let node = &side.node;
    assert_eq!(publisher.matched_subscription_count(node), 0);
    assert_eq!(subscription.matched_publisher_count(node), 0);
    // the counts as they change, from the tokens (no polling)
    let (pub_counts, sub_counts) = (
        publisher.watch_matched(node),
        subscription.watch_matched(node),
    );
    assert_eq!(
        pub_counts.try_recv(),
        Ok(0),
        "a watch says the count at once"
    );
    assert_eq!(sub_counts.try_recv(), Ok(0));

    let probe = |name: &str, ty: MessageTypeName, qos: QosProfile| {
        node.create_topic(&Name::new("/zenoh_probe", name).unwrap(), ty, &qos)
    };
    let pose_type = || MessageTypeName::new(PoseStamped::PACKAGE, PoseStamped::NAME);

    for round in 1..=3 {
        let (mut peer, _, _, _) = start_peer(None, "tcp/localhost:7447", DOMAIN, "peer").await;

        let counted = until_count(
            "radar_ros's publisher's matched subscriptions",
            1,
            &pub_counts,
            || publisher.matched_subscription_count(node),
        )
        .await;
        // at once, no settling: this sample must reach the peer
        let x = 100.0 + round as f64;
        publisher.publish(pose("first", x)).unwrap();
        let back = until_count(
            "radar_ros's subscription's matched publishers",
            1,
            &sub_counts,
            || subscription.matched_publisher_count(node),
        )
        .await;
        let heard = loop {
            let line = tokio::time::timeout(WAIT, peer.line())
                .await
                .expect("the peer hears the sample sent as soon as it was counted");
            let v: Value = serde_json::from_str(&line).unwrap();
            if let Some(m) = v.get("received") {
                break m.clone();
            }
        };
        assert_eq!(
            heard["pose"]["position"]["x"].as_f64(),
            Some(x),
            "the first sample the peer hears is the one sent when it was counted: {heard}"
        );

        // beside the peer's endpoints, those that would not match them count nothing, made now that the
        // peer's tokens are known (the publisher above, made the same way, counts it)
        let string_pub: Publisher<String> = node
            .create_publisher(
                &probe(
                    "to_peer",
                    MessageTypeName::new("std_msgs", "String"),
                    reliable(),
                ),
                None,
            )
            .unwrap();
        let best_effort: Publisher<PoseStamped> = node
            .create_publisher(
                &probe(
                    "to_peer",
                    pose_type(),
                    reliable().reliability(Reliability::BestEffort),
                ),
                None,
            )
            .unwrap();
        let like_first: Publisher<PoseStamped> = node
            .create_publisher(&probe("to_peer", pose_type(), reliable()), None)
            .unwrap();
        let latched: Subscription<PoseStamped> = node
            .create_subscription(
                &probe(
                    "from_peer",
                    pose_type(),
                    reliable().durability(Durability::TransientLocal),
                ),
                None,
            )
            .unwrap();
        assert_eq!(
            (
                string_pub.matched_subscription_count(node),
                best_effort.matched_subscription_count(node),
                latched.matched_publisher_count(node),
                like_first.matched_subscription_count(node),
            ),
            (0, 0, 0, 1),
            "another type, a best-effort publisher, a transient-local subscription count nothing; a \
             publisher like the first counts the peer"
        );

        let killed = Instant::now();
        peer.kill().await;
        let gone = until_count(
            "radar_ros's publisher's matched subscriptions after SIGKILL",
            0,
            &pub_counts,
            || publisher.matched_subscription_count(node),
        )
        .await;
        until_count(
            "radar_ros's subscription's matched publishers after SIGKILL",
            0,
            &sub_counts,
            || subscription.matched_publisher_count(node),
        )
        .await;
        println!(
            "round {round}: counted {} ms after the peer was up, counted back {} ms later; gone {} ms \
             after SIGKILL ({} ms both)",
            counted.as_millis(),
            back.as_millis(),
            gone.as_millis(),
            killed.elapsed().as_millis()
        );
    }
    router.kill().await;
}
