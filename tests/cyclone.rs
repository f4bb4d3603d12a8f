//! Issue 70: Eclipse Cyclone DDS as a peer, both ways. `python/cyclone_peer.py` is a plain Cyclone DDS
//! participant (the `cyclonedds` wheel from PyPI) with the names, types and QoS of an rmw_cyclonedds_cpp node.
//! Every scenario also reads what Cyclone logged about radar_ros's packets: nothing malformed (RustDDS patch 69:
//! the preemptive ACKNACK Cyclone refused from RustDDS). Part of the `interop` binary; domains 131-134, 152.

use std::{
    sync::{Arc, Mutex},
    time::Duration,
};

use radar_ros::{
    interfaces::geometry_msgs::msg::Point, msg::Empty, FnResponse, Signal, TimerEvent,
};
use radar_test_util::{eventually, radar, Py};
use serde_json::Value;

const T: Duration = Duration::from_secs(20);

fn cyclone(domain: u16, args: &[&str]) -> Py {
    Py::start(domain, "tests/python/cyclone_peer.py", args)
}

/// Reads the peer's lines up to its Cyclone log, which it prints last; fails on a malformed packet.
async fn clean_log(mut py: Py) {
    let log = py.json_with("cyclone_log").await;
    py.succeeds().await;
    let malformed: Vec<&Value> = log["cyclone_log"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|l| l.as_str().unwrap().contains("malformed"))
        .collect();
    assert!(
        malformed.is_empty(),
        "Cyclone DDS refused radar_ros packets: {malformed:?}"
    );
}

/// A Cyclone publisher starts and interrupts a RADAR response, a Cyclone subscriber gets its signals, and a
/// late Cyclone reader of its state gets the current state only.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_cyclone_node_starts_and_interrupts_a_response_and_reads_its_state() {
    let r = radar(131);
    let dock = r
        .spawn_response(
            "/cy/dock",
            FnResponse::new(|_: Empty| async {
                tokio::time::sleep(Duration::from_secs(30)).await;
                Ok(Empty::default())
            }),
        )
        .unwrap();
    let mut py = cyclone(131, &["drive", "/cy/dock"]);
    for want in ["started", "interrupted", "exited"] {
        assert_eq!(py.json().await["signal"], want);
    }
    let state = py.json().await;
    assert_eq!(state["state"], "idle", "{state}");
    assert_eq!(
        (&state["starts"], &state["interrupts"], &state["exits"]),
        (&1.into(), &1.into(), &1.into()),
        "{state}"
    );
    assert_eq!(state["name"], "/cy/dock");
    assert_eq!(state["start_type"], "std_msgs/msg/Empty");
    let s = dock.state();
    assert_eq!((s.starts, s.interrupts, s.exits), (1, 1, 1));
    clean_log(py).await;
}

/// `ros2 topic pub --once` on a Cyclone DDS robot: a fresh Cyclone process per start, each writing as soon as
/// its writer matched the slot's reader and leaving 0.1 s later (before radar_ros may have matched it back:
/// RustDDS patch 2 keeps what it sent; patch 69's preemptive ACKNACK asks it for a HEARTBEAT in the form Cyclone
/// takes). Every one is acted on, ten in a row with no pause between them.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn every_one_shot_publish_from_a_fresh_cyclone_process_starts_the_response() {
    let r = radar(134);
    let dock = r
        .spawn_response(
            "/cy/quick",
            FnResponse::new(|_: Empty| async { Ok(Empty::default()) }),
        )
        .unwrap();
    for round in 1..=10u64 {
        let py = cyclone(134, &["pub_once", "/cy/quick/start"]);
        clean_log(py).await;
        eventually(T, &format!("start {round} to be acted on"), || {
            dock.state().exits == round
        })
        .await;
    }
    assert_eq!(dock.state().starts, 10);
}

/// A Cyclone subscriber of an event's `triggered` is a listener (E1): the event checks while it listens, and
/// its triggers reach Cyclone; when the Cyclone node leaves, the event stops checking.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_cyclone_listener_activates_an_event_and_gets_its_triggers() {
    let r = radar(132);
    let tick = r
        .spawn_event("/cy/tick", TimerEvent::new(Duration::from_millis(100)))
        .unwrap();
    assert!(!tick.state().active, "nobody listens yet");
    let mut py = cyclone(132, &["listen", "/cy/tick", "3"]);
    for i in 1..=3 {
        assert_eq!(py.json().await["triggered"], i);
    }
    assert!(tick.state().activations >= 1);
    clean_log(py).await;
    eventually(T, "the event to stop checking once Cyclone left", || {
        !tick.state().active
    })
    .await;
}

