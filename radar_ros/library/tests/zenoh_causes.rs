//! Issue 37: a signal's cause crosses processes over Zenoh (ros2-client patch 19), so `until` across processes
//! decides by cause as it does over DDS (response rules R13-R14, connection rule C6).
//!
//! Another program on Zenoh (this binary again, `ZC_ROLE=remote`) runs a RADAR response `/zc/r` whose run
//! lasts the milliseconds its start says. This program holds `whenever E start /zc/r until U` (its manager
//! here, the response there, a router between them). Checked, in order:
//!
//! - the statement's run (started by E) is interrupted by U;
//! - a run the statement did not start (a start injected with no cause) is **not** interrupted by U, though the
//!   statement's start came while it ran (ignored: the response was busy) and so the manager sends U's
//!   interrupt: the interrupt names its statement, the response ignores it for another run (R13) and counts it
//!   ignored. Before patch 19 the interrupt reached the other process without its statement and interrupted
//!   the run (mutation run: with the cause dropped from the attachment this check fails);
//! - a peer written from rmw_zenoh's design document (tests/python/zenoh_peer.py), reading the attachment as
//!   rmw_zenoh reads it (three fields, nothing after them looked at), reads the response's `started` samples:
//!   the statement's, with the 25 bytes of the cause after the GID, and the injected run's, with none.
//!
//! No settling sleeps: each wait is on a state the response publishes. Domain 146. Needs the venv
//! (RADAR_VENV) and the tests' own network namespace (tests/isolated.sh); run by `cargo test --workspace`, whose build has the feature (tests/Cargo.toml).
#![cfg(feature = "zenoh")]

mod zenoh_util;

use std::time::Duration;

use radar_ros::{
    msg::{Empty, ResponseState, StringMsg},
    topics::SignalSubscription,
    FnResponse, Radar, Signal,
};
use serde_json::Value;
use zenoh_util::{local_router, Proc, WAIT};

const DOMAIN: u16 = 146;

