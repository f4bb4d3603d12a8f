//! The `radar` verbs over Zenoh (issue 37): with `RMW_IMPLEMENTATION=rmw_zenoh_cpp`, as a ROS 2 user switches
//! middleware, `radar ls`, `cat` (with a component's parameters, read through its parameter services),
//! `watch`, `record` (read back by the Python MCAP readers) and `replay`, `view` (its WebSocket), `act`,
//! `inject`, `con`, `graph` and `dis` (through the `radar_manager` binary) see and drive this test's components
//! through `radar router`, as `radar_cli.rs` and `view.rs` check them over DDS; a connection made through the
//! manager is shown once, under it; and watching, recording or viewing does not make an unlistened event check
//! (their readers declare no liveliness token: ros2-client patch 18). No verb logs an error; the view, the
//! manager and the router stop cleanly on SIGTERM. Domain 143; runs inside tests/isolated.sh, where port 7447
//! is free (run by tests/zenoh_feature.rs).
#![cfg(feature = "zenoh")]

mod common;

use std::{
    process::{Output, Stdio},
    sync::{
        atomic::{AtomicU64, Ordering},
        Arc,
    },
    time::Duration,
};

use common::Never;
use futures::StreamExt;
use radar_ros::{
    msg::{Empty, StringMsg},
    FnResponse, Radar, TimerEvent,
};
use serde_json::Value;
use tokio::io::AsyncBufReadExt;

const DOMAIN: &str = "143";

/// `radar ARGS` in this test's environment (Zenoh, domain 143).
async fn radar(args: &[&str]) -> Output {
    tokio::time::timeout(
        Duration::from_secs(30),
        tokio::process::Command::new(env!("CARGO_BIN_EXE_radar"))
            .args(args)
            .env_remove("RUST_LOG")
            .kill_on_drop(true)
            .output(),
    )
    .await
    .unwrap_or_else(|_| panic!("radar {args:?} did not end"))
    .unwrap()
}

/// The JSON document a successful `radar ARGS --json` printed last; no error line.
fn ok_json(args: &[&str], out: &Output) -> Value {
    let (stdout, stderr) = (
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr),
    );
    assert!(out.status.success(), "radar {args:?} failed: {stderr}");
    // Known and open (issue 70's session, docs/zenoh.md): Zenoh's session logs "Received Query for unknown
    // key_expr: Remote resource N not found" when a peer's query names a key expression whose declaration it
    // has not taken yet; seen in 4 of 9 runs of this test (also with /diagnostics off), not bisected. Every
    // other error line still fails the test.
    let errors: Vec<&str> = stderr
        .lines()
        .filter(|l| l.contains("ERROR"))
        .filter(|l| {
            !(l.contains("zenoh::api::session")
                && l.contains("Received Query for unknown key_expr"))
        })
        .collect();
    assert!(
        errors.is_empty(),
        "radar {args:?} logged an error: {stderr}"
    );
    let last = stdout.lines().last().unwrap_or_default();
    serde_json::from_str(last)
        .unwrap_or_else(|e| panic!("radar {args:?} printed no JSON ({e}): {stdout}"))
}

async fn json(args: &[&str]) -> Value {
    let mut all = args.to_vec();
    all.push("--json");
    ok_json(args, &radar(&all).await)
}

/// A binary of this package in this test's environment, its stdout piped.
fn spawn(bin: &str, args: &[&str]) -> tokio::process::Child {
    tokio::process::Command::new(bin)
        .args(args)
        .env_remove("RUST_LOG")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .kill_on_drop(true)
        .spawn()
        .unwrap()
}

/// The next JSON text message on a `radar view` WebSocket (15 s at most).
async fn ws_json(
    ws: &mut tokio_tungstenite::WebSocketStream<
        tokio_tungstenite::MaybeTlsStream<tokio::net::TcpStream>,
    >,
) -> Value {
    loop {
        let m = tokio::time::timeout(Duration::from_secs(15), ws.next())
            .await
            .expect("the view says more")
            .expect("the socket is open")
            .unwrap();
        if let tokio_tungstenite::tungstenite::Message::Text(t) = m {
            return serde_json::from_str(&t).unwrap();
        }
    }
}

