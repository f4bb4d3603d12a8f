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
//! network namespace (tests/isolated.sh), where port 7447 is free. Run by tests/zenoh_feature.rs, which builds
//! radar_ros with the feature.
#![cfg(feature = "zenoh")]

use std::{
    path::PathBuf,
    process::Stdio,
    time::{Duration, Instant, SystemTime, UNIX_EPOCH},
};

use radar_ros::msg::{Header, Point, Pose, PoseStamped, Quaternion, RosMessage, Time};
use ros2_client::{
    zenoh::{register_type_hash, Context, ContextOptions},
    MessageTypeName, Name, NodeName, NodeOptions, QosProfile,
};
use serde_json::Value;
use tokio::io::{AsyncBufReadExt, AsyncWriteExt, BufReader, Lines};

const DOMAIN: u16 = 131;
const WAIT: Duration = Duration::from_secs(30);

fn python() -> PathBuf {
    let venv = std::env::var_os("RADAR_VENV").expect(
        "RADAR_VENV names the rclpy venv with eclipse-zenoh (tests/python_env.sh builds it)",
    );
    let py = PathBuf::from(venv).join("bin/python");
    assert!(
        py.exists(),
        "{} is missing: run tests/python_env.sh",
        py.display()
    );
    py
}

fn script(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../tests/python")
        .join(name)
}

struct Proc {
    child: tokio::process::Child,
    lines: Lines<BufReader<tokio::process::ChildStdout>>,
    stdin: Option<tokio::process::ChildStdin>,
}

impl Proc {
    fn start(name: &str, args: &[&str]) -> Proc {
        let mut child = tokio::process::Command::new(python())
            .arg(script(name))
            .args(args)
            .env("PYTHONUNBUFFERED", "1")
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .kill_on_drop(true)
            .spawn()
            .expect("start the venv's python");
        let lines = BufReader::new(child.stdout.take().unwrap()).lines();
        let stdin = child.stdin.take();
        Proc {
            child,
            lines,
            stdin,
        }
    }

    async fn line(&mut self) -> String {
        match tokio::time::timeout(WAIT, self.lines.next_line()).await {
            Ok(Ok(Some(l))) => l,
            other => panic!(
                "the python process said nothing more ({other:?}; exit {:?}); its stderr is above",
                self.child.try_wait()
            ),
        }
    }

    async fn send(&mut self, line: &str) {
        let stdin = self.stdin.as_mut().unwrap();
        stdin.write_all(line.as_bytes()).await.unwrap();
        stdin.write_all(b"\n").await.unwrap();
        stdin.flush().await.unwrap();
    }
}

fn pose(frame: &str, x: f64) -> PoseStamped {
    PoseStamped {
        header: Header {
            stamp: Time {
                sec: 1_700_000_000,
                nanosec: 5,
            },
            frame_id: frame.into(),
        },
        pose: Pose {
            position: Point { x, y: -2.5, z: 0.0 },
            orientation: Quaternion {
                x: 0.0,
                y: 0.0,
                z: 0.0,
                w: 1.0,
            },
        },
    }
}