/// Reads `state` until `pred` holds, failing after [`WAIT`] with what was seen last.
async fn state_until(
    state: &SignalSubscription<ResponseState>,
    what: &str,
    pred: impl Fn(&ResponseState) -> bool,
) -> ResponseState {
    let mut last = None;
    let r = tokio::time::timeout(WAIT, async {
        loop {
            let s = state.recv().await.expect("state");
            if pred(&s) {
                return s;
            }
            last = Some(s);
        }
    })
    .await;
    r.unwrap_or_else(|_| panic!("timed out waiting for {what}; last state: {last:?}"))
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_until_across_processes_over_zenoh_interrupts_only_its_statements_run() {
    // the one test of this binary: its environment is its own
    std::env::set_var("ROS_DOMAIN_ID", DOMAIN.to_string());
    std::env::set_var("RMW_IMPLEMENTATION", "rmw_zenoh_cpp");
    if std::env::var("ZC_ROLE").as_deref() == Ok("remote") {
        return remote_program().await;
    }
    let _router = local_router().await;
    // the design-document peer listens to the response's `started` (it publishes nothing)
    let mut peer = Proc::start(
        "zenoh_peer.py",
        &[
            "tcp/localhost:7447",
            &DOMAIN.to_string(),
            "std_msgs/msg/String",
            "/zc/r/started",
            "/zc/nothing_from_the_peer",
        ],
    );
    peer.until_up().await;
    let (mut remote, _out) = zenoh_util::start_role(
        "an_until_across_processes_over_zenoh_interrupts_only_its_statements_run",
        "ZC_ROLE",
        "ZC_UP",
    )
    .await;

    let radar = Radar::builder()
        .program("zc_program")
        .handle_signals(false)
        .build()
        .unwrap();
    assert!(radar.over_zenoh());
    let r = radar.response("/zc/r").timeout(WAIT).await.unwrap();
    let state = radar.state_subscription("/zc/r/state").unwrap();
    let e = radar.signal_publisher::<StringMsg>("/zc/e").unwrap();
    let u = radar.signal_publisher::<Empty>("/zc/u").unwrap();
    let _c = radar
        .whenever(Signal::new("/zc/e", "std_msgs/msg/String"))
        .start(&r)
        .until(Signal::new("/zc/u", "std_msgs/msg/Empty"))
        .timeout(WAIT)
        .await
        .unwrap();

    // the statement's run: U interrupts it
    e.publish(StringMsg::from("30000")).unwrap();
    state_until(&state, "the statement's run", |s| {
        s.starts == 1 && s.state_label == "running"
    })
    .await;
    u.publish(Empty::default()).unwrap();
    let s = state_until(&state, "the statement's run to end", |s| s.exits == 1).await;
    assert_eq!(s.interrupts, 1, "U interrupted the statement's run: {s:?}");

    // a run the statement did not start: E's start comes while it runs (ignored), so the manager sends U's
    // interrupt, which names the statement; the response does not let it end this run (R13)
    radar
        .inject(r.start_slot(), StringMsg::from("30000"))
        .timeout(WAIT)
        .await
        .unwrap();
    state_until(&state, "the injected run", |s| {
        s.starts == 2 && s.state_label == "running"
    })
    .await;
    e.publish(StringMsg::from("30000")).unwrap();
    state_until(&state, "the statement's start ignored (busy)", |s| {
        s.ignored_starts >= 1
    })
    .await;
    u.publish(Empty::default()).unwrap();
    let s = state_until(&state, "U's interrupt to be read", |s| {
        s.ignored_interrupts >= 1 || s.interrupts >= 2
    })
    .await;
    assert_eq!(
        (s.interrupts, s.ignored_interrupts, s.state_label.as_str()),
        (1, 1, "running"),
        "the interrupt of the statement's until did not end a run the statement had not started: {s:?}"
    );

    // the peer read both `started` samples as rmw_zenoh reads them; the statement's carried its cause after
    // the three fields, the injected run's nothing
    let mut started = Vec::new();
    while started.len() < 2 {
        let v: Value = serde_json::from_str(&peer.line().await).unwrap();
        assert!(v.get("bad_attachment").is_none(), "{v}");
        if v.get("received").is_some() {
            started.push(v);
        }
    }
    let (first, second) = (&started[0], &started[1]);
    assert_eq!(first["received"]["data"], "30000", "{first}");
    assert_eq!(second["received"]["data"], "30000", "{second}");
    assert_eq!(
        (first["seq"].as_i64(), second["seq"].as_i64()),
        (Some(1), Some(2)),
        "one publisher's sequence: {started:?}"
    );
    assert_eq!(first["gid"], second["gid"], "one publisher: {started:?}");
    let extra = first["extra"].as_str().unwrap();
    assert!(
        extra.len() == 50 && extra.starts_with("10"),
        "the statement's `started` carries 25 bytes after the GID (a 16-byte identity and its number): {first}"
    );
    assert_eq!(
        second["extra"], "",
        "a run with no cause carries nothing more: {second}"
    );
    peer.close();
    drop(remote.stdin.take());
    let _ = tokio::time::timeout(Duration::from_secs(10), remote.wait()).await;
}

/// The other program: the response `/zc/r`, whose run lasts the milliseconds its start says, until its stdin
/// closes.
async fn remote_program() {
    let radar = Radar::builder()
        .program("zc_remote")
        .handle_signals(false)
        .build()
        .unwrap();
    assert!(radar.over_zenoh());
    let _r = radar
        .spawn_response(
            "/zc/r",
            FnResponse::new(|s: StringMsg| async move {
                let ms = s.data.parse().unwrap_or(0);
                tokio::time::sleep(Duration::from_millis(ms)).await;
                Ok(Empty::default())
            }),
        )
        .unwrap();
    println!("ZC_UP");
    let mut lines =
        tokio::io::AsyncBufReadExt::lines(tokio::io::BufReader::new(tokio::io::stdin()));
    while let Ok(Some(_)) = lines.next_line().await {}
}
