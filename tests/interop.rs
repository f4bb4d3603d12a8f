//! Interop with real rclpy (ROS 2 Jazzy wheels from PyPI, Fast DDS): Python processes see radar_ros's graph,
//! inject into slots as `ros2 topic pub` does, act as events and responses in connections, call the manager's
//! services with the generated `radar_msgs` types, read latched state, and send bad input. The Python side is
//! `tests/python/interop.py` and `examples/python/`, run with the venv that `tests/python_env.sh` builds
//! (`tests/isolated.sh` builds it before entering the test network). No venv: these tests fail. Domains 94-101,
//! 33-34, 222.

use std::{
    sync::{atomic::Ordering, Arc, Mutex},
    time::Duration,
};

use radar_ros::{
    msg::{ConnectionList, Empty, StringMsg},
    FnResponse, Radar, TimerEvent,
};
use radar_test_util::{counter, eventually, radar, Py};

mod cyclone;
mod diagnostics;
mod kilted;

const T: Duration = Duration::from_secs(20);

fn slow_response(r: &Radar, name: &str) -> radar_ros::ResponseHandle {
    r.spawn_response(
        name,
        FnResponse::new(|_: Empty| async {
            tokio::time::sleep(Duration::from_secs(30)).await;
            Ok(Empty::default())
        }),
    )
    .unwrap()
}

/// An event `ev` (Empty, every 100 ms), a response `/interop/say` (String in, the same String out) and a
/// manager node `/radar_manager`, kept alive by the returned handles.
fn graph_with_manager(
    r: &Radar,
    ev: &str,
) -> (
    radar_ros::EventHandle,
    radar_ros::ResponseHandle,
    radar_ros::manager::ManagerHandle,
) {
    let e = r
        .spawn_event(ev, TimerEvent::new(Duration::from_millis(100)))
        .unwrap();
    let say = r
        .spawn_response(
            "/interop/say",
            FnResponse::new(|s: StringMsg| async move { Ok(s) }),
        )
        .unwrap();
    (e, say, r.serve_manager("/radar_manager").unwrap())
}

/// Scenario 1: rclpy sees radar_ros's nodes, topics with types, and the manager's services with types.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn rclpy_sees_the_radar_graph() {
    let r = radar(94);
    let _graph = graph_with_manager(&r, "/interop/bumper");
    let mut py = Py::interop(
        94,
        &[
            "graph",
            "--nodes",
            "/interop/bumper",
            "/interop/say",
            "/radar_manager",
            "--services",
            "/radar_manager/connect",
            "/radar_manager/disconnect",
            "/radar_manager/list",
        ],
    );
    let g = py.json().await;
    py.succeeds().await;
    let nodes = g["nodes"].as_array().unwrap();
    for (ns, name) in [
        ("/interop", "bumper"),
        ("/interop", "say"),
        ("/", "radar_manager"),
    ] {
        assert!(
            nodes.contains(&serde_json::json!([ns, name])),
            "node {ns} {name} in {nodes:?}"
        );
    }
    let topic = |t: &str| g["topics"][t].clone();
    let ty = |t: &str| serde_json::json!([t]);
    for (t, want) in [
        ("/interop/bumper/triggered", "std_msgs/msg/Empty"),
        ("/interop/bumper/state", "radar_msgs/msg/EventState"),
        ("/interop/say/start", "std_msgs/msg/String"),
        ("/interop/say/interrupt", "std_msgs/msg/Empty"),
        ("/interop/say/exit", "std_msgs/msg/Empty"),
        ("/interop/say/started", "std_msgs/msg/String"),
        ("/interop/say/interrupted", "std_msgs/msg/Empty"),
        ("/interop/say/exited", "std_msgs/msg/String"),
        ("/interop/say/state", "radar_msgs/msg/ResponseState"),
        (
            "/radar_manager/connections",
            "radar_msgs/msg/ConnectionList",
        ),
    ] {
        assert_eq!(topic(t), ty(want), "topic {t}");
    }
    for (s, want) in [
        ("/radar_manager/connect", "radar_msgs/srv/Connect"),
        ("/radar_manager/disconnect", "radar_msgs/srv/Disconnect"),
        ("/radar_manager/list", "radar_msgs/srv/List"),
    ] {
        assert_eq!(g["services"][s], ty(want), "service {s}");
    }
}

