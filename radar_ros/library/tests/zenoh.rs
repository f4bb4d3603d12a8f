//! Issue 37, first step: radar_ros's types over Zenoh named as rmw_zenoh names them. With the `zenoh` feature,
//! ros2-client's Zenoh backend is built beside DDS, and a type hash radar_ros knows (`RosMessage::TYPE_HASH`,
//! rosidl's) can be given to it (`ros2_client::zenoh::register_type_hash`, ros2-client patch 10); without it,
//! every type outside the backend's short built-in list went out under an all-zero hash, which no rmw_zenoh
//! peer ever matches.
//!
//! The oracle is a peer written from rmw_zenoh's design document with the eclipse-zenoh wheel and rclpy's CDR
//! (tests/python/zenoh_peer.py), in rmw_zenoh's default layout: a router on port 7447
//! (tests/python/zenoh_router.py) for discovery, sessions in peer mode that find each other through its
//! gossip. radar_ros's side is told nothing: the backend's default session is rmw_zenoh's (ros2-client patch
//! 11; before it, a session connected to no router and met no one). The peer subscribes as rmw_zenoh does,
//! on the exact key with the hash rosidl wrote into the venv's `share/geometry_msgs/msg/PoseStamped.json`.
//! Checked: both directions carry the message; the attachment (sequence number, source time, 16-byte GID) is
//! well formed and consistent; the liveliness tokens of radar_ros's side name the topic, the DDS type name and
//! rosidl's hash. Domain 131 (key expressions carry it; Zenoh has no multicast here).
//!
//! Needs the rclpy venv (RADAR_VENV, with the eclipse-zenoh wheel; tests/python_env.sh) and the tests' own
//! network namespace (tests/isolated.sh), where port 7447 is free. Run by `cargo test --workspace`, whose build
//! has the feature (tests/Cargo.toml).
#![cfg(feature = "zenoh")]

mod zenoh_util;

use std::time::Duration;

use ros2_client::zenoh::register_type_hash;
use serde_json::Value;
use zenoh_util::{check_heard, local_router, start_peer, Side};

const DOMAIN: u16 = 131;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn radar_ros_types_cross_zenoh_to_and_from_a_peer_written_from_rmw_zenohs_design() {
    // port 7447 is the host's router's: only inside the tests' own network namespace
    let mut router = local_router().await;
    let (mut peer, rosidl_hash, peer_zid, mut tokens) =
        start_peer(None, "tcp/localhost:7447", DOMAIN, "peer").await;

    // radar_ros's side: the hash it knows given to the Zenoh backend, a session with the backend's default
    // configuration (rmw_zenoh's: connect to the router at tcp/localhost:7447, gossip; ros2-client patch 11)
    assert!(
        std::env::var_os("ZENOH_CONFIG_OVERRIDE").is_none()
            && std::env::var_os("ZENOH_SESSION_CONFIG_URI").is_none(),
        "this test checks the default session configuration: unset ZENOH_CONFIG_OVERRIDE and \
         ZENOH_SESSION_CONFIG_URI"
    );
    let mut side = Side::open(DOMAIN);
    let why = format!(
        "radar_ros's session must reach the router at tcp/localhost:7447, and its publisher name rosidl's \
         hash {rosidl_hash}"
    );
    let heard = side.until_heard(&mut peer, 3, &mut tokens, &why).await;
    check_heard(&heard);

    let (msg, info) = side.hear_peer(&mut peer, 7.25).await;
    assert_eq!(msg.header.frame_id, "from_peer");
    assert!(
        info.sequence_number() >= 1,
        "the peer's sequence number: {info:?}"
    );

    // the tokens the peer saw of radar_ros's side name its node, topics, type and rosidl's hash
    while let Some(line) = peer.line_within(Duration::from_millis(300)).await {
        let v: Value = serde_json::from_str(&line).unwrap();
        if v.get("token").is_some() {
            tokens.push(v);
        }
    }
    let ours: Vec<Vec<String>> = tokens
        .iter()
        .filter(|t| t["put"] == true)
        .map(|t| {
            t["token"]
                .as_str()
                .unwrap()
                .split('/')
                .map(str::to_owned)
                .collect::<Vec<_>>()
        })
        .filter(|parts| parts.len() > 2 && parts[2] != peer_zid)
        .collect();
    let entity = |kind: &str, topic: &str| {
        ours.iter()
            .find(|p| p.len() == 13 && p[5] == kind && p[9] == topic)
            .unwrap_or_else(|| panic!("a {kind} token for {topic}: {ours:#?}"))
            .clone()
    };
    for (kind, topic) in [
        ("MP", "%zenoh_probe%to_peer"),
        ("MS", "%zenoh_probe%from_peer"),
    ] {
        let t = entity(kind, topic);
        assert_eq!(t[0], "@ros2_lv");
        assert_eq!(t[1], DOMAIN.to_string());
        assert_eq!(t[7], "%", "the root namespace, mangled: {t:?}");
        assert_eq!(t[8], "radar_side");
        assert_eq!(t[10], "geometry_msgs::msg::dds_::PoseStamped_");
        assert_eq!(t[11], rosidl_hash, "{t:?}");
    }
    assert!(
        ours.iter()
            .any(|p| p.len() == 9 && p[5] == "NN" && p[8] == "radar_side"),
        "the node's token: {ours:#?}"
    );
    peer.close();
    router.close();
}

#[test]
fn a_type_hash_given_to_zenoh_is_refused_when_malformed_or_in_conflict() {
    let dds = "radar_zenoh_probe::msg::dds_::Probe_";
    let hash = "RIHS01_0123456789abcdef0123456789abcdef0123456789abcdef0123456789abcdef";
    for bad in [
        "RIHS01_00",
        "RIHS02_0123456789abcdef0123456789abcdef0123456789abcdef0123456789abcdef",
    ] {
        let refused = register_type_hash(dds, bad).unwrap_err();
        assert!(refused.contains(bad), "{refused}");
    }
    assert!(register_type_hash(dds, &hash.to_uppercase()).is_err());
    register_type_hash(dds, hash).unwrap();
    register_type_hash(dds, hash).expect("the same hash again is a no-op");
    let other = hash.replace("RIHS01_0", "RIHS01_1");
    let refused = register_type_hash(dds, &other).unwrap_err();
    assert!(
        refused.contains(hash) && refused.contains(&other),
        "{refused}"
    );
    // a type the backend's own table knows keeps its hash
    assert!(register_type_hash("std_msgs::msg::dds_::String_", hash).is_err());
}
