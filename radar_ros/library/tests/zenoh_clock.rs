//! Issue 37: a peer whose clock is an hour ahead, over Zenoh. Zenoh stamps samples with each session's hybrid
//! logical clock, and a session drops (or re-stamps) a sample stamped too far in its future; rmw_zenoh's
//! session keeps them (`drop_future_timestamp: false`), and so does ros2-client's default session (patch
//! 11). A robot whose clock is off must still hear, and be heard by, the rest.
//!
//! The design-document peer (tests/python/zenoh_peer.py) runs under libfaketime an hour ahead (its wall clock
//! and so its Zenoh timestamps and its attachment's source time); the router and radar_ros's side keep this
//! host's clock. Checked: both ways, plain and latched (transient local, whose late-joiner history is ordered
//! by those timestamps); the peer's source time is an hour ahead (libfaketime works), radar_ros's is now.
//!
//! Domain 136. Needs libfaketime (tests/python_env.sh installs it), the venv and tests/isolated.sh (a router on
//! port 7447); run by `cargo test --workspace`, whose build has the feature (tests/Cargo.toml).
#![cfg(feature = "zenoh")]

mod zenoh_util;

use std::time::{SystemTime, UNIX_EPOCH};

use ros2_client::{
    qos::{Durability, History},
    QosProfile,
};
use serde_json::Value;
use zenoh_util::{local_router, start_peer_env, Proc, Side, WAIT};

const DOMAIN: u16 = 136;
const LIBFAKETIME: &str = "/usr/lib/x86_64-linux-gnu/faketime/libfaketime.so.1";

fn now_ns() -> i64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .unwrap()
        .as_nanos() as i64
}

/// How far `stamp_ns` is from now, in seconds.
fn ahead_s(stamp_ns: i64) -> f64 {
    (stamp_ns - now_ns()) as f64 / 1e9
}

async fn skewed_peer(durability: &str) -> Proc {
    assert!(
        std::path::Path::new(LIBFAKETIME).exists(),
        "{LIBFAKETIME} is missing: apt-get install faketime (tests/python_env.sh installs it)"
    );
    let envs = [
        ("LD_PRELOAD", LIBFAKETIME),
        ("FAKETIME", "+1h"),
        ("FAKETIME_DONT_FAKE_MONOTONIC", "1"),
    ];
    start_peer_env(
        None,
        "tcp/localhost:7447",
        DOMAIN,
        ("peer", durability),
        &envs,
    )
    .await
    .0
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_peer_an_hour_ahead_is_heard_and_hears_plain_and_latched() {
    let mut router = local_router().await;

    // plain: both ways
    let mut peer = skewed_peer("volatile").await;
    let mut side = Side::open(DOMAIN);
    let mut tokens = Vec::new();
    let heard = side
        .until_heard(
            &mut peer,
            3,
            &mut tokens,
            "a peer an hour ahead hears radar_ros",
        )
        .await;
    for v in &heard {
        let ahead = ahead_s(v["stamp_ns"].as_i64().unwrap());
        assert!(
            ahead.abs() < 60.0,
            "radar_ros's source time is its own now: {ahead} s off"
        );
    }
    let (msg, info) = side.hear_peer(&mut peer, 6.5).await;
    assert_eq!(msg.header.frame_id, "from_peer");
    let stamp = info.source_timestamp().expect("a source time").to_nanos();
    let ahead = ahead_s(stamp);
    assert!(
        (3500.0..3700.0).contains(&ahead),
        "the peer's clock is an hour ahead (libfaketime): its source time is {ahead} s ahead"
    );
    peer.close();
    drop(side);

    // latched: the skewed peer publishes its state before radar_ros's side subscribes
    let mut peer = skewed_peer("transient_local").await;
    peer.send(r#"{"header": {"frame_id": "skewed state"}, "pose": {"position": {"x": 8.5}}}"#)
        .await;
    loop {
        let line = peer.line_within(WAIT).await.expect("the peer says it sent");
        if serde_json::from_str::<Value>(&line)
            .unwrap()
            .get("sent")
            .is_some()
        {
            break;
        }
    }
    let latched = QosProfile::publisher_default()
        .durability(Durability::TransientLocal)
        .history(History::KeepLast { depth: 1 });
    let side = Side::open_with(DOMAIN, latched.clone());
    let late = side.subscription(&latched);
    let (msg, _) = tokio::time::timeout(WAIT, late.async_take())
        .await
        .expect("a late transient-local subscription gets the skewed peer's state")
        .unwrap();
    assert_eq!(msg.header.frame_id, "skewed state");
    // and the skewed peer, latched too, gets radar_ros's
    let mut side = side;
    let mut tokens = Vec::new();
    let heard = side
        .until_heard(
            &mut peer,
            1,
            &mut tokens,
            "the skewed peer hears radar_ros's latched state",
        )
        .await;
    assert_eq!(heard.len(), 1);
    peer.close();
    router.close();
}