/// Scenario 2: injection as `ros2 topic pub` does it (default QoS, one message): Empty into start, then
/// interrupt; rclpy sees started, interrupted, exited in order. Then a typed payload in and out.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn rclpy_injects_into_slots_and_sees_the_signals_in_order() {
    let r = radar(95);
    rclpy_starts_and_interrupts(&r, &radar_test_util::python(), 95, "/interop/slow").await;

    let got: Arc<Mutex<Vec<String>>> = Default::default();
    let g = got.clone();
    let _echo = r
        .spawn_response(
            "/interop/echo",
            FnResponse::new(move |s: StringMsg| {
                g.lock().unwrap().push(s.data.clone());
                async move { Ok(StringMsg::from(format!("done:{}", s.data).as_str())) }
            }),
        )
        .unwrap();
    let mut py = Py::interop(95, &["inject_string", "/interop/echo", "kitchen"]);
    let mut signals = Vec::new();
    loop {
        let v = py.json().await;
        if v.get("order").is_some() {
            break;
        }
        if let Some(s) = v.get("signal") {
            signals.push((s.as_str().unwrap().to_owned(), v["data"].clone()));
        }
    }
    py.succeeds().await;
    assert_eq!(
        signals,
        vec![
            ("started".to_owned(), serde_json::json!("kitchen")),
            ("exited".to_owned(), serde_json::json!("done:kitchen")),
        ]
    );
    assert_eq!(*got.lock().unwrap(), vec!["kitchen".to_owned()]);
}

/// Scenario 2's first half with the rclpy of `interpreter`'s venv (Jazzy's, or Kilted's: `kilted.rs`): a
/// response `name` of `r` (on `domain`) started and interrupted as `ros2 topic pub` does it; rclpy reads
/// started, interrupted, exited in order.
async fn rclpy_starts_and_interrupts(
    r: &Radar,
    interpreter: &std::path::Path,
    domain: u16,
    name: &str,
) {
    let resp = slow_response(r, name);
    let mut py = Py::start_in(
        interpreter,
        domain,
        "tests/python/interop.py",
        &["inject", name],
        &[],
    );
    let order = py.json_with("order").await;
    py.succeeds().await;
    assert_eq!(
        order["order"],
        serde_json::json!(["started", "interrupted", "exited"])
    );
    let s = resp.state();
    assert_eq!((s.starts, s.interrupts, s.exits), (1, 1, 1));
}

/// Scenario 3a: an rclpy event (examples/python/radar_event.py) connected by Rust `whenever` to a Rust
/// response; it checks only while the connection listens.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_rclpy_event_drives_a_rust_response() {
    rclpy_event_drives_a_rust_response(&radar_test_util::python(), 96, "/interop").await;
}

/// Scenario 3a with the rclpy of `interpreter`'s venv (Jazzy's, or Kilted's: `kilted.rs`) on `domain`, its
/// components under `ns`.
async fn rclpy_event_drives_a_rust_response(interpreter: &std::path::Path, domain: u16, ns: &str) {
    let r = radar(domain);
    let (resp, runs) = counter(&r, &format!("{ns}/count"));
    let bumper = format!("{ns}/py_bumper");
    let mut ev = Py::start_in(
        interpreter,
        domain,
        "examples/python/radar_event.py",
        &[&bumper, "--period", "0.05"],
        &[],
    );
    ev.expect_line("up").await;
    let found = r.event(&bumper).await.unwrap();
    assert_eq!(found.triggered().ros_type(), "std_msgs/msg/Empty");
    {
        let _c = r.whenever(found.triggered()).start(&resp).await.unwrap();
        ev.expect_line("active").await;
        eventually(T, "runs started by the rclpy event", || {
            runs.load(Ordering::SeqCst) >= 3
        })
        .await;
    }
    // the connection is gone: the rclpy event sees no listener and stops checking
    ev.expect_line("inactive").await;
    let after = runs.load(Ordering::SeqCst);
    tokio::time::sleep(Duration::from_millis(300)).await;
    assert!(
        runs.load(Ordering::SeqCst) <= after + 1,
        "no runs without the connection"
    );
}

