//! Shared helpers for the integration tests: participants on an explicit domain, and a probe that drives a
//! response's slots and records its signals from a separate DDS participant.
//!
//! Every test uses its own `ROS_DOMAIN_ID` (see `tests/README.md` for the allocation), so tests can run in
//! parallel. The suite runs inside `tests/isolated.sh` (a private network namespace), so DDS multicast never
//! leaves the machine; [`radar`] refuses to run outside it.

use std::{
    path::{Path, PathBuf},
    process::Stdio,
    time::Duration,
};

use serde_json::Value;
use tokio::io::{AsyncBufReadExt, BufReader, Lines};

use radar_ros::{
    msg::{Empty, ResponseState, RosMessage},
    settings::DiscoveryRange,
    topics::RawMessage,
    topics::RawPublisher,
    topics::SignalPublisher,
    topics::SignalSubscription,
    Radar, RadarBuilder,
};

/// How long any wait on DDS discovery may take before a test fails.
pub const DISCOVERY: Duration = Duration::from_secs(15);

/// Installs a log subscriber once (`RUST_LOG` to see more).
pub fn init_logs() {
    let _ = tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| "warn,rustdds=error,ros2_client::distributions=error,ros2_client::service::wrappers=error".into()),
        )
        .with_test_writer()
        .try_init();
}

/// Panics unless the tests run inside `tests/isolated.sh` (or `RADAR_ALLOW_NETWORK=1` says the host
/// network may carry DDS multicast).
pub fn require_isolation() {
    let ok = std::env::var("RADAR_ISOLATED").as_deref() == Ok("1")
        || std::env::var("RADAR_ALLOW_NETWORK").as_deref() == Ok("1");
    assert!(
        ok,
        "DDS tests send multicast discovery traffic: run them inside a private network namespace with \
         `tests/all.sh` (as README.md and .ci/run do) or `tests/isolated.sh cargo test --workspace`, or set \
         RADAR_ALLOW_NETWORK=1 to use the host network"
    );
}

/// UDP datagrams sent in this network namespace so far (`/proc/self/net/snmp`: every process of the test
/// namespace counts, so a test that reads it runs alone in its binary, and alone under nextest:
/// .config/nextest.toml).
pub fn datagrams_sent() -> u64 {
    let snmp = std::fs::read_to_string("/proc/self/net/snmp").expect("/proc/self/net/snmp");
    let mut udp = snmp.lines().filter(|l| l.starts_with("Udp:"));
    let (names, values) = (udp.next().unwrap(), udp.next().unwrap());
    let i = names
        .split_whitespace()
        .position(|n| n == "OutDatagrams")
        .expect("OutDatagrams");
    values.split_whitespace().nth(i).unwrap().parse().unwrap()
}

/// A participant in `domain` (subnet discovery, as ROS 2's default; inside the test namespace).
pub fn radar(domain: u16) -> Radar {
    radar_with(domain, |b| b)
}

/// [`radar`] with more settings of the builder.
pub fn radar_with(domain: u16, more: impl FnOnce(RadarBuilder) -> RadarBuilder) -> Radar {
    init_logs();
    require_isolation();
    more(
        Radar::builder()
            .domain_id(domain)
            .discovery_range(DiscoveryRange::Subnet),
    )
    .build()
    .expect("participant")
}

/// A signal as seen on the wire.
#[derive(Clone, Debug, PartialEq)]
pub enum Seen<P, O> {
    /// `started` with its payload.
    Started(P),
    /// `interrupted`.
    Interrupted,
    /// `exited` with its output.
    Exited(O),
}

/// Drives one response from another participant and records what it emits.
pub struct ResponseProbe<P: RosMessage, O: RosMessage> {
    /// Publishes on `start`.
    pub start: SignalPublisher<P>,
    /// Publishes on `interrupt`.
    pub interrupt: SignalPublisher<Empty>,
    /// Publishes on `exit`.
    pub exit: SignalPublisher<Empty>,
    started: SignalSubscription<P>,
    interrupted: SignalSubscription<Empty>,
    exited: SignalSubscription<O>,
    state: SignalSubscription<ResponseState>,
}

