//! The connection manager as a ROS node: connect/disconnect/list services called from another participant,
//! the `connections` topic, errors as answers, and a caller that exits taking its connections with it (also
//! while its connection is still arming), counts kept current. Domains 90-92, 32, 13 and 61.

use std::{sync::atomic::Ordering, time::Duration};

use radar_ros::{
    msg::{ConnectRequest, Connection, ConnectionList, DisconnectRequest, ListRequest, StringMsg},
    FnResponse, TimerEvent,
};
use radar_test_util::{
    call_once, counter, eventually, peer_with_first_line, radar, radar_with, ManagerClient,
    DISCOVERY,
};

fn req(kind: u8, source: &str, target: &str) -> ConnectRequest {
    ConnectRequest {
        kind,
        source: source.into(),
        target: target.into(),
        timeout: 2.0,
        ..Default::default()
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn connections_are_made_listed_and_removed_through_the_services() {
    let host = radar(90);
    let _tick = host
        .spawn_event("tick", TimerEvent::new(Duration::from_millis(100)))
        .unwrap();
    let (_count, runs) = counter(&host, "count");
    let _echo = host
        .spawn_response("echo", FnResponse::new(|s: StringMsg| async move { Ok(s) }))
        .unwrap();
    let _manager = host.serve_manager("radar_manager").unwrap();

    let me = radar(90);
    let connections = me
        .state_subscription::<ConnectionList>("/radar_manager/connections")
        .unwrap();
    let initial = connections.recv().timeout(DISCOVERY).await.unwrap();
    assert_eq!(initial.manager, "/radar_manager");
    assert!(initial.connections.is_empty());
    let client = ManagerClient::new(&me, "/radar_manager", "deliberative_py_stand_in").await;

    let made = call_once(
        &client.connect,
        ConnectRequest {
            depth: 50,
            ..req(Connection::WHENEVER, "tick/triggered", "count/start")
        },
        DISCOVERY,
    )
    .await;
    assert!(made.ok, "{}", made.error);
    eventually(DISCOVERY, "runs through the service's connection", || {
        runs.load(Ordering::SeqCst) >= 2
    })
    .await;

    let listed = tokio::time::timeout(DISCOVERY, async {
        loop {
            let l = connections.recv().await.unwrap();
            if !l.connections.is_empty() {
                return l;
            }
        }
    })
    .await
    .unwrap();
    let c = &listed.connections[0];
    assert_eq!(
        (
            c.id,
            c.kind_label.as_str(),
            c.source.as_str(),
            c.source_type.as_str(),
            c.target.as_str()
        ),
        (
            made.id,
            "whenever",
            "/tick/triggered",
            "std_msgs/msg/Empty",
            "/count/start"
        )
    );
    assert!(c.owner.starts_with("service caller"), "{}", c.owner);
    assert_eq!(c.depth, 50, "the requested QoS depth");
    let l = call_once(&client.list, ListRequest::default(), DISCOVERY).await;
    assert_eq!(l.connections.len(), 1);

    // errors come back as answers that say what to do
    for (r, needles) in [
        (
            req(Connection::ONCE, "nope/triggered", "count/start"),
            vec!["publisher on /nope/triggered", "running"],
        ),
        (
            req(Connection::WHENEVER, "tick/triggered", "echo/start"),
            vec![
                "/tick/triggered",
                "std_msgs/msg/Empty",
                "/echo/start",
                "std_msgs/msg/String",
            ],
        ),
        (
            req(Connection::ONCE, "bad-name", "count/start"),
            vec!["invalid ROS name"],
        ),
        (
            req(7, "tick/triggered", "count/start"),
            vec!["neither ONCE"],
        ),
    ] {
        let a = call_once(&client.connect, r.clone(), DISCOVERY).await;
        assert!(!a.ok, "{r:?} must fail");
        for n in needles {
            assert!(a.error.contains(n), "{n:?} missing from {:?}", a.error);
        }
    }

    let gone = call_once(
        &client.disconnect,
        DisconnectRequest { id: made.id },
        DISCOVERY,
    )
    .await;
    assert!(gone.ok, "{}", gone.error);
    let n = runs.load(Ordering::SeqCst);
    tokio::time::sleep(Duration::from_millis(400)).await;
    assert!(runs.load(Ordering::SeqCst) <= n + 1);
    let again = call_once(
        &client.disconnect,
        DisconnectRequest { id: made.id },
        DISCOVERY,
    )
    .await;
    assert!(
        !again.ok && again.error.contains("list service"),
        "{}",
        again.error
    );
    assert!(call_once(&client.list, ListRequest::default(), DISCOVERY)
        .await
        .connections
        .is_empty());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_callers_connections_go_when_its_process_leaves_the_graph() {
    let host = radar(91);
    let tick = host
        .spawn_event("tick", TimerEvent::new(Duration::from_millis(100)))
        .unwrap();
    let (_count, runs) = counter(&host, "count");
    let _manager = host.serve_manager("radar_manager").unwrap();
    let (mut child, line) = peer_with_first_line(
        env!("CARGO_BIN_EXE_radar_test_peer"),
        91,
        &["connect", "/radar_manager", "tick/triggered", "count/start"],
    )
    .await;
    assert!(line.starts_with("connected true "), "{line}");
    eventually(DISCOVERY, "runs through the child's connection", || {
        runs.load(Ordering::SeqCst) >= 2
    })
    .await;
    let t0 = std::time::Instant::now();
    assert!(std::process::Command::new("kill")
        .args(["-TERM", &child.id().unwrap().to_string()])
        .status()
        .unwrap()
        .success());
    eventually(DISCOVERY, "the event to deactivate", || {
        !tick.state().active
    })
    .await;
    println!(
        "the caller exited: its connection was removed after {:?}",
        t0.elapsed()
    );
    let n = runs.load(Ordering::SeqCst);
    tokio::time::sleep(Duration::from_millis(400)).await;
    assert!(runs.load(Ordering::SeqCst) <= n + 1);
    let _ = child.wait().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_killed_caller_loses_its_connections_within_its_lease() {
    let host = radar(32);
    let tick = host
        .spawn_event("tick", TimerEvent::new(Duration::from_millis(100)))
        .unwrap();
    let (_count, runs) = counter(&host, "count");
    let _manager = host.serve_manager("radar_manager").unwrap();
    let (mut child, line) = peer_with_first_line(
        env!("CARGO_BIN_EXE_radar_test_peer"),
        32,
        &["connect", "/radar_manager", "tick/triggered", "count/start"],
    )
    .await;
    assert!(line.starts_with("connected true "), "{line}");
    eventually(DISCOVERY, "runs through the child's connection", || {
        runs.load(Ordering::SeqCst) >= 2
    })
    .await;
    assert_eq!(host.connections().len(), 1);
    let t0 = std::time::Instant::now();
    child.kill().await.unwrap(); // SIGKILL: no goodbye; the manager learns it from the lease
    eventually(
        Duration::from_secs(30),
        "the manager to drop the dead caller's connection",
        || host.connections().is_empty(),
    )
    .await;
    let removed = t0.elapsed();
    eventually(DISCOVERY, "the event to deactivate", || {
        !tick.state().active
    })
    .await;
    let inactive = t0.elapsed();
    println!(
        "caller killed: connection removed after {removed:?}, event inactive after {inactive:?}"
    );
    assert!(removed < Duration::from_secs(5), "{removed:?}");
    assert!(inactive < Duration::from_secs(5), "{inactive:?}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_killed_deliberative_program_takes_its_connections_with_it() {
    let host = radar(92);
    let tick = host
        .spawn_event("tick", TimerEvent::new(Duration::from_millis(100)))
        .unwrap();
    let (_count, runs) = counter(&host, "count");
    let (mut child, line) = peer_with_first_line(
        env!("CARGO_BIN_EXE_radar_test_peer"),
        92,
        &["whenever", "tick", "count"],
    )
    .await;
    assert_eq!(line, "connected");
    eventually(
        DISCOVERY,
        "runs through the child's embedded manager",
        || runs.load(Ordering::SeqCst) >= 2,
    )
    .await;
    let t0 = std::time::Instant::now();
    child.kill().await.unwrap(); // SIGKILL: its relays vanish without a word
                                 // its relay was the event's only listener: the event deactivates when the dead participant's lease ends
    eventually(Duration::from_secs(30), "the event to deactivate", || {
        !tick.state().active
    })
    .await;
    let took = t0.elapsed();
    println!("deliberative program killed: its connection ended after {took:?} (DDS lease)");
    assert!(took < Duration::from_secs(5), "{took:?}");
    let n = runs.load(Ordering::SeqCst);
    tokio::time::sleep(Duration::from_millis(300)).await;
    assert_eq!(
        runs.load(Ordering::SeqCst),
        n,
        "nothing is delivered any more"
    );
}

/// Every program is visible: a deliberative program's own (embedded) connections are on its program node's
/// `connections` topic and `list` service, named after the program, without `serve_manager`; they go when the
/// statement's guard does.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn every_program_shows_its_connections_on_its_program_node() {
    let program = radar_with(72, |b| b.program("patrol"));
    assert_eq!(program.program_node().fully_qualified(), "/patrol");
    let tick = program
        .spawn_event("tick", TimerEvent::new(Duration::from_millis(100)))
        .unwrap();
    let (count, _runs) = counter(&program, "count");
    let guard = program.whenever(&tick).start(&count).await.unwrap();

    let observer = radar(72);
    let connections = observer
        .state_subscription::<ConnectionList>("/patrol/connections")
        .unwrap();
    let shown = tokio::time::timeout(DISCOVERY, async {
        loop {
            let l = connections.recv().await.unwrap();
            if !l.connections.is_empty() {
                return l;
            }
        }
    })
    .await
    .expect("the program's connection shown");
    assert_eq!(shown.manager, "/patrol");
    let c = &shown.connections[0];
    assert_eq!(
        (
            c.id,
            c.kind_label.as_str(),
            c.source.as_str(),
            c.target.as_str()
        ),
        (guard.id(), "whenever", "/tick/triggered", "/count/start")
    );
    let client = ManagerClient::new(&observer, "/patrol", "radar_cli_stand_in").await;
    let listed = call_once(&client.list, ListRequest::default(), DISCOVERY).await;
    assert_eq!(listed.connections.len(), 1);
    assert_eq!(listed.connections[0].id, guard.id());

    drop(guard);
    tokio::time::timeout(DISCOVERY, async {
        loop {
            if connections.recv().await.unwrap().connections.is_empty() {
                return;
            }
        }
    })
    .await
    .expect("the connection's end shown");

    // the default name is the executable's and the process id, and each participant of the process has its
    // own (the other tests of this binary run in this process too, so which number each gets is not known)
    let (a, b) = (radar(72), radar(72));
    let (na, nb) = (a.program_node().base(), b.program_node().base());
    for n in [na, nb] {
        assert!(
            n.starts_with("manager_service") && n.contains(&format!("_{}", std::process::id())),
            "{n}"
        );
    }
    assert_ne!(na, nb);
}

/// A program's name is its `Radar`'s: when the last handle to it is dropped, the name comes back, so a program
/// made again under that name right after (a test that runs one plain and then secured, a tool that
/// reconnects) is that name, not `<name>_2`, though something of the first (here one of its events, as a
/// component's task being let go of on a worker thread is) still holds its participant. Repeated, with no
/// pause between, as a race is. Before, the name came back only when the participant went, so under load the
/// second was `again_2`, whose endpoints a policy made from the first run did not grant.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_program_made_again_right_after_the_first_ends_has_its_name() {
    let mut left = None;
    for round in 0..20 {
        let program = radar_with(72, |b| b.program("again"));
        assert_eq!(
            program.program_node().fully_qualified(),
            "/again",
            "round {round}"
        );
        let tick = program
            .spawn_event(
                &format!("again_tick_{round}"),
                TimerEvent::new(Duration::from_millis(5)),
            )
            .unwrap();
        let (count, _runs) = counter(&program, &format!("again_count_{round}"));
        let _guard = program.whenever(&tick).start(&count).await.unwrap();
        left = Some(tick);
    }
    drop(left);
}

/// Issue 19, B7: a caller that leaves while its connection is still arming owns nothing: when the arming ends,
/// the connection is dropped, not kept for a dead owner. Before, the caller's departure was handled first (it
/// owned nothing yet) and the connection, recorded afterwards, lived on for ever.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_caller_that_leaves_while_its_connection_arms_owns_nothing() {
    use radar_ros::msg::Empty;
    use radar_test_util::HostPeer;
    let host = radar(13);
    let (_target, _runs) = counter(&host, "b7_target");
    let _manager = host.serve_manager("b7_manager").unwrap();
    let mut peer = HostPeer::start(env!("CARGO_BIN_EXE_radar_test_peer"), 13).await;
    // the source does not exist yet: the connection arms for as long as it takes to come (up to 10 s)
    peer.run("connect-send /b7_manager /b7_source/triggered /b7_target/start 10")
        .await;
    peer.send("quit").await;
    peer.wait().await;
    // the manager has seen the caller leave: a fresh participant's goodbye is heard in milliseconds
    tokio::time::sleep(Duration::from_millis(300)).await;
    let source = host
        .signal_publisher::<Empty>("/b7_source/triggered")
        .unwrap();
    let _ = &source;
    // the connection arms now (its source is there, matched in milliseconds): it must not stay
    let _source = source;
    for _ in 0..2 {
        tokio::time::sleep(Duration::from_millis(1000)).await;
        let live: Vec<_> = host
            .connections()
            .into_iter()
            .filter(|c| c.source == "/b7_source/triggered")
            .collect();
        assert!(
            live.is_empty(),
            "a connection of a caller that left: {live:?}"
        );
    }
}

/// The counts on a program's `connections` topic follow the signals: a signal does not wake the task that
/// publishes the list (at most one signal per publication tells it), and the list published after each burst
/// shows every signal of it, burst after burst.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_connections_topic_shows_every_signal_delivered_burst_after_burst() {
    use radar_ros::{msg::Int32, Signal};
    let program = radar_with(61, |b| b.program("counting"));
    let src = program.signal_publisher::<Int32>("/n").unwrap();
    let got = std::sync::Arc::new(std::sync::atomic::AtomicU64::new(0));
    let g = got.clone();
    let resp = program
        .spawn_response(
            "tally",
            FnResponse::new(move |_: Int32| {
                g.fetch_add(1, Ordering::SeqCst);
                async { Ok(radar_ros::msg::Empty::default()) }
            }),
        )
        .unwrap();
    let guard = program
        .whenever(Signal::new("/n", "std_msgs/msg/Int32"))
        .start(&resp)
        .depth(std::num::NonZeroUsize::new(100).unwrap())
        .await
        .unwrap();
    let observer = radar(61);
    let connections = observer
        .state_subscription::<ConnectionList>("/counting/connections")
        .unwrap();
    let mut sent = 0u64;
    for burst in [7u64, 1, 25] {
        for _ in 0..burst {
            sent += 1;
            src.publish(Int32 { data: sent as i32 }).unwrap();
            // one at a time: the response takes each (a start while it runs would be ignored, not delivered)
            eventually(DISCOVERY, "the start", || {
                got.load(Ordering::SeqCst) == sent
            })
            .await;
        }
        assert_eq!(guard.delivered(), sent);
        // the list published after the burst, within the throttle's period, shows all of it
        let shown = tokio::time::timeout(DISCOVERY, async {
            loop {
                let l = connections.recv().await.unwrap();
                if l.connections.first().is_some_and(|c| c.delivered >= sent) {
                    return l.connections[0].delivered;
                }
            }
        })
        .await
        .unwrap_or_else(|_| panic!("the list never showed {sent} delivered"));
        assert_eq!(shown, sent, "no more than were sent");
    }
}