/// Scenario 3b: a Rust event connected to an rclpy response (examples/python/radar_response.py), found by
/// name; the deliberative program waits for its `exited`.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_rust_event_drives_an_rclpy_response() {
    let r = radar(97);
    let tick = r
        .spawn_event("/interop/tick", TimerEvent::new(Duration::from_millis(100)))
        .unwrap();
    let mut resp = Py::example(
        97,
        "radar_response.py",
        &["/interop/py_dock", "--duration", "0.1"],
    )
    .await;
    let dock = r.response("/interop/py_dock").await.unwrap();
    assert_eq!(dock.start_slot().ros_type(), "std_msgs/msg/Empty");
    let _c = r.once(tick.triggered()).start(&dock).await.unwrap();
    let _: Empty = r.waitfor(dock.exited()).timeout(T).await.unwrap();
    resp.expect_line("started").await;
    resp.expect_line("exited").await;
    // until: a Rust event interrupts the rclpy response's run this statement started
    let stop = r
        .spawn_event("/interop/stop", TimerEvent::new(Duration::from_millis(300)))
        .unwrap();
    let mut slow = Py::example(
        97,
        "radar_response.py",
        &["/interop/py_slow", "--duration", "30"],
    )
    .await;
    let slow_ref = r.response("/interop/py_slow").await.unwrap();
    let _u = r
        .once(tick.triggered())
        .start(&slow_ref)
        .until(stop.triggered())
        .await
        .unwrap();
    let _: Empty = r.waitfor(slow_ref.interrupted()).timeout(T).await.unwrap();
    slow.expect_line("started").await;
    slow.expect_line("interrupted").await;
    slow.expect_line("exited").await;
}

/// Scenario 4: an rclpy deliberative program uses the manager's services with the generated radar_msgs
/// Python types; the connection shows on the `connections` topic, delivers, and goes on disconnect. A second
/// run leaves without disconnecting, and the manager removes its connection.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_rclpy_program_makes_connections_through_the_manager_services() {
    let r = radar(98);
    let _tick = r
        .spawn_event("/interop/tick", TimerEvent::new(Duration::from_millis(100)))
        .unwrap();
    let (count, _) = counter(&r, "/interop/count");
    let _m = r.serve_manager("/radar_manager").unwrap();
    let mut py = Py::interop(
        98,
        &[
            "deliberative",
            "/radar_manager",
            "/interop/tick/triggered",
            "/interop/count/start",
            "/interop/count/started",
        ],
    );
    let made = py.json_with("connect_ok").await;
    assert_eq!(made["connect_ok"], true, "{made}");
    let listed = py.json_with("listed").await;
    assert_eq!(listed["listed"]["id"], made["id"]);
    assert_eq!(listed["listed"]["kind"], "whenever");
    assert_eq!(listed["listed"]["source"], "/interop/tick/triggered");
    assert_eq!(listed["listed"]["source_type"], "std_msgs/msg/Empty");
    assert_eq!(listed["listed"]["target"], "/interop/count/start");
    assert!(listed["listed"]["owner"]
        .as_str()
        .unwrap()
        .starts_with("service caller"));
    py.json_with("through").await;
    let d = py.json_with("disconnect_ok").await;
    assert_eq!(d["disconnect_ok"], true, "{d}");
    py.json_with("unlisted").await;
    py.succeeds().await;
    assert!(count.state().starts >= 2);
    assert!(r.connections().is_empty());

    // a second run exits without disconnecting: its connection dies with it
    let list = r
        .state_subscription::<ConnectionList>("/radar_manager/connections")
        .unwrap();
    let mut py = Py::interop(
        98,
        &[
            "deliberative",
            "/radar_manager",
            "/interop/tick/triggered",
            "/interop/count/start",
            "/interop/count/started",
            "--no-disconnect",
        ],
    );
    py.json_with("leaving").await;
    assert_eq!(r.connections().len(), 1);
    py.succeeds().await;
    eventually(
        T,
        "the manager to drop the departed caller's connection",
        || r.connections().is_empty(),
    )
    .await;
    // and says so on the connections topic
    tokio::time::timeout(T, async {
        loop {
            if list.recv().await.unwrap().connections.is_empty() {
                break;
            }
        }
    })
    .await
    .expect("an empty connections list");
}