/// The first line `child` prints.
async fn first_line(child: &mut tokio::process::Child) -> String {
    let out = child.stdout.as_mut().unwrap();
    let mut line = String::new();
    tokio::time::timeout(
        Duration::from_secs(30),
        tokio::io::BufReader::new(out).read_line(&mut line),
    )
    .await
    .expect("it says it is up")
    .unwrap();
    line
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_radar_verbs_drive_components_over_zenoh_and_watching_activates_nothing() {
    assert!(
        std::env::var("RADAR_ISOLATED").as_deref() == Ok("1"),
        "run inside tests/isolated.sh: this test starts a Zenoh router on port 7447, rmw_zenoh's"
    );
    // the one test of this binary: its environment is its own, and its children's
    std::env::set_var("ROS_DOMAIN_ID", DOMAIN);
    std::env::set_var("RMW_IMPLEMENTATION", "rmw_zenoh_cpp");
    let mut router = spawn(env!("CARGO_BIN_EXE_radar"), &["router"]);
    assert!(first_line(&mut router).await.starts_with("radar router "));
    let mut manager = spawn(env!("CARGO_BIN_EXE_radar_manager"), &["zv_manager"]);
    assert!(first_line(&mut manager)
        .await
        .contains("serving as /zv_manager"));

    let r = Radar::builder()
        .program("zv_host")
        .handle_signals(false)
        .build()
        .unwrap();
    assert!(r.over_zenoh());
    let tick = r
        .spawn_event("/zv/tick", TimerEvent::new(Duration::from_millis(100)))
        .unwrap();
    let never = r.spawn_event("/zv/never", Never).unwrap();
    let say = r
        .spawn_response(
            "/zv/say",
            FnResponse::new(|s: StringMsg| async move {
                tokio::time::sleep(Duration::from_millis(300)).await;
                Ok(s)
            }),
        )
        .unwrap();
    let slow = r
        .spawn_response(
            "/zv/slow",
            FnResponse::new(|_: Empty| async {
                tokio::time::sleep(Duration::from_secs(60)).await;
                Ok(Empty::default())
            }),
        )
        .unwrap();
    let runs = Arc::new(AtomicU64::new(0));
    let n = runs.clone();
    let _count = r
        .spawn_response(
            "/zv/count",
            FnResponse::new(move |_: Empty| {
                n.fetch_add(1, Ordering::SeqCst);
                async { Ok(Empty::default()) }
            }),
        )
        .unwrap();
    let _armed = r
        .whenever(&never)
        .start(&say)
        .map(|_: Empty| StringMsg::from("never"))
        .await
        .unwrap();

    // ls: every component with its types; -l its state
    let ls = json(&["ls", "/zv", "-l"]).await;
    let names: Vec<&str> = ls
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["name"].as_str().unwrap())
        .collect();
    assert_eq!(
        names,
        ["/zv/count", "/zv/never", "/zv/say", "/zv/slow", "/zv/tick"],
        "{ls}"
    );
    assert_eq!(ls[2]["types"]["start"], "std_msgs/msg/String", "{ls}");
    assert_eq!(ls[1]["state"]["active"], true, "never is armed: {ls}");
    assert_eq!(
        ls[4]["state"]["active"], false,
        "tick has no listener: {ls}"
    );

    // cat: the connection this program made, and a component's parameters through its services
    let cat = json(&["cat", "/zv/say"]).await;
    assert_eq!(
        cat["connections"][0]["source"], "/zv/never/triggered",
        "{cat}"
    );
    let cat = json(&["cat", "/zv/never"]).await;
    assert_eq!(
        cat["parameters"],
        serde_json::json!({"gain": 1.5, "mode": "fast"}),
        "{cat}"
    );

    // watch and record (in the background) see what act and inject do, and leave the unlistened tick inactive
    let watcher = tokio::spawn(radar(&["watch", "--json", "--duration", "6"]));
    let file = std::env::temp_dir().join(format!("zenoh_verbs_{}.mcap", std::process::id()));
    let file_s = file.to_str().unwrap().to_owned();
    let recorder = {
        let file_s = file_s.clone();
        tokio::spawn(async move {
            let args = ["record", "-o", &file_s, "--duration", "6", "--json"];
            radar(&args).await
        })
    };
    tokio::time::sleep(Duration::from_secs(2)).await;
    let started = json(&["act", "start", "/zv/say", "{data: kitchen}"]).await;
    assert_eq!(started["signal"], "started");
    assert_eq!(started["payload"]["data"], "kitchen");
    let injected = json(&["inject", "/zv/slow/start"]).await;
    assert_eq!(injected["type"], "std_msgs/msg/Empty");
    let mut state = slow.watch_state();
    tokio::time::timeout(Duration::from_secs(10), state.wait_for(|s| s.starts == 1))
        .await
        .expect("the injected start ran")
        .unwrap();
    let interrupted = json(&["act", "interrupt", "/zv/slow"]).await;
    assert_eq!(interrupted["signal"], "interrupted");
    let out = watcher.await.unwrap();
    ok_json(&["watch"], &out);
    let timeline: Vec<Value> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let saw = |component: &str, event: &str| {
        timeline
            .iter()
            .any(|v| v["component"] == component && v["event"] == event)
    };
    assert!(saw("/zv/say", "started"), "{timeline:?}");
    assert!(saw("/zv/say", "exited"), "{timeline:?}");
    assert!(saw("/zv/slow", "interrupted"), "{timeline:?}");
    // the recording, read back by the independent Python readers (tests/python/mcap_read.py)
    let recorded = recorder.await.unwrap();
    let summary = ok_json(&["record"], &recorded);
    let read = std::process::Command::new(radar_test_util::python())
        .arg(radar_test_util::repo().join("tests/python/mcap_read.py"))
        .arg(&file)
        .output()
        .unwrap();
    assert!(
        read.status.success(),
        "{}",
        String::from_utf8_lossy(&read.stderr)
    );
    let messages: Vec<Value> = String::from_utf8_lossy(&read.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(messages.len() as u64, summary["messages"].as_u64().unwrap());
    let on =
        |topic: &str| -> Vec<&Value> { messages.iter().filter(|m| m["topic"] == topic).collect() };
    assert_eq!(
        on("/zv/say/started")[0]["msg"]["data"],
        "kitchen",
        "{messages:?}"
    );
    assert_eq!(on("/zv/slow/interrupted").len(), 1, "{messages:?}");
    assert!(!on("/zv/say/state").is_empty(), "{messages:?}");
    // replay: the recorded signals published again over Zenoh; say's started, with its payload, heard here
    let again = r
        .signal_subscription::<StringMsg>("/zv/say/started")
        .unwrap();
    let replayed = json(&["replay", &file_s, "--rate", "4"]).await;
    // replay publishes the recorded signals again: not the states, the slot samples, the connection lists
    // or radar record's own /radar/trace, which a recording also keeps (issue 69)
    let signals: Vec<&str> = messages
        .iter()
        .map(|m| m["topic"].as_str().unwrap())
        .filter(|t| {
            [
                "/triggered",
                "/started",
                "/interrupted",
                "/exited",
                "/dropped",
            ]
            .iter()
            .any(|s| t.ends_with(s))
        })
        .collect();
    assert_eq!(
        replayed["published"].as_u64().unwrap() as usize,
        signals.len(),
        "{replayed}; recorded: {signals:?}"
    );
    let heard = tokio::time::timeout(Duration::from_secs(10), again.recv())
        .await
        .expect("the replayed started")
        .unwrap();
    assert_eq!(heard.data, "kitchen");
    let _ = std::fs::remove_file(&file);
    assert_eq!(say.state().completed, 1);
    assert_eq!(
        tick.state().activations,
        0,
        "watching (and every other verb) left the unlistened event inactive"
    );

    // view: a page's WebSocket gets a snapshot of every component, then each signal as it happens
    let mut view = spawn(
        env!("CARGO_BIN_EXE_radar"),
        &["view", "--port", "0", "--json"],
    );
    let said: Value = serde_json::from_str(&first_line(&mut view).await).unwrap();
    let url = said["url"]
        .as_str()
        .unwrap()
        .replacen("http://", "ws://", 1);
    let (mut ws, _) = tokio_tungstenite::connect_async(format!("{url}ws"))
        .await
        .unwrap();
    let snapshot = ws_json(&mut ws).await;
    assert_eq!(snapshot["type"], "snapshot", "{snapshot}");
    // every component, as the view discovers them (in the snapshot or the changes after it)
    let want = ["/zv/count", "/zv/never", "/zv/say", "/zv/slow", "/zv/tick"];
    let mut shown = std::collections::BTreeSet::new();
    let mut m = snapshot;
    loop {
        for c in m["components"].as_array().unwrap() {
            shown.insert(c["name"].as_str().unwrap().to_owned());
        }
        if want.iter().all(|w| shown.contains(*w)) {
            break;
        }
        m = ws_json(&mut ws).await;
    }
    json(&["act", "start", "/zv/say", "{data: viewed}"]).await;
    loop {
        let m = ws_json(&mut ws).await;
        let lines = m["timeline"].as_array().cloned().unwrap_or_default();
        if lines
            .iter()
            .any(|l| l["component"] == "/zv/say" && l["signal"] == "started")
        {
            break;
        }
    }
    drop(ws);
    stop(view, "radar view").await;
    assert_eq!(
        tick.state().activations,
        0,
        "viewing left the unlistened event inactive"
    );

    // con through the radar_manager binary: a detached whenever runs count until `radar dis`
    let made = json(&[
        "con",
        "whenever",
        "/zv/tick/triggered",
        "/zv/count/start",
        "--detach",
        "--manager",
        "/zv_manager",
    ])
    .await;
    let id = made["id"].as_u64().unwrap();
    let cat = json(&["cat", "/zv/count"]).await;
    let shown = cat["connections"].as_array().unwrap();
    assert_eq!(
        shown.len(),
        1,
        "shown once, by the manager that made it: {cat}"
    );
    assert_eq!(shown[0]["program"], "/zv_manager", "{cat}");
    let mut ticking = tick.watch_state();
    tokio::time::timeout(
        Duration::from_secs(10),
        ticking.wait_for(|s| s.activations == 1),
    )
    .await
    .expect("the manager's relay is a listener: tick checks")
    .unwrap();
    let deadline = tokio::time::Instant::now() + Duration::from_secs(10);
    while runs.load(Ordering::SeqCst) < 3 {
        assert!(
            tokio::time::Instant::now() < deadline,
            "count runs through the manager"
        );
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    // graph: the connection drawn once, under the manager that made it
    let picture = json(&["graph"]).await;
    let drawn: Vec<&Value> = picture["edges"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|e| e["source"] == "/zv/tick")
        .collect();
    assert_eq!(drawn.len(), 1, "{picture}");
    assert_eq!(
        (&drawn[0]["target"], &drawn[0]["slot"], &drawn[0]["program"]),
        (
            &Value::from("/zv/count"),
            &Value::from("start"),
            &Value::from("/zv_manager")
        ),
        "{picture}"
    );
    let removed = json(&["dis", &id.to_string()]).await;
    assert_eq!(removed["removed"], id);
    tokio::time::timeout(Duration::from_secs(10), ticking.wait_for(|s| !s.active))
        .await
        .expect("tick stops checking once the connection is removed")
        .unwrap();

    // the manager and the router stop cleanly when told
    stop(manager, "radar_manager").await;
    stop(router, "radar router").await;
    drop(never);
}

/// SIGTERM to `child`: it must exit 0 with no error line.
async fn stop(child: tokio::process::Child, what: &str) {
    // SAFETY: a plain kill(2) of the child's pid
    assert_eq!(
        unsafe { libc::kill(child.id().unwrap() as i32, libc::SIGTERM) },
        0
    );
    let out = tokio::time::timeout(Duration::from_secs(30), child.wait_with_output())
        .await
        .unwrap_or_else(|_| panic!("{what} stops when told"))
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{what}: {:?} {stderr}", out.status);
    assert!(
        !stderr.contains("ERROR"),
        "{what} logged an error: {stderr}"
    );
}
