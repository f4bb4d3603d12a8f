//! Issue 70: health where ROS tools look. An rclpy subscriber of `/diagnostics` (`python/diagnostics.py`,
//! `diagnostic_msgs/msg/DiagnosticArray` as rqt_runtime_monitor and the aggregator read it) sees, from a
//! program node and a manager node, each condition with its level: a connection waiting for its source (WARN,
//! naming who left), a target lost (ERROR), a connection whose own code panics (WARN, with the panic), messages
//! dropped as malformed (WARN, per topic), and a manager's connection whose owner went silent (WARN); and the
//! program's summary at the worst of them. Part of the `interop` binary; domain 139.

use std::{collections::HashMap, time::Duration};

use radar_ros::{
    msg::{Empty, StringMsg},
    FnResponse, Signal, TimerEvent,
};
use radar_test_util::{eventually, publish_unreadable_string, radar_with, HostPeer, Py, DISCOVERY};
use serde_json::Value;

const T: Duration = Duration::from_secs(20);
const PEER: &str = env!("CARGO_BIN_EXE_radar_test_peer");
const OK: u64 = 0;
const WARN: u64 = 1;
const ERROR: u64 = 2;

/// Reads the subscriber's statuses until `name` has `level` and its message contains `says`; returns it.
async fn status(
    py: &mut Py,
    seen: &mut HashMap<String, Value>,
    name: &str,
    level: u64,
    says: &str,
) -> Value {
    let found = tokio::time::timeout(T, async {
        loop {
            if let Some(s) = seen.get(name) {
                if s["level"] == level && s["message"].as_str().unwrap().contains(says) {
                    return s.clone();
                }
            }
            let v = py.json().await;
            if let Some(n) = v["name"].as_str() {
                seen.insert(n.to_owned(), v);
            }
        }
    })
    .await;
    found.unwrap_or_else(|_| {
        panic!(
            "no status {name:?} at level {level} saying {says:?} on /diagnostics within {T:?}; last: {:?}",
            seen.get(name)
        )
    })
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_rclpy_monitor_reads_each_condition_on_diagnostics() {
    let r = radar_with(139, |b| b.program("dg_prog"));
    // the other side of the connections: another participant, which leaves
    let other = radar_with(139, |b| b.program("dg_other"));
    let src = other.signal_publisher::<Empty>("/dg/src").unwrap();
    let far = other
        .spawn_response(
            "/dg/far",
            FnResponse::new(|_: Empty| async { Ok(Empty::default()) }),
        )
        .unwrap();
    let tick = r
        .spawn_event("/dg/tick", TimerEvent::new(Duration::from_millis(100)))
        .unwrap();
    let near = r
        .spawn_response(
            "/dg/near",
            FnResponse::new(|_: Empty| async { Ok(Empty::default()) }),
        )
        .unwrap();
    let _echo = r
        .spawn_response(
            "/dg/echo",
            FnResponse::new(|s: StringMsg| async move { Ok(s) }),
        )
        .unwrap();
    let mut py = Py::start(139, "tests/python/diagnostics.py", &["/dg_"]);
    assert_eq!(py.json().await["subscribed"], true);
    let mut seen = HashMap::new();

    let waits = r
        .whenever(Signal::new("/dg/src", "std_msgs/msg/Empty"))
        .start(&near);
    let waits = waits.timeout(T).await.unwrap();
    let lost = r
        .whenever(tick.triggered())
        .start(&far.reference())
        .timeout(T)
        .await
        .unwrap();
    let panics = r
        .whenever(tick.triggered())
        .start(&near)
        .filter(|_: &Empty| -> bool { panic!("boom in the filter") })
        .timeout(T)
        .await
        .unwrap();
    let armed = status(
        &mut py,
        &mut seen,
        &format!("/dg_prog: connection {}", waits.id()),
        OK,
        "armed",
    )
    .await;
    assert_eq!(armed["values"]["source"], "/dg/src");
    let p = status(
        &mut py,
        &mut seen,
        &format!("/dg_prog: connection {}", panics.id()),
        WARN,
        "boom",
    )
    .await;
    assert!(p["values"]["panics"].as_str().unwrap() != "0", "{p}");

    // malformed: an unreadable payload on echo's start slot
    let raw = other
        .raw_publisher("/dg/echo/start", "std_msgs/msg/String")
        .unwrap();
    publish_unreadable_string(&r, &raw).await;
    let m = status(
        &mut py,
        &mut seen,
        "/dg_prog: malformed messages",
        WARN,
        "/dg/echo/start",
    )
    .await;
    assert!(
        m["message"].as_str().unwrap().starts_with("1 dropped"),
        "{m}"
    );

    // the other participant leaves: the source is gone (WARN, who left), the target is lost (ERROR)
    drop((src, far, raw));
    other.shutdown().timeout(T).await.unwrap();
    let w = status(
        &mut py,
        &mut seen,
        &format!("/dg_prog: connection {}", waits.id()),
        WARN,
        "waiting for source",
    )
    .await;
    assert!(
        w["values"]["departure"]
            .as_str()
            .is_some_and(|d| !d.is_empty()),
        "{w}"
    );
    status(
        &mut py,
        &mut seen,
        &format!("/dg_prog: connection {}", lost.id()),
        ERROR,
        "target lost",
    )
    .await;
    status(&mut py, &mut seen, "/dg_prog: connections", ERROR, "error").await;

    // a manager node whose caller (another process) stops: its connection is suspended (WARN)
    let _mgr = r.serve_manager("dg_mgr").unwrap();
    let mut owner = HostPeer::start(PEER, 139).await;
    owner
        .query("connect-remote /dg_mgr /dg/tick/triggered /dg/near/start")
        .await;
    status(
        &mut py,
        &mut seen,
        "/dg_mgr: connections",
        OK,
        "1 connections: 1 ok",
    )
    .await;
    owner.signal("STOP");
    let s = tokio::time::timeout(DISCOVERY, async {
        loop {
            let v = py.json().await;
            let n = v["name"].as_str().unwrap_or_default().to_owned();
            if n.starts_with("/dg_mgr: connection ") && v["level"] == WARN {
                return v;
            }
        }
    })
    .await
    .expect("the manager's connection of a silent owner on /diagnostics");
    assert!(
        s["message"]
            .as_str()
            .unwrap()
            .contains("has not said it is alive"),
        "{s}"
    );
    owner.signal("KILL");
    eventually(T, "near to have run", || near.state().starts > 0).await;
    py.proceed().await;
}