/// Scenario 5: rclpy subscribing late to a response's transient-local `state` gets the current state.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn rclpy_gets_the_latched_state_on_subscribing() {
    let r = radar(99);
    let resp = slow_response(&r, "/interop/busy");
    r.inject(resp.reference().start_slot(), Empty::default())
        .timeout(T)
        .await
        .unwrap();
    eventually(T, "the run to start", || resp.state().starts == 1).await;
    let mut py = Py::interop(99, &["state", "/interop/busy"]);
    let s = py.json().await;
    py.succeeds().await;
    assert_eq!(s["name"], "/interop/busy");
    assert_eq!(s["state_label"], "running");
    assert_eq!(s["start_type"], "std_msgs/msg/Empty");
    assert_eq!(s["starts"], 1);
    assert!(
        s["after_s"].as_f64().unwrap() < 5.0,
        "the latched state came with discovery: {s}"
    );
}

/// Scenario 6: bad input from Python. A slot published with the wrong type is not matched and changes
/// nothing; the manager refuses unknown components, mismatched types and invalid names with reasons.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn bad_input_from_rclpy_is_refused_with_reasons() {
    let r = radar(100);
    let resp = slow_response(&r, "/interop/guarded");
    let _graph = graph_with_manager(&r, "/interop/tick");
    let mut py = Py::interop(
        100,
        &[
            "bad_input",
            "/interop/guarded",
            "/radar_manager",
            "/interop/tick",
            "/interop/say/start",
        ],
    );
    let wrong = py.json_with("wrong_type_matched").await;
    assert_eq!(
        wrong["wrong_type_matched"], 0,
        "Fast DDS does not match other types"
    );
    assert_eq!(wrong["seen_after_wrong"], serde_json::json!([]));
    assert_eq!(
        resp.state().starts,
        0,
        "the wrong-type messages started nothing"
    );
    assert_eq!(
        resp.slot_publishers()[0],
        0,
        "nor are they counted as publishers"
    );
    // (the script waited for this while its wrong-type publisher was the only one; it had inherited a
    // closed stdin, so it used to go on at once and its valid start could beat the check above)
    py.proceed().await;
    py.json_with("still_works").await;
    // rclpy saw `started`; the handle's state is updated by the response task right after it sends it
    eventually(T, "the start counted", || resp.state().starts == 1).await;
    assert_eq!(resp.state().starts, 1);
    let mut answers = std::collections::BTreeMap::new();
    for _ in 0..5 {
        let a = py.json_with("request").await;
        assert_eq!(a["ok"], false, "{a}");
        answers.insert(
            a["request"].as_str().unwrap().to_owned(),
            a["error"].as_str().unwrap().to_owned(),
        );
    }
    py.succeeds().await;
    for (request, needles) in [
        ("unknown source", vec!["/interop/nope/triggered", "running"]),
        ("unknown target", vec!["/interop/nobody/start"]),
        (
            "type mismatch",
            vec![
                "/interop/tick/triggered",
                "std_msgs/msg/Empty",
                "/interop/say/start",
                "std_msgs/msg/String",
            ],
        ),
        ("invalid name", vec!["bad-name!", "invalid ROS name"]),
        ("invalid kind", vec!["neither ONCE"]),
    ] {
        let e = &answers[request];
        for n in needles {
            assert!(e.contains(n), "{request}: {n:?} missing from {e:?}");
        }
    }
}

/// Waits until `cond` holds, at most `timeout`; whether it did.
async fn within(timeout: Duration, cond: impl Fn() -> bool) -> bool {
    tokio::time::timeout(timeout, async {
        while !cond() {
            tokio::time::sleep(Duration::from_millis(5)).await;
        }
    })
    .await
    .is_ok()
}