impl<P: RosMessage, O: RosMessage> ResponseProbe<P, O> {
    /// Connects to the response `name` and waits until every endpoint is matched.
    pub async fn connect(radar: &Radar, name: &str) -> Self {
        let p = ResponseProbe {
            start: radar.signal_publisher(&format!("{name}/start")).unwrap(),
            interrupt: radar
                .signal_publisher(&format!("{name}/interrupt"))
                .unwrap(),
            exit: radar.signal_publisher(&format!("{name}/exit")).unwrap(),
            started: radar
                .signal_subscription(&format!("{name}/started"))
                .unwrap(),
            interrupted: radar
                .signal_subscription(&format!("{name}/interrupted"))
                .unwrap(),
            exited: radar
                .signal_subscription(&format!("{name}/exited"))
                .unwrap(),
            state: radar.state_subscription(&format!("{name}/state")).unwrap(),
        };
        p.start
            .wait_for_subscribers(1)
            .timeout(DISCOVERY)
            .await
            .unwrap();
        p.interrupt
            .wait_for_subscribers(1)
            .timeout(DISCOVERY)
            .await
            .unwrap();
        p.exit
            .wait_for_subscribers(1)
            .timeout(DISCOVERY)
            .await
            .unwrap();
        p.started
            .wait_for_publishers(1)
            .timeout(DISCOVERY)
            .await
            .unwrap();
        p.interrupted
            .wait_for_publishers(1)
            .timeout(DISCOVERY)
            .await
            .unwrap();
        p.exited
            .wait_for_publishers(1)
            .timeout(DISCOVERY)
            .await
            .unwrap();
        p.state
            .wait_for_publishers(1)
            .timeout(DISCOVERY)
            .await
            .unwrap();
        p
    }

    /// Collects the next `n` signals, in the order the response emitted them (by source timestamp), failing
    /// after `timeout`.
    pub async fn signals(&self, n: usize, timeout: Duration) -> Vec<Seen<P, O>> {
        let mut got: Vec<(i64, Seen<P, O>)> = Vec::new();
        let deadline = tokio::time::Instant::now() + timeout;
        while got.len() < n {
            let next = tokio::time::timeout_at(deadline, async {
                tokio::select! {
                    r = self.started.recv_stamped() => r.map(|(m, t)| (t, Seen::Started(m))),
                    r = self.interrupted.recv_stamped() => r.map(|(_, t)| (t, Seen::Interrupted)),
                    r = self.exited.recv_stamped() => r.map(|(m, t)| (t, Seen::Exited(m))),
                }
            })
            .await;
            match next {
                Ok(Ok(x)) => got.push(x),
                Ok(Err(e)) => panic!("receive failed: {e}"),
                Err(_) => panic!(
                    "timed out after {timeout:?} with {} of {n} signals: {got:?}",
                    got.len()
                ),
            }
        }
        got.sort_by_key(|(t, _)| *t);
        got.into_iter().map(|(_, s)| s).collect()
    }

    /// Asserts that no signal arrives within `d`.
    pub async fn assert_quiet(&self, d: Duration) {
        let r = tokio::time::timeout(d, async {
            tokio::select! {
                r = self.started.recv() => format!("started {:?}", r),
                r = self.interrupted.recv() => format!("interrupted {:?}", r),
                r = self.exited.recv() => format!("exited {:?}", r),
            }
        })
        .await;
        if let Ok(s) = r {
            panic!("expected no signal, got {s}");
        }
    }

    /// Reads state messages until one satisfies `pred`; returns the labels seen on the way (inclusive).
    pub async fn states_until(
        &self,
        timeout: Duration,
        pred: impl Fn(&ResponseState) -> bool,
    ) -> (Vec<String>, ResponseState) {
        let mut labels = Vec::new();
        let deadline = tokio::time::Instant::now() + timeout;
        loop {
            match tokio::time::timeout_at(deadline, self.state.recv()).await {
                Ok(Ok(s)) => {
                    labels.push(s.state_label.clone());
                    if pred(&s) {
                        return (labels, s);
                    }
                }
                Ok(Err(e)) => panic!("state receive failed: {e}"),
                Err(_) => panic!("timed out waiting for a state; saw {labels:?}"),
            }
        }
    }
}