/// Issue 69 defect 3, with the peer that found it: `once /lvl start dock` (a `geometry_msgs/msg/Point` start).
/// A plain Cyclone writer whose Point is one uint32 (4 bytes where a Point is 24) must not use the `once` up
/// (C2: what the target cannot read is no delivery), and a writer announcing another definition's type hash
/// must not be matched at all (RustDDS patch 70: as rmw_zenoh refuses it); the good Point that follows, from a
/// writer announcing the hash rosidl wrote into the geometry_msgs wheel, starts dock, with its x.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_cyclone_writer_of_another_definition_neither_starts_nor_uses_up_a_once() {
    let r = radar(133);
    let xs = Arc::new(Mutex::new(Vec::new()));
    let xs2 = xs.clone();
    let dock = r
        .spawn_response(
            "/cy/dock",
            FnResponse::new(move |p: Point| {
                xs2.lock().unwrap().push(p.x);
                async { Ok(Empty::default()) }
            }),
        )
        .unwrap();
    let mut py = cyclone(133, &["level", "/lvl"]);
    assert_eq!(py.json().await["up"], true);
    let once = r
        .once(Signal::new("/lvl/triggered", "geometry_msgs/msg/Point"))
        .start(&dock)
        .timeout(T)
        .await
        .expect("armed on the Cyclone writers of /lvl/triggered");
    py.proceed().await;
    let wrote = py.json().await;
    assert_eq!(wrote["wrote"][2], "good");
    once.closed().timeout(T).await.expect("the once is spent");
    // the run it started, if any, begins within a moment; then nothing more may come
    let began = std::time::Instant::now();
    while xs.lock().unwrap().is_empty() && began.elapsed() < Duration::from_secs(3) {
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    tokio::time::sleep(Duration::from_millis(300)).await;
    assert_eq!(
        *xs.lock().unwrap(),
        vec![1.5],
        "the once starts dock once, with the good Point's x (the writers' order: {wrote})"
    );
    assert_eq!(dock.state().starts, 1);
    py.proceed().await;
    clean_log(py).await;
}

/// rmw_cyclonedds_cpp maps services its own way: the request's identity (the client's id and a sequence number)
/// in front of the request's payload, and the reply's, instead of Fast DDS's related sample identity. The
/// manager's services answer such a client as they answer rclpy (ros2-client patch 26: told by the request
/// writer's vendor): a Cyclone client connects `whenever tick start count` and gets its answer with its own
/// header, disconnects it (and gets a clear error for an id that is not there), connects again, and when it
/// leaves the connection goes with it, as any caller's does (the manager knows which participant asked).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_cyclone_client_calls_the_managers_services_and_owns_what_it_made() {
    let host = radar(152);
    let tick = host
        .spawn_event("/cy/svc_tick", TimerEvent::new(Duration::from_millis(100)))
        .unwrap();
    let count = host
        .spawn_response(
            "/cy/svc_count",
            FnResponse::new(|_: Empty| async { Ok(Empty::default()) }),
        )
        .unwrap();
    let _manager = host.serve_manager("cy_manager").unwrap();
    let mut py = cyclone(
        152,
        &[
            "manage",
            "/cy_manager",
            "/cy/svc_tick/triggered",
            "/cy/svc_count/start",
        ],
    );

    let made = py.json().await;
    assert_eq!(made["connected"], true, "{made}");
    assert_eq!(made["seq"], 1, "the reply carries the request's header");
    let runs = count.state().exits;
    eventually(T, "runs through the Cyclone client's connection", || {
        count.state().exits >= runs + 2
    })
    .await;

    py.proceed().await;
    let gone = py.json().await;
    assert_eq!(gone["disconnected"], true, "{gone}");
    let unknown = py.json().await;
    assert_eq!(unknown["disconnected_unknown"], false, "{unknown}");
    assert!(
        unknown["error"].as_str().unwrap().contains("987654321"),
        "the error names the id: {unknown}"
    );
    eventually(T, "the event to stop once disconnected", || {
        !tick.state().active
    })
    .await;

    py.proceed().await;
    let again = py.json().await;
    assert_eq!(again["connected"], true, "{again}");
    assert_ne!(again["id"], made["id"]);
    eventually(T, "the event to check again", || tick.state().active).await;

    // the caller leaves: its connection goes with it (the manager knew its participant)
    py.proceed().await;
    clean_log(py).await;
    eventually(T, "the Cyclone caller's connection to go with it", || {
        !tick.state().active
    })
    .await;
}