/// Scenario 7: `ros2 topic pub --once` as the real command line does it: a fresh process (a new DDS
/// participant) per message, which publishes as soon as it counts one matched subscription and leaves 0.1 s
/// later. Thirty starts and thirty interrupts, each from its own process: every one is acted on.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn every_one_shot_publish_from_a_fresh_process_is_acted_on() {
    const N: u64 = 30;
    let r = radar(101);
    let resp = slow_response(&r, "/interop/oneshot");
    let mut acted = 0;
    let mut lost = None;
    let mut matched_after = Vec::new();
    type Acted = fn(&radar_ros::msg::ResponseState, u64) -> bool;
    'rounds: for i in 0..N {
        let steps: [(&str, Acted); 2] = [
            ("start", |s, i| s.starts == i + 1),
            ("interrupt", |s, i| {
                s.interrupts == i + 1 && s.exits == i + 1
            }),
        ];
        for (slot, done) in steps {
            let mut py = Py::interop(101, &["pub_once", &format!("/interop/oneshot/{slot}")]);
            let p = py.json_with("published").await;
            matched_after.push(p["matched_after_s"].as_f64().unwrap());
            py.succeeds().await;
            // the process is gone: its message has arrived, or arrives from what the transport held for it
            if within(Duration::from_secs(5), || done(&resp.state(), i)).await {
                acted += 1;
            } else {
                lost = Some(format!("{slot} #{i}, state then: {:?}", resp.state()));
                break 'rounds;
            }
        }
    }
    println!(
        "{acted} of {} one-shot publishes from fresh processes acted on; they matched after {:.2}-{:.2} s",
        2 * N,
        matched_after.iter().cloned().fold(f64::MAX, f64::min),
        matched_after.iter().cloned().fold(0.0, f64::max)
    );
    assert_eq!(
        lost, None,
        "a one-shot publish was lost after {acted} acted on"
    );
    let s = resp.state();
    assert_eq!((s.starts, s.interrupts, s.exits), (N, N, N));
}

/// Scenario 8: `ros2 service call` as the real command line does it: a fresh process per call, which waits
/// for the service and sends one request. Thirty calls to the manager's `list`, each answered at once (a
/// request dropped because it came before discovery matched its writer was answered only after the
/// client's next heartbeat, 3 s later, or never if the caller gives up sooner).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn every_service_call_from_a_fresh_process_is_answered() {
    const N: usize = 30;
    let r = radar(33);
    let _graph = graph_with_manager(&r, "/interop/tick");
    let mut answered = 0;
    let mut answer_s = Vec::new();
    for _ in 0..N {
        let mut py = Py::interop(33, &["list_once", "/radar_manager"]);
        let a = py.json_with("answered").await;
        py.succeeds().await;
        if a["answered"] == true && a["answer_s"].as_f64().unwrap() < 1.5 {
            answered += 1;
            assert_eq!(a["connections"], 0, "{a}");
        }
        if a["answered"] == true {
            answer_s.push(a["answer_s"].as_f64().unwrap());
        }
    }
    println!(
        "{answered} of {N} service calls from fresh processes answered within 1.5 s; answers after {:.3}-{:.3} s",
        answer_s.iter().cloned().fold(f64::MAX, f64::min),
        answer_s.iter().cloned().fold(0.0, f64::max)
    );
    assert_eq!(answered, N);
}

