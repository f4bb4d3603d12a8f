//! `radar router` (issue 37): a Zenoh router as rmw_zenoh's `rmw_zenohd` runs one. With no configuration it
//! listens on rmw_zenoh's `tcp/[::]:7447`, and two peers written from rmw_zenoh's design document
//! (tests/python/zenoh_peer.py, the eclipse-zenoh wheel; nothing of radar_ros's) in their default layout
//! (connect to `tcp/localhost:7447`, multicast off) meet through it: one publishes, the other hears. SIGINT and
//! SIGTERM stop it with exit status 0 and no error line. A peer whose clock is an hour ahead (libfaketime), whose
//! samples the router routes (both peers its clients), is said once, as a warning naming its session, not
//! twice per sample (Zenoh's own warning and error, which radar's logging turns off). Without the `zenoh` feature the verb says how to get
//! one. Runs inside tests/isolated.sh, where port 7447 is free (run by tests/zenoh_feature.rs).
#![cfg(feature = "zenoh")]

use std::{
    path::PathBuf,
    process::Stdio,
    time::{Duration, Instant},
};

use serde_json::Value;
use tokio::io::{AsyncBufReadExt, AsyncWriteExt, BufReader, Lines};

const WAIT: Duration = Duration::from_secs(30);

/// Port 7447 is one router's at a time: the tests here take turns.
static PORT_7447: tokio::sync::Mutex<()> = tokio::sync::Mutex::const_new(());

struct Proc {
    child: tokio::process::Child,
    lines: Lines<BufReader<tokio::process::ChildStdout>>,
    stdin: tokio::process::ChildStdin,
}

impl Proc {
    fn start(mut cmd: tokio::process::Command) -> Proc {
        let mut child = cmd
            .env("PYTHONUNBUFFERED", "1")
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .kill_on_drop(true)
            .spawn()
            .expect("start");
        let lines = BufReader::new(child.stdout.take().unwrap()).lines();
        let stdin = child.stdin.take().unwrap();
        Proc {
            child,
            lines,
            stdin,
        }
    }

    async fn line(&mut self) -> String {
        match tokio::time::timeout(WAIT, self.lines.next_line()).await {
            Ok(Ok(Some(l))) => l,
            other => panic!("nothing more printed: {other:?}"),
        }
    }
}

fn peer(topic_in: &str, topic_out: &str) -> Proc {
    peer_with(topic_in, topic_out, "peer", &[])
}

/// [`peer`] in `mode` (`peer` or `client`), with `envs` added to its environment.
fn peer_with(topic_in: &str, topic_out: &str, mode: &str, envs: &[(&str, &str)]) -> Proc {
    let venv = std::env::var_os("RADAR_VENV")
        .expect("RADAR_VENV names the venv with eclipse-zenoh (tests/python_env.sh)");
    let mut cmd = tokio::process::Command::new(PathBuf::from(venv).join("bin/python"));
    cmd.arg(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../tests/python/zenoh_peer.py"))
        .args([
            "tcp/localhost:7447",
            "141",
            "std_msgs/msg/String",
            topic_in,
            topic_out,
            mode,
        ])
        .envs(envs.iter().copied());
    Proc::start(cmd)
}

async fn up(p: &mut Proc) {
    loop {
        let v: Value = serde_json::from_str(&p.line().await).unwrap();
        if v.get("up").is_some() {
            return;
        }
    }
}

async fn router_stops_cleanly_on(signal: i32) {
    let mut router = Proc::start({
        let mut c = tokio::process::Command::new(env!("CARGO_BIN_EXE_radar"));
        c.arg("router").stderr(Stdio::piped());
        c
    });
    let said = router.line().await;
    assert!(
        said.starts_with("radar router ") && said.contains("tcp/[::]:7447"),
        "{said}"
    );
    let mut a = peer("/router_probe/a", "/router_probe/b");
    let mut b = peer("/router_probe/b", "/router_probe/a");
    up(&mut a).await;
    up(&mut b).await;
    // a publishes (a line per 100 ms) until b hears it: they met through the router
    let started = Instant::now();
    'heard: loop {
        assert!(
            started.elapsed() < WAIT,
            "the peers never met through radar router"
        );
        a.stdin
            .write_all(b"{\"data\": \"through the router\"}\n")
            .await
            .unwrap();
        a.stdin.flush().await.unwrap();
        let deadline = tokio::time::Instant::now() + Duration::from_millis(100);
        while let Ok(Ok(Some(l))) = tokio::time::timeout_at(deadline, b.lines.next_line()).await {
            let v: Value = serde_json::from_str(&l).unwrap();
            if v["received"]["data"] == "through the router" {
                break 'heard;
            }
        }
    }
    // SAFETY: a plain kill(2) of the child's pid
    assert_eq!(
        unsafe { libc::kill(router.child.id().unwrap() as i32, signal) },
        0
    );
    let out = tokio::time::timeout(WAIT, router.child.wait_with_output())
        .await
        .expect("radar router stops when told");
    let out = out.unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "exit {:?}: {stderr}", out.status);
    assert!(!stderr.contains("ERROR"), "no error line: {stderr}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn radar_router_joins_design_document_peers_and_stops_cleanly() {
    assert!(
        std::env::var("RADAR_ISOLATED").as_deref() == Ok("1"),
        "run inside tests/isolated.sh: this test listens on port 7447, rmw_zenoh's router's"
    );
    let _port = PORT_7447.lock().await;
    router_stops_cleanly_on(libc::SIGINT).await;
    router_stops_cleanly_on(libc::SIGTERM).await;
}

