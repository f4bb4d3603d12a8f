//! `radar router` (issue 37): a Zenoh router as rmw_zenoh's `rmw_zenohd` runs one. With no configuration it
//! listens on rmw_zenoh's `tcp/[::]:7447`, and two peers written from rmw_zenoh's design document
//! (tests/python/zenoh_peer.py, the eclipse-zenoh wheel; nothing of radar_ros's) in their default layout
//! (connect to `tcp/localhost:7447`, multicast off) meet through it: one publishes, the other hears. SIGINT and
//! SIGTERM stop it with exit status 0 and no error line. Without the `zenoh` feature the verb says how to get
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
        ]);
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
    router_stops_cleanly_on(libc::SIGINT).await;
    router_stops_cleanly_on(libc::SIGTERM).await;
}