/// Scenario 9: a response goes through 100 state changes with nobody subscribed to its `state`; late
/// subscribers with transient-local durability and a deep queue get exactly one sample, the current state:
/// rclpy (Fast DDS) and ros2-client (RustDDS, another participant).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_late_state_subscriber_gets_only_the_current_state() {
    use ros2_client::{
        qos::{Durability, History},
        MessageTypeName, Name, NodeName, NodeOptions,
    };
    let r = radar(34);
    let resp = slow_response(&r, "/interop/cycled");
    let start = r
        .signal_publisher::<Empty>("/interop/cycled/start")
        .unwrap();
    let interrupt = r
        .signal_publisher::<Empty>("/interop/cycled/interrupt")
        .unwrap();
    start.wait_for_subscribers(1).timeout(T).await.unwrap();
    interrupt.wait_for_subscribers(1).timeout(T).await.unwrap();
    // idle -> running -> interrupting -> exiting -> idle: four state changes per cycle
    for i in 1..=25 {
        start.publish(Empty::default()).unwrap();
        eventually(T, "started", || resp.state().starts == i).await;
        interrupt.publish(Empty::default()).unwrap();
        eventually(T, "exited", || resp.state().exits == i).await;
    }
    start.publish(Empty::default()).unwrap();
    eventually(T, "running again", || resp.state().starts == 26).await;
    let current = resp.state();
    assert_eq!(current.state_label, "running");

    let mut py = Py::interop(34, &["state_all", "/interop/cycled"]);
    let got = py.json_with("count").await;
    py.succeeds().await;
    assert_eq!(got["count"], 1, "rclpy got {got}");
    assert_eq!(
        got["states"][0],
        serde_json::json!(["running", 26, 25, 25]),
        "{got}"
    );

    // ros2-client in another participant, same QoS as the rclpy subscriber
    let late = radar_ros::Radar::builder().domain_id(34).build().unwrap();
    let mut node = late
        .dds_context()
        .expect("a DDS Radar")
        .new_node(
            NodeName::new("/", "late_state_reader").unwrap(),
            NodeOptions::new().enable_rosout(false),
        )
        .unwrap();
    let qos = radar_ros::qos::state_qos()
        .durability(Durability::TransientLocal)
        .history(History::KeepLast { depth: 100 });
    let topic = node
        .create_topic(
            &Name::parse("/interop/cycled/state").unwrap(),
            MessageTypeName::new("radar_msgs", "ResponseState"),
            &qos,
        )
        .unwrap();
    let sub = node
        .create_subscription::<radar_ros::msg::ResponseState>(&topic, Some(qos))
        .unwrap();
    tokio::spawn(node.spinner().unwrap().spin());
    let mut stream = Box::pin(sub.async_stream());
    let first = tokio::time::timeout(T, futures::StreamExt::next(&mut stream))
        .await
        .expect("the latched state")
        .unwrap()
        .unwrap()
        .0;
    assert_eq!(
        (first.state_label.as_str(), first.starts, first.exits),
        ("running", 26, 25)
    );
    let more = tokio::time::timeout(
        Duration::from_secs(1),
        futures::StreamExt::next(&mut stream),
    )
    .await;
    assert!(
        more.is_err(),
        "a second sample: {:?}",
        more.map(|m| m.map(|r| r.map(|x| x.0)))
    );
}

/// Enclaves cross both ways in each participant's DDS USER_DATA (`enclave=/path;`, RustDDS patch 29) as rmw
/// announces them: rclpy's graph shows radar_ros's nodes in the enclave the program was given (`--enclave`),
/// and `Introspect::nodes` (what `radar security generate_policy` reads) shows the rclpy node in its enclave
/// with the topics it publishes and subscribes and the services it serves, from its `ros_discovery_info`.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn enclaves_and_each_nodes_endpoints_are_seen_both_ways_with_rclpy() {
    let r = radar_test_util::radar_with(222, |b| {
        b.program("enclaved_radar").ros_args(
            radar_ros::ros_args::RosArgs::parse(["x", "--ros-args", "--enclave", "/radar/side"])
                .unwrap(),
        )
    });
    let _say = r
        .spawn_response(
            "/interop/enc_say",
            FnResponse::new(|s: StringMsg| async move { Ok(s) }),
        )
        .unwrap();
    let mut py = Py::interop(
        222,
        &[
            "enclaved",
            "--enclave",
            "/py/side",
            "--wait-for",
            "/interop/enc_say",
        ],
    );
    let seen = py.json().await;
    for node in ["/interop/enc_say", "/enclaved_radar"] {
        assert_eq!(
            seen["enclaves"][node], "/radar/side",
            "rclpy sees {node}'s enclave: {seen}"
        );
    }
    let mut found = None;
    for _ in 0..10 {
        let nodes = r.introspect().nodes().timeout(T).await.unwrap();
        found = nodes
            .into_iter()
            .find(|n| n.fully_qualified() == "/interop_enclaved" && !n.publishes.is_empty());
        if found.is_some() {
            break;
        }
    }
    let n = found.expect("radar_ros sees the rclpy node");
    assert_eq!(n.enclave, "/py/side", "{n:?}");
    assert!(n.publishes.contains("/py_enclaved/out"), "{n:?}");
    assert!(n.subscribes.contains("/py_enclaved/in"), "{n:?}");
    assert!(
        n.serves.contains("/interop_enclaved/get_parameters"),
        "{n:?}"
    );
    py.kill();
}
