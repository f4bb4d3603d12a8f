//! When components leave the graph (connection rule 5, "When components leave" in the crate docs): what a
//! waiter, a connection and the manager's list show when the source or the target process exits cleanly or
//! is killed, and what happens when a component of that name comes back. Every component that leaves lives
//! in a `radar_test_peer host` process of its own. Domains 37-39, 47-49, 53, 223-224.

use std::time::{Duration, Instant};

use radar_ros::{
    graph::LossCause,
    manager::Link,
    msg::{Connection, Empty, ResponseState},
    Error, Signal,
};
use radar_test_util::{eventually, radar, HostPeer, DISCOVERY};

const PEER: &str = env!("CARGO_BIN_EXE_radar_test_peer");

fn empty(topic: &str) -> Signal {
    Signal::new(topic, "std_msgs/msg/Empty")
}

/// The latest state of response `name`, as its latched state topic shows it.
async fn response_state(radar: &radar_ros::Radar, name: &str) -> ResponseState {
    let s = radar
        .state_subscription::<ResponseState>(&format!("/{name}/state"))
        .unwrap();
    s.wait_for_publishers(1).timeout(DISCOVERY).await.unwrap();
    let mut last = s.recv().timeout(DISCOVERY).await.unwrap();
    while let Some(newer) = s.try_recv() {
        last = newer;
    }
    last
}

