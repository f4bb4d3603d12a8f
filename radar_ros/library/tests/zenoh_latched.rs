//! Issue 37: state a late observer must see (TRANSIENT_LOCAL: a component's `state`, the manager's connection
//! list) over Zenoh as rmw_zenoh carries it. ros2-client's Zenoh backend had no transient local: a late
//! subscriber got nothing. Patch 12 declares a transient-local publisher as rmw_zenoh does since its 0.2.2 (a
//! zenoh-ext advanced publisher with a cache of the history depth and publisher detection) and a
//! transient-local subscription as an advanced subscriber that queries those caches, late publishers' too.
//!
//! The oracle is the peer written from rmw_zenoh's design document (tests/python/zenoh_peer.py) in its
//! `transient_local` mode, which declares its endpoints with the eclipse-zenoh wheel's own advanced publisher
//! and subscriber as rmw_zenoh's source does (nothing from radar_ros or ros2-client), through a router in
//! rmw_zenoh's layout on port 7447. Checked, both ways, with keep-last 1 (radar_ros's `state` QoS):
//! - radar_ros's side publishes three samples before the peer exists; the peer, started after, hears exactly
//!   the last one, with its own sequence number (3) and source time;
//! - the peer publishes one sample, which radar_ros's side's first subscription hears live; a transient-local
//!   subscription made after that gets it too, a volatile one made at the same moment does not;
//! - the tokens radar_ros's side declares carry transient local in their QoS (`:1:,1:,:,:,,`).
//!
//! Domain 133. Needs the venv (RADAR_VENV) and the tests' own network namespace (tests/isolated.sh); run by `cargo test --workspace`, whose build has the feature (tests/Cargo.toml).
#![cfg(feature = "zenoh")]

mod zenoh_util;

use std::time::{Duration, Instant};

use ros2_client::{
    qos::{Durability, History},
    QosProfile,
};
use serde_json::Value;
use zenoh_util::{check_heard, local_router, start_peer_with, Proc, Side, WAIT};

const DOMAIN: u16 = 133;

/// radar_ros's `state` QoS: reliable, transient local, keep last 1.
fn latched() -> QosProfile {
    QosProfile::publisher_default()
        .durability(Durability::TransientLocal)
        .history(History::KeepLast { depth: 1 })
}

/// The next line of `peer` that has `field` (within [`WAIT`], else fails saying `why`); token lines on the way
/// go to `tokens`.
async fn next_with(peer: &mut Proc, field: &str, tokens: &mut Vec<Value>, why: &str) -> Value {
    loop {
        let line = peer
            .line_within(WAIT)
            .await
            .unwrap_or_else(|| panic!("no {field:?} line from the peer in {WAIT:?}: {why}"));
        let v: Value = serde_json::from_str(&line).unwrap();
        assert!(
            v.get("bad_attachment").is_none(),
            "an attachment not as the design says: {v}"
        );
        if v.get(field).is_some() {
            return v;
        }
        if v.get("token").is_some() {
            tokens.push(v);
        }
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn latched_state_reaches_a_late_rmw_zenoh_peer_and_a_late_subscription_gets_the_peers() {
    let mut router = local_router().await;

    // radar_ros's side publishes its state three times before anyone listens
    let mut side = Side::open_with(DOMAIN, latched());
    side.publish(3);

    // the peer starts after: its advanced subscriber asks the caches it finds for their history
    let (mut peer, _hash, peer_zid, mut tokens) = start_peer_with(
        None,
        "tcp/localhost:7447",
        DOMAIN,
        "peer",
        "transient_local",
    )
    .await;
    let first = next_with(
        &mut peer,
        "received",
        &mut tokens,
        "a late rmw_zenoh subscriber gets the last of the samples published before it",
    )
    .await;
    check_heard(std::slice::from_ref(&first));
    assert_eq!(
        first["received"]["header"]["frame_id"], "to_peer 3",
        "the last of the three (keep last 1), not an earlier one: {first}"
    );
    while let Some(line) = peer.line_within(Duration::from_millis(500)).await {
        let v: Value = serde_json::from_str(&line).unwrap();
        assert!(
            v.get("received").is_none(),
            "one sample of history (depth 1), then nothing while nothing is published: {v}"
        );
        tokens.push(v);
    }

    // the peer publishes once; only then does radar_ros's side subscribe, latched and volatile
    peer.send(r#"{"header": {"frame_id": "peer state"}, "pose": {"position": {"x": 4.5}}}"#)
        .await;
    let sent = next_with(&mut peer, "sent", &mut tokens, "the peer publishes").await;
    assert_eq!(sent["sent"], 1);
    // the side's first subscription, there all along, hears it live: the sample has reached this session
    // (a subscription declared while it was still on its way would get it live too)
    let (live, _) = tokio::time::timeout(WAIT, side.subscription.async_take())
        .await
        .expect("the peer's sample, live")
        .unwrap();
    assert_eq!(live.header.frame_id, "peer state");
    let late = side.subscription(&latched());
    let volatile = side.subscription(&QosProfile::default());
    let (msg, info) = tokio::time::timeout(WAIT, late.async_take())
        .await
        .expect("a late transient-local subscription gets the peer's cached sample")
        .unwrap();
    assert_eq!(msg.header.frame_id, "peer state");
    assert_eq!(msg.pose.position.x, 4.5);
    assert_eq!(info.sequence_number(), 1, "{info:?}");
    let started = Instant::now();
    assert!(
        tokio::time::timeout(Duration::from_millis(500), volatile.async_take())
            .await
            .is_err(),
        "a volatile subscription gets nothing published before it"
    );
    assert!(started.elapsed() >= Duration::from_millis(500));

    // radar_ros's tokens say transient local, keep last 1
    let ours: Vec<String> = tokens
        .iter()
        .filter(|t| t["put"] == true)
        .filter_map(|t| t["token"].as_str().map(str::to_owned))
        .filter(|k| k.split('/').nth(2) != Some(peer_zid.as_str()))
        .collect();
    for (kind, topic) in [
        ("MP", "%zenoh_probe%to_peer"),
        ("MS", "%zenoh_probe%from_peer"),
    ] {
        let token = ours
            .iter()
            .find(|k| {
                let parts: Vec<&str> = k.split('/').collect();
                parts.len() == 13 && parts[5] == kind && parts[9] == topic
            })
            .unwrap_or_else(|| panic!("radar_ros's {kind} token on {topic}: {ours:#?}"));
        assert!(
            token.ends_with("/:1:,1:,:,:,,"),
            "transient local, keep last 1: {token}"
        );
    }
    peer.close();
    router.close();
}
