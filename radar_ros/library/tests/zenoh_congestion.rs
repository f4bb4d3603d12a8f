//! Issue 37, "signals that must arrive do" over Zenoh: a reliable KEEP_ALL publisher waits for room when the
//! link is congested instead of dropping samples, as rmw_zenoh's does (ros2-client patch 13: the backend
//! declared every publisher with Zenoh's default, which drops on congestion whatever the QoS). Every other
//! publisher keeps dropping, as rmw_zenoh's.
//!
//! A burst far larger than Zenoh's queues (2,000 samples of 64 KiB, published as fast as the publisher can)
//! to a subscriber that takes them slowly, in two sessions of this process that meet through a router in
//! rmw_zenoh's default layout (peers, port 7447): every sample arrives, in order. With the old congestion
//! control most of them are lost (mutation run).
//!
//! Domain 135. Needs the venv (RADAR_VENV, for the router) and the tests' own network namespace
//! (tests/isolated.sh); run by `cargo test --workspace`, whose build has the feature (tests/Cargo.toml).
#![cfg(feature = "zenoh")]

mod zenoh_util;

use std::time::{Duration, Instant};

use ros2_client::{
    qos::{History, Reliability, WhenFull},
    zenoh::{Context, ContextOptions, Node, Subscription},
    MessageTypeName, Name, NodeName, NodeOptions, QosProfile,
};
use zenoh_util::{local_router, WAIT};

const DOMAIN: u16 = 135;
const BURST: usize = 2_000;
const BODY: usize = 64 * 1024;

fn node(name: &str) -> (Context, Node) {
    let ctx = Context::with_options(ContextOptions::new().domain_id(DOMAIN)).unwrap();
    let node = ctx
        .new_node(NodeName::new("/", name).unwrap(), NodeOptions::new())
        .unwrap();
    (ctx, node)
}

fn topic(node: &Node, qos: &QosProfile) -> ros2_client::zenoh::Topic {
    node.create_topic(
        &Name::new("/", "zenoh_burst").unwrap(),
        MessageTypeName::new("std_msgs", "String"),
        qos,
    )
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_reliable_keep_all_burst_larger_than_zenohs_queues_arrives_whole_and_in_order() {
    let mut router = local_router().await;
    let keep_all = QosProfile::default()
        .reliability(Reliability::Reliable {
            when_full: WhenFull::DEFAULT,
        })
        .history(History::KeepAll);
    let (_ctx_b, node_b) = node("burst_sink");
    let sub: Subscription<String> = node_b
        .create_subscription(&topic(&node_b, &keep_all), None)
        .unwrap();
    let (_ctx_a, node_a) = node("burst_source");
    let publisher = node_a
        .create_publisher::<String>(&topic(&node_a, &keep_all), None)
        .unwrap();
    // the path is up: a first sample crosses
    let started = Instant::now();
    loop {
        assert!(started.elapsed() < WAIT, "the two sessions never met");
        publisher.publish("hello".to_owned()).unwrap();
        if let Ok(got) = tokio::time::timeout(Duration::from_millis(100), sub.async_take()).await {
            assert_eq!(got.unwrap().0, "hello");
            break;
        }
    }
    while sub.try_take().unwrap().is_some() {}

    // the burst, as fast as the publisher goes (it blocks when Zenoh's queues are full)
    let burst = std::thread::spawn(move || {
        let body = "x".repeat(BODY);
        for i in 0..BURST {
            publisher
                .publish(format!("{i:06} {body}"))
                .expect("publish");
        }
        publisher
    });
    // taken slowly: a millisecond's pause every ten samples
    let mut got = Vec::with_capacity(BURST);
    while got.len() < BURST {
        match tokio::time::timeout(Duration::from_secs(5), sub.async_take()).await {
            Ok(m) => {
                let (msg, _) = m.unwrap();
                assert_eq!(msg.len(), 7 + BODY);
                got.push(msg[..6].parse::<usize>().unwrap());
                if got.len() % 10 == 0 {
                    tokio::time::sleep(Duration::from_millis(1)).await;
                }
            }
            Err(_) => break,
        }
    }
    let _publisher = burst.join().unwrap();
    let want: Vec<usize> = (0..BURST).collect();
    assert!(
        got == want,
        "all {BURST} samples, in order: got {} (first missing: {:?})",
        got.len(),
        want.iter().find(|i| !got.contains(i))
    );
    router.close();
}