fn now_ns() -> i64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .unwrap()
        .as_nanos() as i64
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn radar_ros_types_cross_zenoh_to_and_from_a_peer_written_from_rmw_zenohs_design() {
    // port 7447 is the host's router's: only inside the tests' own network namespace
    assert!(
        std::env::var("RADAR_ISOLATED").as_deref() == Ok("1"),
        "run inside tests/isolated.sh: this test starts a Zenoh router on port 7447, rmw_zenoh's"
    );
    let mut router = Proc::start("zenoh_router.py", &["tcp/127.0.0.1:7447"]);
    assert_eq!(router.line().await, "up");
    let ros_type = PoseStamped::ros_type_name();
    let mut peer = Proc::start(
        "zenoh_peer.py",
        &[
            "tcp/localhost:7447",
            &DOMAIN.to_string(),
            &ros_type,
            "/zenoh_probe/to_peer",
            "/zenoh_probe/from_peer",
        ],
    );
    // the peer's own tokens may come before it says it is up
    let mut tokens = Vec::new();
    let up = loop {
        let v: Value = serde_json::from_str(&peer.line().await).unwrap();
        if v.get("up").is_some() {
            break v;
        }
        tokens.push(v);
    };
    let rosidl_hash = up["hash"].as_str().unwrap().to_owned();
    let peer_zid = up["up"].as_str().unwrap().to_owned();
    assert_eq!(
        PoseStamped::TYPE_HASH,
        Some(rosidl_hash.as_str()),
        "radar_ros ships rosidl's hash"
    );

    // radar_ros's side: the hash it knows given to the Zenoh backend, a session with the backend's default
    // configuration (rmw_zenoh's: connect to the router at tcp/localhost:7447, gossip; ros2-client patch 11)
    let type_name = MessageTypeName::new(PoseStamped::PACKAGE, PoseStamped::NAME);
    register_type_hash(&type_name.dds_msg_type(), PoseStamped::TYPE_HASH.unwrap()).unwrap();
    assert!(
        std::env::var_os("ZENOH_CONFIG_OVERRIDE").is_none()
            && std::env::var_os("ZENOH_SESSION_CONFIG_URI").is_none(),
        "this test checks the default session configuration: unset ZENOH_CONFIG_OVERRIDE and \
         ZENOH_SESSION_CONFIG_URI"
    );
    let ctx = Context::with_options(ContextOptions::new().domain_id(DOMAIN)).unwrap();
    let node = ctx
        .new_node(
            NodeName::new("/", "radar_side").unwrap(),
            NodeOptions::new(),
        )
        .unwrap();
    let qos = QosProfile::default();
    let to_peer = node.create_topic(
        &Name::new("/zenoh_probe", "to_peer").unwrap(),
        type_name.clone(),
        &qos,
    );
    let from_peer = node.create_topic(
        &Name::new("/zenoh_probe", "from_peer").unwrap(),
        type_name,
        &qos,
    );
    let publisher = node
        .create_publisher::<PoseStamped>(&to_peer, None)
        .unwrap();
    let subscription = node
        .create_subscription::<PoseStamped>(&from_peer, None)
        .unwrap();

    // radar_ros -> the peer: published until the peer has heard three (no wait for discovery to settle)
    let started = Instant::now();
    let mut heard = Vec::new();
    let mut n = 0;
    let mut tick = tokio::time::interval(Duration::from_millis(20));
    while heard.len() < 3 {
        assert!(
            started.elapsed() < WAIT,
            "the peer heard {} of radar_ros's samples in {WAIT:?} (radar_ros's session must reach the router \
             at tcp/localhost:7447, and its publisher name rosidl's hash {rosidl_hash}); tokens seen: \
             {tokens:#?}",
            heard.len()
        );
        tokio::select! {
            _ = tick.tick() => {
                n += 1;
                publisher.publish(pose(&format!("to_peer {n}"), n as f64)).unwrap();
            }
            line = peer.line() => {
                let v: Value = serde_json::from_str(&line).unwrap();
                assert!(v.get("bad_attachment").is_none(), "an attachment not as the design says: {v}");
                if v.get("token").is_some() {
                    tokens.push(v);
                } else if v.get("received").is_some() {
                    heard.push(v);
                }
            }
        }
    }
    for (i, v) in heard.iter().enumerate() {
        let frame = v["received"]["header"]["frame_id"].as_str().unwrap();
        let k: i64 = frame.strip_prefix("to_peer ").unwrap().parse().unwrap();
        assert_eq!(v["received"]["pose"]["position"]["x"], k as f64, "{v}");
        assert_eq!(v["received"]["pose"]["position"]["y"], -2.5, "{v}");
        assert_eq!(
            v["seq"], k,
            "the sequence number counts the publisher's samples: {v}"
        );
        if i > 0 {
            assert!(
                v["seq"].as_i64() > heard[i - 1]["seq"].as_i64(),
                "{heard:#?}"
            );
            assert_eq!(
                v["gid"], heard[0]["gid"],
                "one publisher, one GID: {heard:#?}"
            );
        }
        let stamp = v["stamp_ns"].as_i64().unwrap();
        assert!(
            (now_ns() - stamp).abs() < 60_000_000_000,
            "source time is now-ish: {v}"
        );
        assert_eq!(v["gid"].as_str().unwrap().len(), 32, "a 16-byte GID: {v}");
    }

    // the peer -> radar_ros: a line per attempt until one arrives
    let started = Instant::now();
    let got = loop {
        assert!(
            started.elapsed() < WAIT,
            "nothing from the peer in {WAIT:?}"
        );
        peer.send(r#"{"header": {"frame_id": "from_peer"}, "pose": {"position": {"x": 7.25}}}"#)
            .await;
        match tokio::time::timeout(Duration::from_millis(100), subscription.async_take()).await {
            Ok(got) => break got.unwrap(),
            Err(_) => continue,
        }
    };
    let (msg, info) = got;
    assert_eq!(msg.header.frame_id, "from_peer");
    assert_eq!(msg.pose.position.x, 7.25);
    assert!(
        info.sequence_number() >= 1,
        "the peer's sequence number: {info:?}"
    );

    // the tokens the peer saw of radar_ros's side name its node, topics, type and rosidl's hash
    while let Ok(Some(line)) =
        tokio::time::timeout(Duration::from_millis(300), peer.lines.next_line())
            .await
            .map(|l| l.ok().flatten())
    {
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
    drop(peer.stdin.take());
    drop(router.stdin.take());
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