/// Waits until the async `cond` holds, checking every 50 ms; panics with `what` after `within`; how long it took.
pub async fn eventually_async<F, Fut>(within: Duration, what: &str, mut cond: F) -> Duration
where
    F: FnMut() -> Fut,
    Fut: std::future::Future<Output = bool>,
{
    let t0 = std::time::Instant::now();
    loop {
        if cond().await {
            return t0.elapsed();
        }
        assert!(t0.elapsed() < within, "{what}: not within {within:?}");
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

/// Waits until `cond` holds, checking every 5 ms; panics with `what` after `timeout`.
pub async fn eventually(timeout: Duration, what: &str, cond: impl Fn() -> bool) {
    let r = tokio::time::timeout(timeout, async {
        while !cond() {
            tokio::time::sleep(Duration::from_millis(5)).await;
        }
    })
    .await;
    assert!(r.is_ok(), "timed out after {timeout:?} waiting for {what}");
}

/// Publishes on `raw` (a `std_msgs/msg/String` topic of `r`'s participant, once a subscriber matched) a payload
/// that is not a string: a length of 2^31 - 1 bytes in a 4-byte message. Returns once `r` counted it as
/// malformed on that topic.
pub async fn publish_unreadable_string(r: &Radar, raw: &RawPublisher) {
    raw.wait_for_subscribers(1)
        .timeout(DISCOVERY)
        .await
        .unwrap();
    raw.publish(RawMessage::from_bytes(vec![0xff, 0xff, 0xff, 0x7f]))
        .unwrap();
    let topic = raw.topic().to_string();
    eventually(DISCOVERY, "the malformed payload to be counted", || {
        r.malformed_messages().iter().any(|m| m.topic == topic)
    })
    .await;
}

/// Calls a service until it answers (the server's discovery takes a moment), failing after `timeout`.
pub async fn call_service<Req, Resp>(
    client: &ros2_client::dds::Client<Req, Resp>,
    req: Req,
    timeout: Duration,
) -> Resp
where
    Req: ros2_client::Message + Clone + 'static,
    Resp: ros2_client::Message + 'static,
{
    let deadline = tokio::time::Instant::now() + timeout;
    loop {
        if let Ok(id) = client.async_send_request(req.clone()).await {
            if let Ok(Ok(resp)) = tokio::time::timeout(
                Duration::from_millis(500),
                client.async_receive_response(id),
            )
            .await
            {
                return resp;
            }
        }
        assert!(
            tokio::time::Instant::now() < deadline,
            "no answer from the service within {timeout:?}"
        );
    }
}

/// Sends one request and waits for its answer (for calls that must not be repeated).
pub async fn call_once<Req, Resp>(
    client: &ros2_client::dds::Client<Req, Resp>,
    req: Req,
    timeout: Duration,
) -> Resp
where
    Req: ros2_client::Message + Clone + 'static,
    Resp: ros2_client::Message + 'static,
{
    let id = client.async_send_request(req).await.expect("send request");
    tokio::time::timeout(timeout, client.async_receive_response(id))
        .await
        .expect("an answer in time")
        .expect("a readable answer")
}

/// Clients of a manager node's three services, on a node of `radar`'s participant.
pub struct ManagerClient {
    _node: ros2_client::dds::Node,
    /// `connect`.
    pub connect:
        ros2_client::dds::Client<radar_ros::msg::ConnectRequest, radar_ros::msg::ConnectResponse>,
    /// `disconnect`.
    pub disconnect: ros2_client::dds::Client<
        radar_ros::msg::DisconnectRequest,
        radar_ros::msg::DisconnectResponse,
    >,
    /// `list`.
    pub list: ros2_client::dds::Client<radar_ros::msg::ListRequest, radar_ros::msg::ListResponse>,
}

impl ManagerClient {
    /// Makes the clients and waits until the manager answers `list` (so the services are discovered).
    pub async fn new(radar: &Radar, manager: &str, node_name: &str) -> ManagerClient {
        use ros2_client::{dds::ServiceMapping, Name, NodeName, NodeOptions, ServiceTypeName};
        let mut node = radar
            .dds_context()
            .expect("a DDS Radar")
            .new_node(
                NodeName::new("/", node_name).unwrap(),
                NodeOptions::new()
                    .enable_rosout(false)
                    .start_parameter_services(false),
            )
            .unwrap();
        let q = radar_ros::qos::signal_qos();
        let svc = |n: &str| Name::new(manager, n).unwrap();
        let c = ManagerClient {
            connect: node
                .create_client(
                    ServiceMapping::Enhanced,
                    &svc("connect"),
                    &ServiceTypeName::new("radar_msgs", "Connect"),
                    q.clone(),
                    q.clone(),
                )
                .unwrap(),
            disconnect: node
                .create_client(
                    ServiceMapping::Enhanced,
                    &svc("disconnect"),
                    &ServiceTypeName::new("radar_msgs", "Disconnect"),
                    q.clone(),
                    q.clone(),
                )
                .unwrap(),
            list: node
                .create_client(
                    ServiceMapping::Enhanced,
                    &svc("list"),
                    &ServiceTypeName::new("radar_msgs", "List"),
                    q.clone(),
                    q,
                )
                .unwrap(),
            _node: node,
        };
        call_service(&c.list, radar_ros::msg::ListRequest::default(), DISCOVERY).await;
        // the three servers live on one node; give the other two the moment discovery of one took
        tokio::time::sleep(Duration::from_millis(200)).await;
        c
    }
}

/// A response named `name` that counts its runs and returns at once; the count is shared.
pub fn counter(
    radar: &Radar,
    name: &str,
) -> (
    radar_ros::ResponseHandle,
    std::sync::Arc<std::sync::atomic::AtomicU64>,
) {
    use std::sync::{atomic::Ordering, Arc};
    let n = Arc::new(std::sync::atomic::AtomicU64::new(0));
    let c = n.clone();
    let h = radar
        .spawn_response(
            name,
            radar_ros::FnResponse::new(move |_: Empty| {
                c.fetch_add(1, Ordering::SeqCst);
                async { Ok(Empty::default()) }
            }),
        )
        .unwrap();
    (h, n)
}

/// Starts `radar_test_peer ARGS` in `domain`, and returns it with the first line it prints.
pub async fn peer_with_first_line(
    peer: &str,
    domain: u16,
    args: &[&str],
) -> (tokio::process::Child, String) {
    use tokio::io::{AsyncBufReadExt, BufReader};
    let mut child = tokio::process::Command::new(peer)
        .args(args)
        .env("ROS_DOMAIN_ID", domain.to_string())
        .env("RUST_LOG", "error")
        .stdout(std::process::Stdio::piped())
        .kill_on_drop(true)
        .spawn()
        .expect("start radar_test_peer");
    let mut lines = BufReader::new(child.stdout.take().unwrap()).lines();
    let line = tokio::time::timeout(Duration::from_secs(30), lines.next_line())
        .await
        .expect("the peer prints in time")
        .expect("readable output")
        .expect("a line");
    (child, line)
}

/// A `radar_test_peer host` process: another program with its own participant, hosting components as told
/// (see `bin/peer.rs`), and stopped, continued or killed as a test wants.
pub struct HostPeer {
    child: tokio::process::Child,
    stdin: tokio::process::ChildStdin,
    lines: tokio::io::Lines<tokio::io::BufReader<tokio::process::ChildStdout>>,
    /// What it wrote on stderr so far (also passed on to this process's stderr).
    stderr: std::sync::Arc<std::sync::Mutex<Vec<String>>>,
}

impl HostPeer {
    /// Starts one in `domain` (the path is `env!("CARGO_BIN_EXE_radar_test_peer")`) and waits until it runs.
    /// It logs errors only (`RADAR_PEER_LOG` sets its `RUST_LOG`).
    pub async fn start(peer: &str, domain: u16) -> HostPeer {
        let log = std::env::var("RADAR_PEER_LOG").unwrap_or_else(|_| "error".into());
        Self::start_logging(peer, domain, &log).await
    }

    /// [`HostPeer::start`] with its `RUST_LOG` set to `log`.
    pub async fn start_logging(peer: &str, domain: u16, log: &str) -> HostPeer {
        Self::start_on(None, peer, domain, log).await
    }

    /// [`HostPeer::start_logging`] on `host` (another network namespace), if given.
    pub async fn start_on(host: Option<&NetHost>, peer: &str, domain: u16, log: &str) -> HostPeer {
        use tokio::io::AsyncBufReadExt;
        let mut cmd = match host {
            Some(h) => {
                let mut c = tokio::process::Command::new("nsenter");
                c.arg(format!("--net=/proc/{}/ns/net", h.pid)).arg(peer);
                c
            }
            None => tokio::process::Command::new(peer),
        };
        let mut child = cmd
            .arg("host")
            .env("ROS_DOMAIN_ID", domain.to_string())
            .env("RUST_LOG", log)
            .env("NO_COLOR", "1")
            .stdin(std::process::Stdio::piped())
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .kill_on_drop(true)
            .spawn()
            .expect("start radar_test_peer host");
        let stdin = child.stdin.take().unwrap();
        let lines = tokio::io::BufReader::new(child.stdout.take().unwrap()).lines();
        let stderr = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
        let mut err_lines = tokio::io::BufReader::new(child.stderr.take().unwrap()).lines();
        let keep = stderr.clone();
        tokio::spawn(async move {
            while let Ok(Some(l)) = err_lines.next_line().await {
                eprintln!("[peer] {l}");
                keep.lock().unwrap().push(l);
            }
        });
        let mut p = HostPeer {
            child,
            stdin,
            lines,
            stderr,
        };
        assert_eq!(p.line().await, "ready");
        p
    }

    /// The peer's next line. Waits longer than any command of the peer does (30 s for discovery, or the
    /// milliseconds a command names, 60 s at most in these tests), so that a slow peer answers with its own
    /// `err ...` saying what it waited for instead of the test giving up first (seen on a loaded machine: a
    /// `collect-arm` over the lossy link outlived a 15 s wait here).
    async fn line(&mut self) -> String {
        const ANSWER: Duration = Duration::from_secs(90);
        tokio::time::timeout(ANSWER, self.lines.next_line())
            .await
            .expect("the peer answers in time")
            .expect("readable output")
            .unwrap_or_default()
    }

    /// Sends one command without waiting for an answer.
    pub async fn send(&mut self, command: &str) {
        use tokio::io::AsyncWriteExt;
        self.stdin
            .write_all(format!("{command}\n").as_bytes())
            .await
            .expect("the peer reads its stdin");
        self.stdin.flush().await.unwrap();
    }

    /// Sends one command and asserts that it answers `ok`.
    pub async fn run(&mut self, command: &str) {
        self.send(command).await;
        let answer = self.line().await;
        assert_eq!(answer, "ok", "peer command {command:?}");
    }

    /// Sends one command and returns the lines it answers before `ok`.
    pub async fn query(&mut self, command: &str) -> Vec<String> {
        self.send(command).await;
        let mut out = Vec::new();
        loop {
            let l = self.line().await;
            if l == "ok" {
                return out;
            }
            assert!(!l.starts_with("err "), "peer command {command:?}: {l}");
            out.push(l);
        }
    }

    /// The lines it wrote on stderr so far.
    pub fn stderr(&self) -> Vec<String> {
        self.stderr.lock().unwrap().clone()
    }

    /// Its process id.
    pub fn pid(&self) -> u32 {
        self.child.id().expect("running")
    }

    /// Sends a signal (`KILL`, `STOP`, `CONT`, `TERM`) to it.
    pub fn signal(&self, sig: &str) {
        let ok = std::process::Command::new("kill")
            .args([&format!("-{sig}"), &self.pid().to_string()])
            .status()
            .map(|s| s.success())
            .unwrap_or(false);
        assert!(ok, "kill -{sig} {}", self.pid());
    }

    /// Waits for it to exit (after `quit`, `emit-exit` or a kill); returns its exit status.
    pub async fn wait(mut self) -> std::process::ExitStatus {
        tokio::time::timeout(DISCOVERY, self.child.wait())
            .await
            .expect("the peer exits in time")
            .expect("wait")
    }
}

/// A small seeded generator (xorshift64) for the moments of faults: a run is repeated by its seed. Seed it
/// with an odd number.
pub struct Rng(pub u64);

impl Rng {
    /// The next number.
    pub fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
}

/// A network namespace standing in for another machine: lo plus whatever link joins it to the other host.
/// It lives as long as this value (a `sleep` process holds it).
pub struct NetHost {
    holder: std::process::Child,
    /// The holder's pid: `nsenter --net=/proc/PID/ns/net` runs a program on this host.
    pub pid: u32,
    /// Its address on the link.
    pub addr: String,
}

impl NetHost {
    fn new(addr: &str) -> NetHost {
        let holder = std::process::Command::new("unshare")
            .args(["--net", "--", "sleep", "3600"])
            .spawn()
            .expect("unshare (util-linux) makes a network namespace: the tests run as root in isolated.sh");
        let h = NetHost {
            pid: holder.id(),
            holder,
            addr: addr.to_owned(),
        };
        // the namespace exists once unshare has exec'd sleep: wait for its ns to differ from ours
        let mine = std::fs::read_link("/proc/self/ns/net").unwrap();
        for _ in 0..500 {
            match std::fs::read_link(format!("/proc/{}/ns/net", h.pid)) {
                Ok(ns) if ns != mine => break,
                _ => std::thread::sleep(Duration::from_millis(2)),
            }
        }
        h.ip(&["link", "set", "lo", "up"]);
        h
    }

    /// Runs `ip ARGS` on this host, panicking if it fails.
    pub fn ip(&self, args: &[&str]) {
        let out = std::process::Command::new("nsenter")
            .arg(format!("--net=/proc/{}/ns/net", self.pid))
            .arg("ip")
            .args(args)
            .output()
            .expect("nsenter and ip (iproute2)");
        assert!(
            out.status.success(),
            "ip {}: {}",
            args.join(" "),
            String::from_utf8_lossy(&out.stderr)
        );
    }

    /// Gives interface `dev` this host's address, brings it up with multicast, and routes multicast
    /// (DDS discovery) through it.
    fn configure(&self, dev: &str) {
        self.ip(&["addr", "add", &format!("{}/24", self.addr), "dev", dev]);
        self.ip(&["link", "set", dev, "up"]);
        self.ip(&["link", "set", dev, "multicast", "on"]);
        self.ip(&["route", "add", "224.0.0.0/4", "dev", dev]);
    }
}

impl Drop for NetHost {
    fn drop(&mut self) {
        let _ = self.holder.kill();
        let _ = self.holder.wait();
    }
}

/// Two hosts joined by one link: a veth pair (a clean cable), or a user-space relay that drops, delays
/// and reorders packets (see `bin/netem.rs`).
pub struct TwoHosts {
    /// The first host.
    pub a: NetHost,
    /// The second host.
    pub b: NetHost,
    relay: Option<std::process::Child>,
}

impl TwoHosts {
    /// Hosts 10.88.0.1 and 10.88.0.2 on a veth pair.
    pub fn cable() -> TwoHosts {
        let (a, b) = (NetHost::new("10.88.0.1"), NetHost::new("10.88.0.2"));
        let out = std::process::Command::new("ip")
            .args([
                "link",
                "add",
                "h0",
                "netns",
                &a.pid.to_string(),
                "type",
                "veth",
                "peer",
                "name",
                "h1",
            ])
            .args(["netns", &b.pid.to_string()])
            .output()
            .expect("ip (iproute2)");
        assert!(
            out.status.success(),
            "veth: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        a.configure("h0");
        b.configure("h1");
        TwoHosts { a, b, relay: None }
    }

    /// Hosts 10.89.0.1 and 10.89.0.2 joined by `radar_test_netem` (path `netem`): each packet is lost with
    /// probability `loss`, else delivered after `delay_ms` plus up to `jitter_ms`.
    pub fn lossy(netem: &str, loss: f64, delay_ms: f64, jitter_ms: f64, seed: u64) -> TwoHosts {
        use std::io::BufRead;
        let (a, b) = (NetHost::new("10.89.0.1"), NetHost::new("10.89.0.2"));
        let mut relay = std::process::Command::new(netem)
            .args([
                a.pid.to_string(),
                b.pid.to_string(),
                loss.to_string(),
                delay_ms.to_string(),
                jitter_ms.to_string(),
                seed.to_string(),
            ])
            .stdin(std::process::Stdio::piped())
            .stdout(std::process::Stdio::piped())
            .spawn()
            .expect("start radar_test_netem");
        let mut first = String::new();
        std::io::BufReader::new(relay.stdout.take().unwrap())
            .read_line(&mut first)
            .unwrap();
        assert_eq!(first.trim(), "ready", "radar_test_netem did not start");
        a.configure("tun0");
        b.configure("tun0");
        TwoHosts {
            a,
            b,
            relay: Some(relay),
        }
    }
}

impl Drop for TwoHosts {
    fn drop(&mut self) {
        if let Some(mut r) = self.relay.take() {
            drop(r.stdin.take()); // it prints its counts and ends
            let _ = r.wait();
        }
    }
}

// ------------------------------------------------------------------------------------------------ rclpy

/// How long a Python process may stay silent when a line is expected.
pub const PY_TIMEOUT: Duration = Duration::from_secs(20);

/// The stdout of a finished command (a cargo build or test run by a test), which must have succeeded: else the
/// test fails with `what` and both outputs.
pub fn check(out: &std::process::Output, what: &str) -> String {
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "{what} failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}

/// Asserts that cargo test's output `out` has each of `tests` run and passed.
pub fn ran_and_passed(out: &str, tests: &[&str]) {
    for t in tests {
        assert!(
            out.lines()
                .any(|l| l.starts_with("test ") && l.contains(t) && l.ends_with("... ok")),
            "{t} ran and passed:\n{out}"
        );
    }
}

// ------------------------------------------------------------------------------------------ feature builds

/// The repository's root.
pub fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_owned()
}

/// The venv's interpreter. Missing venv: fail, saying how to build it.
pub fn python() -> PathBuf {
    let venv = std::env::var_os("RADAR_VENV")
        .map(PathBuf::from)
        .unwrap_or_else(|| repo().join("target/ros2-venv"));
    let py = venv.join("bin/python");
    assert!(
        py.exists(),
        "the rclpy venv is missing at {}: run tests/python_env.sh (tests/isolated.sh runs it before the \
         tests; see its output for why it failed)",
        venv.display()
    );
    py
}

/// The interpreter of ROS 2 Kilted's rclpy venv (inside the Jazzy one; `python_env.sh` builds both).
pub fn kilted_python() -> PathBuf {
    let py = python()
        .parent()
        .unwrap()
        .parent()
        .unwrap()
        .join("kilted/bin/python");
    assert!(
        py.exists(),
        "the Kilted rclpy venv is missing at {}: run tests/python_env.sh",
        py.display()
    );
    py
}

/// A Python process (the rclpy venv's interpreter, Fast DDS) whose stdout is JSON lines (or plain lines from the
/// examples), killed when dropped.
pub struct Py {
    child: tokio::process::Child,
    lines: Lines<BufReader<tokio::process::ChildStdout>>,
    /// Its stdin: a script that waits for the test (`sys.stdin.readline()`) goes on at [`Py::proceed`].
    stdin: tokio::process::ChildStdin,
    what: String,
}

impl Py {
    pub fn start(domain: u16, script: &str, args: &[&str]) -> Py {
        Py::start_with_env(domain, script, args, &[])
    }

    /// [`Py::start`] with more environment variables.
    pub fn start_with_env(domain: u16, script: &str, args: &[&str], env: &[(&str, &str)]) -> Py {
        Py::start_in(&python(), domain, script, args, env)
    }

    /// [`Py::start_with_env`] with another interpreter (another distro's venv: [`kilted_python`]).
    pub fn start_in(
        interpreter: &Path,
        domain: u16,
        script: &str,
        args: &[&str],
        env: &[(&str, &str)],
    ) -> Py {
        let mut child = tokio::process::Command::new(interpreter)
            .envs(env.iter().copied())
            .arg(repo().join(script))
            .args(args)
            .env("ROS_DOMAIN_ID", domain.to_string())
            .env("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")
            .env("PYTHONUNBUFFERED", "1")
            .env_remove("ROS_AUTOMATIC_DISCOVERY_RANGE")
            .stdout(Stdio::piped())
            .stdin(Stdio::piped())
            .kill_on_drop(true)
            .spawn()
            .expect("start the venv's python");
        let lines = BufReader::new(child.stdout.take().unwrap()).lines();
        let stdin = child.stdin.take().unwrap();
        Py {
            child,
            lines,
            stdin,
            what: format!("{script} {}", args.join(" ")),
        }
    }

    /// Kills the process (SIGKILL) at once.
    pub fn kill(&mut self) {
        self.child.start_kill().expect("kill the python process");
    }

    /// Lets a script waiting on its stdin go on.
    pub async fn proceed(&mut self) {
        use tokio::io::AsyncWriteExt;
        self.stdin
            .write_all(b"go\n")
            .await
            .expect("the script reads its stdin");
        self.stdin.flush().await.unwrap();
    }

    /// Starts one of `examples/python/` and waits until it says it is up.
    pub async fn example(domain: u16, script: &str, args: &[&str]) -> Py {
        let mut py = Py::start(domain, &format!("examples/python/{script}"), args);
        py.expect_line("up").await;
        py
    }

    pub fn interop(domain: u16, args: &[&str]) -> Py {
        Py::start(domain, "tests/python/interop.py", args)
    }

    pub async fn line(&mut self) -> String {
        match tokio::time::timeout(PY_TIMEOUT, self.lines.next_line()).await {
            Ok(Ok(Some(l))) => l,
            Ok(Ok(None)) => {
                let status = self.child.wait().await;
                panic!(
                    "{} ended ({status:?}) before printing what was expected; its stderr is above",
                    self.what
                )
            }
            Ok(Err(e)) => panic!("{}: unreadable output: {e}", self.what),
            Err(_) => panic!("{}: nothing printed for {PY_TIMEOUT:?}", self.what),
        }
    }

    pub async fn json(&mut self) -> Value {
        let l = self.line().await;
        serde_json::from_str(&l).unwrap_or_else(|e| panic!("{}: not JSON ({e}): {l}", self.what))
    }

    /// The next JSON line that has `key`.
    pub async fn json_with(&mut self, key: &str) -> Value {
        loop {
            let v = self.json().await;
            if v.get(key).is_some() {
                return v;
            }
        }
    }

    /// Reads lines until one is `want`, for at most [`PY_TIMEOUT`]; returns the lines before it.
    pub async fn expect_line(&mut self, want: &str) -> Vec<String> {
        let mut before = Vec::new();
        let found = tokio::time::timeout(PY_TIMEOUT, async {
            loop {
                let l = self.line().await;
                if l == want {
                    return;
                }
                before.push(l);
            }
        })
        .await;
        assert!(
            found.is_ok(),
            "{}: no line {want:?} within {PY_TIMEOUT:?}; last lines: {:?}",
            self.what,
            &before[before.len().saturating_sub(5)..]
        );
        before
    }

    pub async fn succeeds(mut self) {
        let status = tokio::time::timeout(PY_TIMEOUT, self.child.wait())
            .await
            .unwrap_or_else(|_| panic!("{} did not end", self.what))
            .unwrap();
        assert!(status.success(), "{} failed: {status}", self.what);
    }
}
