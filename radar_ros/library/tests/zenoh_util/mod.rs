//! What the Zenoh tests share (tests/zenoh.rs, tests/zenoh_netns.rs): the venv's Python processes (the router
//! and the peer written from rmw_zenoh's design document, tests/python/zenoh_*.py), optionally inside another
//! network namespace, and radar_ros's side of the exchange.

#![allow(dead_code)] // each test binary uses its part

use std::{
    path::PathBuf,
    process::{Command, Stdio},
    time::{Duration, Instant, SystemTime, UNIX_EPOCH},
};

use radar_ros::msg::{Header, Point, Pose, PoseStamped, Quaternion, RosMessage, Time};
use ros2_client::{
    zenoh::{register_type_hash, Context, ContextOptions, Node, Publisher, Subscription},
    MessageInfo, MessageTypeName, Name, NodeName, NodeOptions, QosProfile,
};
use serde_json::Value;
use tokio::io::{AsyncBufReadExt, AsyncWriteExt, BufReader, Lines};

/// How long any one step may take.
pub const WAIT: Duration = Duration::from_secs(30);

pub fn python() -> PathBuf {
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

/// A Python script of tests/python, killed when dropped; its stdout is read line by line.
pub struct Proc {
    child: tokio::process::Child,
    lines: Lines<BufReader<tokio::process::ChildStdout>>,
    stdin: Option<tokio::process::ChildStdin>,
}

impl Proc {
    pub fn start(name: &str, args: &[&str]) -> Proc {
        Proc::start_in(None, name, args)
    }

    /// Starts it in the network namespace of process `netns` (through `nsenter`), or in this one.
    pub fn start_in(netns: Option<u32>, name: &str, args: &[&str]) -> Proc {
        Proc::start_with(netns, name, args, &[])
    }

    /// [`Proc::start_in`] with `envs` added to its environment.
    pub fn start_with(
        netns: Option<u32>,
        name: &str,
        args: &[&str],
        envs: &[(&str, &str)],
    ) -> Proc {
        let mut cmd = match netns {
            Some(pid) => {
                let mut c = tokio::process::Command::new("nsenter");
                c.arg(format!("--net=/proc/{pid}/ns/net")).arg(python());
                c
            }
            None => tokio::process::Command::new(python()),
        };
        let mut child = cmd
            .arg(script(name))
            .args(args)
            .env("PYTHONUNBUFFERED", "1")
            // the helpers use rclpy's serialization only, never its middleware: rcl refuses an
            // RMW_IMPLEMENTATION (rmw_zenoh_cpp, which a test of radar_ros on Zenoh sets) its wheels lack
            .env_remove("RMW_IMPLEMENTATION")
            .envs(envs.iter().copied())
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

    pub async fn line(&mut self) -> String {
        match tokio::time::timeout(WAIT, self.lines.next_line()).await {
            Ok(Ok(Some(l))) => l,
            other => panic!(
                "the python process said nothing more ({other:?}; exit {:?}); its stderr is above",
                self.child.try_wait()
            ),
        }
    }

    /// The next line if one comes within `d`.
    pub async fn line_within(&mut self, d: Duration) -> Option<String> {
        tokio::time::timeout(d, self.lines.next_line())
            .await
            .ok()
            .and_then(|l| l.ok().flatten())
    }

    pub async fn send(&mut self, line: &str) {
        let stdin = self.stdin.as_mut().unwrap();
        stdin.write_all(line.as_bytes()).await.unwrap();
        stdin.write_all(b"\n").await.unwrap();
        stdin.flush().await.unwrap();
    }

    /// Reads lines until the peer says it is up (`{"up": ...}`): that line, and those before it (its own tokens
    /// may come first).
    pub async fn until_up(&mut self) -> (Value, Vec<Value>) {
        let mut before = Vec::new();
        loop {
            let v: Value = serde_json::from_str(&self.line().await).unwrap();
            if v.get("up").is_some() {
                return (v, before);
            }
            before.push(v);
        }
    }

    /// Closes its stdin (the scripts end on it).
    pub fn close(&mut self) {
        drop(self.stdin.take());
    }

    /// SIGKILL, at once.
    pub async fn kill(&mut self) {
        self.child.kill().await.expect("kill the python process");
    }
}

/// The lines a program started by [`start_role`] prints.
pub type RoleLines = Lines<BufReader<tokio::process::ChildStdout>>;

/// This test binary run again as another program (`role_var=remote`, only test `name`), once it has printed a
/// line ending in `up`: the process (killed when dropped; its stdin piped) and its stdout's lines.
pub async fn start_role(
    name: &str,
    role_var: &str,
    up: &str,
) -> (tokio::process::Child, RoleLines) {
    let mut child = tokio::process::Command::new(std::env::current_exe().unwrap())
        .args(["--exact", name, "--nocapture", "--test-threads=1"])
        .env(role_var, "remote")
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .kill_on_drop(true)
        .spawn()
        .unwrap();
    let mut out = BufReader::new(child.stdout.take().unwrap()).lines();
    until_line(&mut out, up).await;
    (child, out)
}

/// Reads `out` until a line ending in `want` comes (at most [`WAIT`]).
pub async fn until_line(out: &mut RoleLines, want: &str) {
    loop {
        let line = tokio::time::timeout(WAIT, out.next_line())
            .await
            .unwrap_or_else(|_| panic!("the other program says {want} within {WAIT:?}"))
            .unwrap()
            .unwrap_or_else(|| panic!("the other program ended before it said {want}"));
        if line.ends_with(want) {
            return;
        }
    }
}

/// The router of rmw_zenoh's default layout on `tcp/127.0.0.1:7447`, up. Only inside tests/isolated.sh, where
/// that port is the tests' own namespace's (on the host it is the host's router's).
pub async fn local_router() -> Proc {
    assert!(
        std::env::var("RADAR_ISOLATED").as_deref() == Ok("1"),
        "run inside tests/isolated.sh: this test starts a Zenoh router on port 7447, rmw_zenoh's"
    );
    let mut router = Proc::start("zenoh_router.py", &["tcp/127.0.0.1:7447"]);
    assert_eq!(router.line().await, "up");
    router
}

/// Samples cross both ways: radar_ros's side until the peer has heard three (checked as the design says), then
/// the peer's until one with `x` arrives.
pub async fn both_ways(side: &mut Side, peer: &mut Proc, x: f64, why: &str) {
    let mut tokens = Vec::new();
    let heard = side.until_heard(peer, 3, &mut tokens, why).await;
    check_heard(&heard);
    let (msg, _) = side.hear_peer(peer, x).await;
    assert_eq!(msg.header.frame_id, "from_peer");
}

/// The design-document peer: `zenoh_peer.py ROUTER DOMAIN pkg/msg/PoseStamped /zenoh_probe/to_peer
/// /zenoh_probe/from_peer MODE` (`peer` or `client`), started and up. Returns it, rosidl's hash it read, its
/// session id and the tokens it printed before it was up.
pub async fn start_peer(
    netns: Option<u32>,
    router: &str,
    domain: u16,
    mode: &str,
) -> (Proc, String, String, Vec<Value>) {
    start_peer_with(netns, router, domain, mode, "volatile").await
}

/// [`start_peer`] with the peer's endpoints of `durability` (`volatile` or `transient_local`).
pub async fn start_peer_with(
    netns: Option<u32>,
    router: &str,
    domain: u16,
    mode: &str,
    durability: &str,
) -> (Proc, String, String, Vec<Value>) {
    start_peer_env(netns, router, domain, (mode, durability), &[]).await
}

/// [`start_peer_with`] (`how`: mode and durability) with `envs` added to the peer's environment.
pub async fn start_peer_env(
    netns: Option<u32>,
    router: &str,
    domain: u16,
    how: (&str, &str),
    envs: &[(&str, &str)],
) -> (Proc, String, String, Vec<Value>) {
    let topics = ("/zenoh_probe/to_peer", "/zenoh_probe/from_peer");
    start_peer_on(netns, router, domain, how, topics, envs).await
}

/// [`start_peer_env`] with the peer subscribed to `topics.0` and publishing `topics.1` (PoseStamped both).
pub async fn start_peer_on(
    netns: Option<u32>,
    router: &str,
    domain: u16,
    how: (&str, &str),
    topics: (&str, &str),
    envs: &[(&str, &str)],
) -> (Proc, String, String, Vec<Value>) {
    let (mode, durability) = how;
    let mut peer = Proc::start_with(
        netns,
        "zenoh_peer.py",
        &[
            router,
            &domain.to_string(),
            &PoseStamped::ros_type_name(),
            topics.0,
            topics.1,
            mode,
            durability,
        ],
        envs,
    );
    let (up, tokens) = peer.until_up().await;
    let hash = up["hash"].as_str().unwrap().to_owned();
    let zid = up["up"].as_str().unwrap().to_owned();
    assert_eq!(
        PoseStamped::TYPE_HASH,
        Some(hash.as_str()),
        "radar_ros ships rosidl's hash"
    );
    (peer, hash, zid, tokens)
}

/// radar_ros's side: a node `radar_side` publishing `/zenoh_probe/to_peer` and subscribed to
/// `/zenoh_probe/from_peer`, with rosidl's hash given to the backend. The session's configuration comes from
/// the environment, as rmw_zenoh's does.
pub struct Side {
    _ctx: Context,
    pub node: Node,
    pub publisher: Publisher<PoseStamped>,
    pub subscription: Subscription<PoseStamped>,
    sent: i64,
}

impl Side {
    pub fn open(domain: u16) -> Side {
        Side::open_with(domain, QosProfile::default())
    }

    /// [`Side::open`] with both endpoints of `qos`.
    pub fn open_with(domain: u16, qos: QosProfile) -> Side {
        let type_name = MessageTypeName::new(PoseStamped::PACKAGE, PoseStamped::NAME);
        register_type_hash(&type_name.dds_msg_type(), PoseStamped::TYPE_HASH.unwrap()).unwrap();
        let ctx = Context::with_options(ContextOptions::new().domain_id(domain)).unwrap();
        let node = ctx
            .new_node(
                NodeName::new("/", "radar_side").unwrap(),
                NodeOptions::new(),
            )
            .unwrap();
        let topic = |name| {
            node.create_topic(
                &Name::new("/zenoh_probe", name).unwrap(),
                type_name.clone(),
                &qos,
            )
        };
        let publisher = node.create_publisher(&topic("to_peer"), None).unwrap();
        let subscription = node.create_subscription(&topic("from_peer"), None).unwrap();
        Side {
            _ctx: ctx,
            node,
            publisher,
            subscription,
            sent: 0,
        }
    }

    /// Another subscription to `/zenoh_probe/from_peer`, of `qos`.
    pub fn subscription(&self, qos: &QosProfile) -> Subscription<PoseStamped> {
        let topic = self.node.create_topic(
            &Name::new("/zenoh_probe", "from_peer").unwrap(),
            MessageTypeName::new(PoseStamped::PACKAGE, PoseStamped::NAME),
            qos,
        );
        self.node.create_subscription(&topic, None).unwrap()
    }

    /// Publishes `n` samples at once, counted as [`Side::until_heard`] counts them.
    pub fn publish(&mut self, n: usize) {
        for _ in 0..n {
            self.sent += 1;
            self.publisher
                .publish(pose(&format!("to_peer {}", self.sent), self.sent as f64))
                .unwrap();
        }
    }

    /// Publishes every 20 ms until the peer has heard `n` more samples (no wait for discovery to settle
    /// first); returns what it printed of them. Token lines it prints meanwhile go to `tokens`.
    pub async fn until_heard(
        &mut self,
        peer: &mut Proc,
        n: usize,
        tokens: &mut Vec<Value>,
        why: &str,
    ) -> Vec<Value> {
        let started = Instant::now();
        let mut heard = Vec::new();
        let mut tick = tokio::time::interval(Duration::from_millis(20));
        while heard.len() < n {
            assert!(
                started.elapsed() < WAIT,
                "the peer heard {} of radar_ros's samples in {WAIT:?} ({why}); tokens seen: {tokens:#?}",
                heard.len()
            );
            tokio::select! {
                _ = tick.tick() => {
                    self.sent += 1;
                    self.publisher.publish(pose(&format!("to_peer {}", self.sent), self.sent as f64)).unwrap();
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
        heard
    }

    /// Has the peer publish (a line per 100 ms) until a sample arrives here.
    pub async fn hear_peer(&self, peer: &mut Proc, x: f64) -> (PoseStamped, MessageInfo) {
        let started = Instant::now();
        loop {
            assert!(
                started.elapsed() < WAIT,
                "nothing from the peer in {WAIT:?}"
            );
            peer.send(&format!(
                r#"{{"header": {{"frame_id": "from_peer"}}, "pose": {{"position": {{"x": {x}}}}}}}"#
            ))
            .await;
            if let Ok(got) =
                tokio::time::timeout(Duration::from_millis(100), self.subscription.async_take())
                    .await
            {
                let (msg, info) = got.unwrap();
                if msg.pose.position.x == x {
                    return (msg, info);
                }
            }
        }
    }
}

pub fn pose(frame: &str, x: f64) -> PoseStamped {
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

/// Checks what the peer printed of samples it heard: the message, and the attachment as the design says
/// (sequence numbers counting the publisher's samples, one GID, a source time of now, nothing after them).
pub fn check_heard(heard: &[Value]) {
    let now_ns = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .unwrap()
        .as_nanos() as i64;
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
            (now_ns - stamp).abs() < 60_000_000_000,
            "source time is now-ish: {v}"
        );
        assert_eq!(v["gid"].as_str().unwrap().len(), 32, "a 16-byte GID: {v}");
        assert_eq!(
            v["extra"], "",
            "a sample with no cause is rmw_zenoh's attachment exactly: {v}"
        );
    }
}

/// A network namespace of its own, held by a `sleep` started in it; gone (with its links) when dropped.
pub struct Netns {
    holder: std::process::Child,
}

impl Netns {
    pub fn new() -> Netns {
        let holder = Command::new("unshare")
            .args(["--net", "--", "sleep", "600"])
            .spawn()
            .expect("unshare (util-linux) starts a process in a new network namespace");
        let ns = Netns { holder };
        let mine = std::fs::read_link("/proc/self/ns/net").unwrap();
        let started = Instant::now();
        while std::fs::read_link(format!("/proc/{}/ns/net", ns.pid()))
            .ok()
            .as_ref()
            == Some(&mine)
        {
            assert!(started.elapsed() < WAIT, "unshare made no namespace");
            std::thread::sleep(Duration::from_millis(5));
        }
        ns.ip(&["link", "set", "lo", "up"]);
        ns
    }

    pub fn pid(&self) -> u32 {
        self.holder.id()
    }

    /// `ip ARGS` inside it.
    pub fn ip(&self, args: &[&str]) {
        let net = format!("--net=/proc/{}/ns/net", self.pid());
        run("nsenter", &[&[net.as_str(), "ip"], args].concat());
    }
}

impl Drop for Netns {
    fn drop(&mut self) {
        let _ = self.holder.kill();
        let _ = self.holder.wait();
    }
}

pub fn run(cmd: &str, args: &[&str]) {
    let out = Command::new(cmd)
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("{cmd}: {e}"));
    assert!(
        out.status.success(),
        "{cmd} {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// A veth pair from `a` (this namespace if `None`) to `b`, addressed `a_addr` and `b_addr` (CIDR).
pub fn link(a: Option<&Netns>, a_if: &str, a_addr: &str, b: &Netns, b_if: &str, b_addr: &str) {
    run(
        "ip",
        &["link", "add", a_if, "type", "veth", "peer", "name", b_if],
    );
    run("ip", &["link", "set", b_if, "netns", &b.pid().to_string()]);
    match a {
        Some(a) => {
            run("ip", &["link", "set", a_if, "netns", &a.pid().to_string()]);
            a.ip(&["addr", "add", a_addr, "dev", a_if]);
            a.ip(&["link", "set", a_if, "up"]);
        }
        None => {
            run("ip", &["addr", "add", a_addr, "dev", a_if]);
            run("ip", &["link", "set", a_if, "up"]);
        }
    }
    b.ip(&["addr", "add", b_addr, "dev", b_if]);
    b.ip(&["link", "set", b_if, "up"]);
}

/// Asserts that nothing in `from`'s namespace reaches `addr` (an address of this one): a TCP connect to it
/// fails as unreachable. Only the router's namespace links the two.
pub fn assert_unreachable(from: &Netns, addr: &str) {
    let out = Command::new("nsenter")
        .arg(format!("--net=/proc/{}/ns/net", from.pid()))
        .arg(python())
        .args([
            "-c",
            &format!("import socket; socket.create_connection(('{addr}', 9), timeout=2)"),
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("unreachable"),
        "no route from the other namespace to {addr}: {err}"
    );
}