const LIBFAKETIME: &str = "/usr/lib/x86_64-linux-gnu/faketime/libfaketime.so.1";

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_peer_an_hour_ahead_is_said_once_as_a_warning_not_an_error_per_sample() {
    assert!(
        std::env::var("RADAR_ISOLATED").as_deref() == Ok("1"),
        "run inside tests/isolated.sh: this test listens on port 7447, rmw_zenoh's router's"
    );
    assert!(
        std::path::Path::new(LIBFAKETIME).exists(),
        "{LIBFAKETIME} is missing: apt-get install faketime (tests/python_env.sh installs it)"
    );
    let _port = PORT_7447.lock().await;
    let mut router = Proc::start({
        let mut c = tokio::process::Command::new(env!("CARGO_BIN_EXE_radar"));
        c.arg("router")
            .env_remove("RUST_LOG")
            .stderr(Stdio::piped());
        c
    });
    assert!(router.line().await.starts_with("radar router "));
    // both clients of the router, so it routes (and stamps) every sample
    let mut ahead = peer_with(
        "/skew_probe/a",
        "/skew_probe/b",
        "client",
        &[
            ("LD_PRELOAD", LIBFAKETIME),
            ("FAKETIME", "+1h"),
            ("FAKETIME_DONT_FAKE_MONOTONIC", "1"),
        ],
    );
    let mut b = peer_with("/skew_probe/b", "/skew_probe/a", "client", &[]);
    let ahead_zid = loop {
        let v: Value = serde_json::from_str(&ahead.line().await).unwrap();
        if let Some(z) = v.get("up") {
            break z.as_str().unwrap().to_owned();
        }
    };
    up(&mut b).await;
    // the peer ahead publishes a line per 20 ms until b has heard 20
    let started = Instant::now();
    let mut heard = 0;
    while heard < 20 {
        assert!(
            started.elapsed() < WAIT,
            "b heard {heard} of the peer ahead's samples"
        );
        ahead
            .stdin
            .write_all(b"{\"data\": \"from an hour ahead\"}\n")
            .await
            .unwrap();
        ahead.stdin.flush().await.unwrap();
        let deadline = tokio::time::Instant::now() + Duration::from_millis(20);
        while let Ok(Ok(Some(l))) = tokio::time::timeout_at(deadline, b.lines.next_line()).await {
            let v: Value = serde_json::from_str(&l).unwrap();
            if v["received"]["data"] == "from an hour ahead" {
                heard += 1;
            }
        }
    }
    // SAFETY: a plain kill(2) of the child's pid
    assert_eq!(
        unsafe { libc::kill(router.child.id().unwrap() as i32, libc::SIGINT) },
        0
    );
    let out = tokio::time::timeout(WAIT, router.child.wait_with_output())
        .await
        .expect("radar router stops when told")
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "exit {:?}: {stderr}", out.status);
    assert!(!stderr.contains("ERROR"), "no error line: {stderr}");
    let notices: Vec<&str> = stderr.lines().filter(|l| l.contains("clock")).collect();
    assert_eq!(
        notices.len(),
        1,
        "one line about the clock, for {heard} samples: {stderr}"
    );
    assert!(
        notices[0].contains("WARN")
            && notices[0].contains(&ahead_zid)
            && notices[0].contains("NTP"),
        "the warning names the session ahead ({ahead_zid}) and what to do: {stderr}"
    );
}