async fn eventually_state(
    radar: &radar_ros::Radar,
    name: &str,
    what: &str,
    cond: impl Fn(&ResponseState) -> bool,
) -> ResponseState {
    let deadline = Instant::now() + DISCOVERY;
    loop {
        let s = response_state(radar, name).await;
        if cond(&s) {
            return s;
        }
        assert!(
            Instant::now() < deadline,
            "{name}: {what}; last state {s:?}"
        );
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn waitfor_ends_naming_the_component_when_it_exits_or_is_killed() {
    let radar = radar(37);
    // clean exit: the goodbye is heard at once
    let mut peer = HostPeer::start(PEER, 37).await;
    peer.run("publisher /beacon/triggered").await;
    let mut w = radar
        .waiter::<Empty>(empty("/beacon/triggered"))
        .timeout(DISCOVERY)
        .await
        .unwrap();
    let t0 = Instant::now();
    peer.send("quit").await;
    let err = w.recv().timeout(DISCOVERY).await.unwrap_err();
    let took = t0.elapsed();
    println!("source exited: waitfor ended after {took:?}: {err}");
    match &err {
        Error::ComponentLost { departure, .. } => {
            assert_eq!(departure.component(), "/beacon");
            assert_eq!(departure.topic(), "/beacon/triggered");
            assert_eq!(departure.cause(), &LossCause::Left);
        }
        other => panic!("expected ComponentLost, got {other}"),
    }
    let text = err.to_string();
    assert!(
        text.contains("/beacon left the ROS graph") && text.contains("start it again"),
        "{text}"
    );
    assert!(took < Duration::from_secs(2), "took {took:?}");
    peer.wait().await;

    // SIGKILL: no goodbye; the lease runs out
    let mut peer = HostPeer::start(PEER, 37).await;
    peer.run("publisher /beacon/triggered").await;
    let w = radar
        .waitfor::<Empty>(empty("/beacon/triggered"))
        .timeout(Duration::from_secs(30));
    let waiting = tokio::spawn(async move { w.await });
    // arming is done when the connection is listed
    eventually(DISCOVERY, "the waiter armed", || {
        radar.connections().len() == 1
    })
    .await;
    let t0 = Instant::now();
    peer.signal("KILL");
    let err = waiting.await.unwrap().unwrap_err();
    let took = t0.elapsed();
    println!("source killed: waitfor ended after {took:?}: {err}");
    match &err {
        Error::ComponentLost { departure, .. } => {
            assert!(
                matches!(departure.cause(), LossCause::Unreachable { .. }),
                "{departure}"
            );
        }
        other => panic!("expected ComponentLost, got {other}"),
    }
    assert!(err.to_string().contains("/beacon is unreachable"), "{err}");
    assert!(
        took < Duration::from_secs(5),
        "within the 3 s lease: {took:?}"
    );
    assert!(radar.connections().is_empty(), "the waiter let go");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_signal_sent_just_before_the_component_exits_is_delivered_not_reported_lost() {
    let radar = radar(38);
    let rounds = 15;
    for round in 0..rounds {
        // its warnings (a flush that did not finish, say) are kept for the failure message
        let mut peer = HostPeer::start_logging(PEER, 38, "warn,rustdds=warn").await;
        peer.run("publisher /last/triggered").await;
        let mut w = radar
            .waiter::<Empty>(empty("/last/triggered"))
            .timeout(DISCOVERY)
            .await
            .unwrap();
        peer.send("emit-exit /last/triggered").await;
        let got = w.recv().timeout(DISCOVERY).await;
        let stderr = peer.stderr();
        let status = peer.wait().await;
        assert!(
            got.is_ok(),
            "round {round}: {:?}; the peer exited {status} and logged: {stderr:#?}",
            got.err()
        );
    }
}

/// `whenever /go/triggered start arm` (re-arming if asked), `arm` in a peer process, `/go` published here.
async fn go_starts_arm_in_a_peer(
    domain: u16,
    rearm: bool,
) -> (
    radar_ros::Radar,
    radar_ros::topics::SignalPublisher<Empty>,
    HostPeer,
    radar_ros::ConnectionGuard,
) {
    let radar = radar(domain);
    let go = radar.signal_publisher::<Empty>("/go/triggered").unwrap();
    let mut peer = HostPeer::start(PEER, domain).await;
    peer.run("response arm 0").await;
    let arm = radar.response("arm").timeout(DISCOVERY).await.unwrap();
    let mut request = radar.whenever(empty("/go/triggered")).start(&arm);
    if rearm {
        request = request.rearm();
    }
    let c = request.await.unwrap();
    (radar, go, peer, c)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_connection_whose_target_is_killed_is_lost_and_a_new_target_of_that_name_gets_nothing() {
    let (radar, go, peer, c) = go_starts_arm_in_a_peer(39, false).await;
    go.publish(Empty::default()).unwrap();
    eventually_state(&radar, "arm", "one start", |s| s.exits == 1).await;
    assert_eq!(c.link(), Some(Link::Armed));

    let t0 = Instant::now();
    peer.signal("KILL");
    let d = c
        .departed()
        .timeout(Duration::from_secs(10))
        .await
        .expect("a component left within 10 s")
        .expect("a whenever lives until dropped");
    let took = t0.elapsed();
    println!("target killed: connection lost after {took:?}: {d}");
    assert_eq!(d.component(), "/arm");
    assert!(matches!(d.cause(), LossCause::Unreachable { .. }), "{d}");
    assert!(took < Duration::from_secs(5), "took {took:?}");
    assert_eq!(c.link(), Some(Link::TargetLost));
    let listed = radar.connections();
    assert_eq!(listed.len(), 1);
    assert_eq!(listed[0].state, Connection::STATE_TARGET_LOST);
    assert_eq!(listed[0].state_label, "target lost");
    assert!(
        listed[0].departure.contains("/arm is unreachable"),
        "{}",
        listed[0].departure
    );

    // a new `arm` appears: this connection does not deliver to it
    let mut peer = HostPeer::start(PEER, 39).await;
    peer.run("response arm 0").await;
    let s = response_state(&radar, "arm").await;
    assert_eq!(s.starts, 0);
    go.publish(Empty::default()).unwrap();
    tokio::time::sleep(Duration::from_millis(500)).await;
    let s = response_state(&radar, "arm").await;
    assert_eq!(s.starts, 0, "a lost connection delivers nothing more");
    assert_eq!(c.link(), Some(Link::TargetLost));
    drop(c);
    assert!(radar.connections().is_empty());
    peer.send("quit").await;
    peer.wait().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_rearming_connection_delivers_to_the_new_target_only_what_comes_after_it() {
    let (radar, go, mut peer, c) = go_starts_arm_in_a_peer(47, true).await;
    // clean exit this time
    peer.send("quit").await;
    let d = c
        .departed()
        .timeout(DISCOVERY)
        .await
        .expect("a component left in time")
        .expect("departed");
    assert_eq!(d.cause(), &LossCause::Left);
    assert_eq!(c.link(), Some(Link::WaitingForTarget));
    assert_eq!(
        radar.connections()[0].state,
        Connection::STATE_WAITING_FOR_TARGET
    );
    peer.wait().await;
    // a signal while there is no target is dropped, not queued for the next one
    go.publish(Empty::default()).unwrap();

    let mut peer = HostPeer::start(PEER, 47).await;
    peer.run("response arm 0").await;
    eventually(DISCOVERY, "the connection re-armed", || {
        c.link() == Some(Link::Armed)
    })
    .await;
    assert!(c.departure().is_none());
    assert_eq!(radar.connections()[0].departure, "");
    let s = response_state(&radar, "arm").await;
    assert_eq!(s.starts, 0, "the signal sent while it waited was not kept");
    go.publish(Empty::default()).unwrap();
    eventually_state(&radar, "arm", "the new target runs", |s| s.exits == 1).await;
    peer.send("quit").await;
    peer.wait().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_until_window_closes_when_its_response_is_killed() {
    let radar = radar(48);
    let go = radar.signal_publisher::<Empty>("/go/triggered").unwrap();
    let stop = radar.signal_publisher::<Empty>("/stop/triggered").unwrap();
    let mut peer = HostPeer::start(PEER, 48).await;
    peer.run("response nav 60000").await;
    let nav = radar.response("nav").timeout(DISCOVERY).await.unwrap();
    let c = radar
        .once(empty("/go/triggered"))
        .start(&nav)
        .until(empty("/stop/triggered"))
        .await
        .unwrap();
    go.publish(Empty::default()).unwrap();
    eventually_state(&radar, "nav", "running", |s| {
        s.state == ResponseState::STATE_RUNNING
    })
    .await;
    let t0 = Instant::now();
    peer.signal("KILL");
    let d = c
        .departed()
        .timeout(Duration::from_secs(10))
        .await
        .expect("a component left within 10 s")
        .expect("the until lives until dropped");
    println!(
        "until's response killed: window closed after {:?}: {d}",
        t0.elapsed()
    );
    assert_eq!(d.component(), "/nav");

    // a new `nav` runs, started by someone else: this statement's `until` must not interrupt it
    let mut peer = HostPeer::start(PEER, 48).await;
    peer.run("response nav 60000").await;
    radar
        .inject(nav.start_slot(), Empty::default())
        .timeout(DISCOVERY)
        .await
        .unwrap();
    eventually_state(&radar, "nav", "the new nav runs", |s| {
        s.state == ResponseState::STATE_RUNNING
    })
    .await;
    stop.publish(Empty::default()).unwrap();
    tokio::time::sleep(Duration::from_millis(500)).await;
    let s = response_state(&radar, "nav").await;
    assert_eq!(
        (s.state, s.interrupts, s.ignored_interrupts),
        (ResponseState::STATE_RUNNING, 0, 0),
        "the closed window sent nothing to the new nav"
    );
    drop(c);
    peer.send("quit").await;
    peer.wait().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_connection_waits_for_a_source_that_left_and_delivers_when_one_is_back() {
    let radar = radar(49);
    let mut peer = HostPeer::start(PEER, 49).await;
    peer.run("publisher /bell/triggered").await;
    let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel();
    let c = radar
        .whenever(empty("/bell/triggered"))
        .call(move |_: Empty| {
            let _ = tx.send(());
        })
        .await
        .unwrap();
    peer.run("emit /bell/triggered").await;
    rx.recv().timeout_or_panic(DISCOVERY).await.unwrap();
    peer.send("quit").await;
    let d = c
        .departed()
        .timeout(DISCOVERY)
        .await
        .expect("a component left in time")
        .expect("departed");
    assert_eq!(d.component(), "/bell");
    assert_eq!(c.link(), Some(Link::WaitingForSource));
    assert_eq!(radar.connections()[0].state_label, "waiting for source");
    peer.wait().await;

    let mut peer = HostPeer::start(PEER, 49).await;
    peer.run("publisher /bell/triggered").await;
    eventually(DISCOVERY, "armed again", || c.link() == Some(Link::Armed)).await;
    peer.run("emit /bell/triggered").await;
    rx.recv().timeout_or_panic(DISCOVERY).await.unwrap();
    peer.send("quit").await;
    peer.wait().await;
}

/// `.timeout_or_panic(d)` on any future, for the waits of these tests.
trait TimeoutOrPanic: std::future::Future + Sized {
    async fn timeout_or_panic(self, d: Duration) -> Self::Output {
        match tokio::time::timeout(d, self).await {
            Ok(v) => v,
            Err(_) => panic!("timed out after {d:?}"),
        }
    }
}
impl<F: std::future::Future> TimeoutOrPanic for F {}

/// RustDDS patch 6, seen from radar_ros: a participant caches every sample its readers got; a state
/// subscription made after a response was replaced shows the new response, not the old one's last state.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_new_state_subscription_shows_the_replacement_not_the_response_that_left() {
    let radar = radar(53);
    let host = |radar_ros_peer: radar_ros::Radar| {
        let h = radar_ros_peer
            .spawn_response(
                "x",
                radar_ros::FnResponse::new(|_: Empty| async { Ok(Empty::default()) }),
            )
            .unwrap();
        (radar_ros_peer, h)
    };
    let (first, h) = host(radar_test_util::radar(53));
    let start = radar.signal_publisher::<Empty>("/x/start").unwrap();
    start
        .wait_for_subscribers(1)
        .timeout(DISCOVERY)
        .await
        .unwrap();
    start.publish(Empty::default()).unwrap();
    eventually_state(&radar, "x", "the first x ran", |s| s.exits == 1).await;
    drop(h);
    drop(first);
    start
        .wait_for_no_subscribers()
        .timeout(DISCOVERY)
        .await
        .unwrap();
    let (_second, _h) = host(radar_test_util::radar(53));
    start
        .wait_for_subscribers(1)
        .timeout(DISCOVERY)
        .await
        .unwrap();
    let s = response_state(&radar, "x").await;
    assert_eq!(
        (s.starts, s.exits),
        (0, 0),
        "the new x has not run; {s:?} is the old x's last state"
    );
}

/// Issue 32: a program that owns `whenever tick start arm` in a standalone manager (made through
/// `RemoteManager`, which says the program is alive) and dies: the connection delivers nothing within a second
/// of its last beat, not for the DDS lease (3.6 s; about 20 s for an rclpy owner). Stopped (SIGSTOP) past that
/// bound, its connection is suspended, and delivers again once the owner continues; killed, it delivers nothing
/// and is gone when the lease runs out. The event and the response live here, the manager and the owner in
/// processes of their own. Domain 223.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_dead_owners_connection_stops_within_a_second_not_at_its_lease() {
    let radar = radar(223);
    let _tick = radar
        .spawn_event(
            "own_tick",
            radar_ros::TimerEvent::new(Duration::from_millis(50)),
        )
        .unwrap();
    let starts = std::sync::Arc::new(std::sync::Mutex::new(Vec::<Instant>::new()));
    let s = starts.clone();
    let _arm = radar
        .spawn_response(
            "own_arm",
            radar_ros::FnResponse::new(move |_: Empty| {
                s.lock().unwrap().push(Instant::now());
                async { Ok(Empty::default()) }
            }),
        )
        .unwrap();
    let between = |from: Instant, to: Instant| {
        starts
            .lock()
            .unwrap()
            .iter()
            .filter(|t| **t > from && **t < to)
            .count()
    };
    let mut m = HostPeer::start(PEER, 223).await;
    m.run("manager mgr").await;
    let mut d = HostPeer::start(PEER, 223).await;
    d.query("connect-remote /mgr /own_tick/triggered /own_arm/start")
        .await;
    eventually(DISCOVERY, "starts through the manager", || {
        starts.lock().unwrap().len() >= 3
    })
    .await;

    // stopped for 2.5 s (under the lease): suspended within a second, delivering again once continued
    d.signal("STOP");
    let stopped = Instant::now();
    tokio::time::sleep(Duration::from_millis(2500)).await;
    let suspended = between(stopped + Duration::from_secs(1), Instant::now());
    d.signal("CONT");
    let continued = Instant::now();
    assert_eq!(
        suspended, 0,
        "starts delivered for a stopped owner more than 1 s after it stopped"
    );
    eventually(DISCOVERY, "starts again once the owner continues", || {
        between(continued, Instant::now()) >= 3
    })
    .await;

    // killed: nothing from a second after its death on, and the connection gone at the lease
    d.signal("KILL");
    let killed = Instant::now();
    tokio::time::sleep(Duration::from_millis(2500)).await;
    let late = between(killed + Duration::from_secs(1), Instant::now());
    assert_eq!(
        late, 0,
        "starts delivered for a killed owner more than 1 s after its death"
    );
    let client = radar_test_util::ManagerClient::new(&radar, "/mgr", "owner_check").await;
    radar_test_util::eventually_async(
        Duration::from_secs(8),
        "the connection gone at the lease",
        || {
            let c = &client;
            async move {
                radar_test_util::call_once(&c.list, Default::default(), DISCOVERY)
                    .await
                    .connections
                    .is_empty()
            }
        },
    )
    .await;
}

/// Issue 32: a target killed and started again at once (launch's `respawn=True`), within its lease: the old
/// process's endpoints are still matched when the new one's match, so the counts never reach zero. The new
/// process writing `arm/state` tells the manager the old one is gone: the plain connection is lost naming
/// the replacement, well before the lease would have said so, and a re-arming one delivers to the new `arm`.
/// (Before: neither connection noticed; the plain one delivered to the new process as if nothing happened,
/// then lost it when the old one's lease ran out.) Domain 224.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_target_respawned_within_its_lease_is_seen_replaced() {
    let (radar, go, peer, plain) = go_starts_arm_in_a_peer(224, false).await;
    let arm = radar.response("arm").timeout(DISCOVERY).await.unwrap();
    let rearming = radar
        .whenever(empty("/go/triggered"))
        .start(&arm)
        .rearm()
        .await
        .unwrap();
    go.publish(Empty::default()).unwrap();
    eventually_state(&radar, "arm", "a start", |s| s.exits >= 1).await;

    peer.signal("KILL");
    let killed = Instant::now();
    let mut respawned = HostPeer::start(PEER, 224).await;
    respawned.run("response arm 0").await;
    println!("respawned {:?} after the kill", killed.elapsed());
    let d = plain
        .departed()
        .timeout(Duration::from_secs(10))
        .await
        .expect("the old arm seen gone within 10 s")
        .expect("a whenever lives until dropped");
    let took = killed.elapsed();
    println!("respawned target: the plain connection lost after {took:?}: {d}");
    assert!(
        matches!(d.cause(), LossCause::Replaced),
        "seen as replaced by the new process, not at the lease: {d}"
    );
    assert_eq!(plain.link(), Some(Link::TargetLost));
    eventually(DISCOVERY, "the re-arming connection armed again", || {
        rearming.link() == Some(Link::Armed)
    })
    .await;
    // what comes from now on goes through the re-arming connection only
    let (plain_before, rearming_before) = (plain.delivered(), rearming.delivered());
    go.publish(Empty::default()).unwrap();
    eventually(DISCOVERY, "the re-arming connection delivers", || {
        rearming.delivered() > rearming_before
    })
    .await;
    assert_eq!(
        plain.delivered(),
        plain_before,
        "the lost connection delivers nothing more"
    );
    respawned.send("quit").await;
    respawned.wait().await;
}

/// The `count_up` program built beside the tests.
fn count_up_example() -> std::path::PathBuf {
    radar_ros_examples::test_support::examples_dir("count_up").join("count_up")
}

/// Issue 69 (rule C5): the README's `count_up` started twice on one domain, 1 s apart (two terminals; a laptop
/// beside the robot running the same launch file). Each program keeps its own statement and its count_up runs
/// Listing 1; neither takes the other's components as a respawn of its own (before: both warned that its
/// components were "started again ... the old one is taken as gone", both dropped their statement, and neither
/// count_up ever started). Each warns once per component that it runs in two live processes, naming both.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn two_live_programs_of_one_name_each_keep_their_connections() {
    radar_test_util::require_isolation();
    let run = |duration: &str| {
        tokio::process::Command::new(count_up_example())
            .args(["--duration", duration])
            .env("ROS_DOMAIN_ID", "126")
            .env("RUST_LOG", "warn")
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .kill_on_drop(true)
            .spawn()
            .expect("count_up runs")
    };
    let first = run("7");
    tokio::time::sleep(Duration::from_secs(1)).await;
    let second = run("6");
    let (a, b) = tokio::join!(first.wait_with_output(), second.wait_with_output());
    for (who, out) in [("first", a.unwrap()), ("second", b.unwrap())] {
        let (stdout, stderr) = (
            String::from_utf8_lossy(&out.stdout).into_owned(),
            String::from_utf8_lossy(&out.stderr).into_owned(),
        );
        assert!(out.status.success(), "{who}: {stdout}\n{stderr}");
        for line in [
            "count_up started",
            "count_up counts 1",
            "count_up interrupted",
        ] {
            assert!(
                stdout.contains(line),
                "{who} has no `{line}`:\n{stdout}\n{stderr}"
            );
        }
        for wrong in [
            "taken as gone",
            "delivers nothing more",
            "is gone (respawned?)",
        ] {
            assert!(!stderr.contains(wrong), "{who} says `{wrong}`:\n{stderr}");
        }
        assert!(
            stderr.contains("/count_up runs in two live processes, process ")
                && stderr.matches("on this host").count() >= 2,
            "{who} names both processes:\n{stderr}"
        );
    }
}
