//! Fault injection: an event, a response, a standalone manager and a deliberative program, each a process of
//! its own, while signals flow (the event triggers every 20 ms); one of them is killed (SIGKILL) or stopped
//! (SIGSTOP, then SIGCONT after 1 s, shorter than the 3 s lease, or 5 s, longer) at a random moment. What is
//! checked on the wire, from a separate observer:
//!
//! - a `once` delivers exactly one signal (it fires before the fault), and never one emitted before it was
//!   armed;
//! - every `started` of a live response is followed by its `exited` (a killed or stopped response may owe
//!   the one of the run it was in);
//! - what the fault makes of the connection, within the lease bound: the manager drops the connections of a
//!   deliberative program that died, shows `waiting for source` when the event died and `target lost` when
//!   the response died; an event whose listeners all died stops checking; a process stopped for less than
//!   the lease changes nothing;
//! - no surviving process panics or logs an error, and none keeps a connection its owner no longer holds.
//!
//! Every round prints its seed. `RADAR_FAULT_ROUNDS` (default 4: each victim once; 12 rounds cover every
//! victim with every fault) and `RADAR_SEED` (the moments of the faults) choose the rounds; the soak in
//! tests/README.md runs many. Domains 58-59.

use std::{
    sync::{Arc, Mutex},
    time::{Duration, Instant},
};

use radar_ros::msg::{Connection, Empty, EventState, Int64};
use radar_test_util::{eventually_async, radar, HostPeer, ManagerClient, Rng, DISCOVERY};

const PEER: &str = env!("CARGO_BIN_EXE_radar_test_peer");
const DOMAIN: u16 = 58;
const LOG: &str = "warn,rustdds=error,ros2_client=error";
/// How long a consequence of a fault may take: the 3 s lease, its 0.6 s check, the 100 ms grace, margin.
const BOUND: Duration = Duration::from_secs(6);

#[derive(Clone, Copy, Debug, PartialEq)]
enum Victim {
    Event,
    Response,
    Manager,
    Deliberative,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Fault {
    Kill,
    /// SIGSTOP for this long, then SIGCONT.
    Stop(Duration),
}

impl Fault {
    /// Whether its peers lose it (its lease runs out).
    fn loses(self) -> bool {
        match self {
            Fault::Kill => true,
            Fault::Stop(d) => d > radar_ros::settings::DEFAULT_LEASE + Duration::from_secs(1),
        }
    }
}

/// What the observer saw.
#[derive(Default)]
struct Seen {
    arm_started: u64,
    arm_exited: u64,
    /// Payloads (emission times of the event's signals) that started `q`.
    q_started: Vec<i64>,
    tick: Option<EventState>,
}

async fn connections(client: &ManagerClient) -> Vec<Connection> {
    radar_test_util::call_once(&client.list, Default::default(), DISCOVERY)
        .await
        .connections
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn faults_during_signal_bursts_keep_the_invariants() {
    let rounds: u64 = std::env::var("RADAR_FAULT_ROUNDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(4);
    let seed: u64 = std::env::var("RADAR_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(20261122);
    let observer = radar(DOMAIN);
    for round in 0..rounds {
        let mut rng = Rng((seed ^ (round + 1).wrapping_mul(0x9e37_79b9_7f4a_7c15)) | 1);
        let victim = [
            Victim::Event,
            Victim::Response,
            Victim::Manager,
            Victim::Deliberative,
        ][(round % 4) as usize];
        // every (victim, fault) pair once in 12 rounds; the seed picks the moments
        let fault = match (round + round / 4) % 3 {
            0 => Fault::Stop(Duration::from_secs(5)),
            1 => Fault::Kill,
            _ => Fault::Stop(Duration::from_secs(1)),
        };
        let at = Duration::from_millis(100 + rng.next_u64() % 700);
        println!(
            "round {round} (RADAR_SEED={seed}, RADAR_FAULT_ROUNDS={}): {victim:?} {fault:?} at {at:?}",
            round + 1
        );
        one_round(&observer, victim, fault, at).await;
    }
}

async fn one_round(observer: &radar_ros::Radar, victim: Victim, fault: Fault, at: Duration) {
    let mut e = HostPeer::start_logging(PEER, DOMAIN, LOG).await;
    let mut r = HostPeer::start_logging(PEER, DOMAIN, LOG).await;
    let mut m = HostPeer::start_logging(PEER, DOMAIN, LOG).await;
    let mut d = HostPeer::start_logging(PEER, DOMAIN, LOG).await;
    e.run("event tick 20").await;
    r.run("response arm 150").await;
    r.run("echo-i64 q").await;
    m.run("manager mgr").await;

    // the observer, from before anything flows
    let seen = Arc::new(Mutex::new(Seen::default()));
    let started = observer
        .signal_subscription::<Empty>("/arm/started")
        .unwrap();
    let exited = observer
        .signal_subscription::<Empty>("/arm/exited")
        .unwrap();
    let q_started = observer.signal_subscription::<Int64>("/q/started").unwrap();
    let tick = observer
        .state_subscription::<EventState>("/tick/state")
        .unwrap();
    for s in [&started, &exited] {
        s.wait_for_publishers(1).timeout(DISCOVERY).await.unwrap();
    }
    q_started
        .wait_for_publishers(1)
        .timeout(DISCOVERY)
        .await
        .unwrap();
    // and the responses' writers have matched the observer's readers (nothing is sent to a reader a writer
    // has not matched); `wait-peers` waits for a subscriber on each signal, so the observer has one on each
    let _others: Vec<_> = ["/arm/interrupted", "/q/interrupted"]
        .iter()
        .map(|t| observer.signal_subscription::<Empty>(t).unwrap())
        .collect();
    let _q_exited = observer.signal_subscription::<Int64>("/q/exited").unwrap();
    r.run("wait-peers arm 0 1").await;
    r.run("wait-peers q 0 1").await;
    let recorder = {
        let seen = seen.clone();
        tokio::spawn(async move {
            loop {
                tokio::select! {
                    Ok(_) = started.recv() => seen.lock().unwrap().arm_started += 1,
                    Ok(_) = exited.recv() => seen.lock().unwrap().arm_exited += 1,
                    Ok(p) = q_started.recv() => seen.lock().unwrap().q_started.push(p.data),
                    Ok(s) = tick.recv() => seen.lock().unwrap().tick = Some(s),
                }
            }
        })
    };
    let client = ManagerClient::new(observer, "/mgr", "observer").await;

    // the deliberative program: a whenever through the manager, and an embedded once
    d.query("connect-via /mgr /tick/triggered /arm/start").await;
    let before = d.query("once /tick/triggered q").await;
    let before_ns: i64 = before[0]
        .strip_prefix("before_ns ")
        .unwrap()
        .parse()
        .unwrap();
    eventually_async(BOUND, "the burst flows", || {
        let s = seen.clone();
        async move { s.lock().unwrap().arm_started >= 1 }
    })
    .await;
    // the event triggers every 20 ms and every process is up: the once fires before any fault
    eventually_async(BOUND, "the once delivers its signal", || {
        let s = seen.clone();
        async move { !s.lock().unwrap().q_started.is_empty() }
    })
    .await;

    // the fault
    tokio::time::sleep(at).await;
    let target = match victim {
        Victim::Event => &e,
        Victim::Response => &r,
        Victim::Manager => &m,
        Victim::Deliberative => &d,
    };
    let t_fault = Instant::now();
    match fault {
        Fault::Kill => target.signal("KILL"),
        Fault::Stop(_) => target.signal("STOP"),
    }

    // what it makes of the connection, while the victim is gone (or stopped)
    let tick_active =
        |seen: &Arc<Mutex<Seen>>| seen.lock().unwrap().tick.as_ref().is_some_and(|t| t.active);
    if fault.loses() {
        match victim {
            Victim::Deliberative => {
                let took = eventually_async(
                    BOUND,
                    "the manager drops the dead program's connection",
                    || {
                        let c = &client;
                        async move { connections(c).await.is_empty() }
                    },
                )
                .await;
                println!(
                    "  its connection dropped after {:?}",
                    t_fault.elapsed().max(took)
                );
                let took = eventually_async(BOUND, "the event stops checking", || {
                    let s = seen.clone();
                    async move { !tick_active(&s) }
                })
                .await;
                println!("  event inactive after {took:?}");
            }
            Victim::Manager => {
                let took = eventually_async(BOUND, "the event stops checking", || {
                    let s = seen.clone();
                    async move { !tick_active(&s) }
                })
                .await;
                println!("  event inactive after {took:?}");
            }
            Victim::Event => {
                let took = eventually_async(BOUND, "the connection waits for its source", || {
                    let c = &client;
                    async move {
                        connections(c).await.first().map(|c| c.state)
                            == Some(Connection::STATE_WAITING_FOR_SOURCE)
                    }
                })
                .await;
                println!("  waiting for source after {took:?}");
            }
            Victim::Response => {
                let took = eventually_async(BOUND, "the connection's target is lost", || {
                    let c = &client;
                    async move {
                        connections(c).await.first().map(|c| c.state)
                            == Some(Connection::STATE_TARGET_LOST)
                    }
                })
                .await;
                let listed = connections(&client).await;
                assert!(
                    listed[0].departure.contains("/arm is unreachable"),
                    "{}",
                    listed[0].departure
                );
                println!("  target lost after {took:?}");
            }
        }
    }
    if let Fault::Stop(d) = fault {
        tokio::time::sleep(d.saturating_sub(t_fault.elapsed())).await;
        target.signal("CONT");
        let t_cont = Instant::now();
        // back: a stopped event is a source again; a stop shorter than the lease changed nothing
        match (victim, fault.loses()) {
            (Victim::Event, _)
            | (Victim::Response | Victim::Manager | Victim::Deliberative, false) => {
                if victim != Victim::Manager {
                    let took = eventually_async(BOUND, "the connection is armed", || {
                        let c = &client;
                        async move {
                            connections(c).await.first().map(|c| c.state)
                                == Some(Connection::STATE_ARMED)
                        }
                    })
                    .await;
                    println!("  armed again {took:?} after SIGCONT");
                }
                let n = seen.lock().unwrap().arm_started;
                eventually_async(BOUND, "signals flow again", || {
                    let s = seen.clone();
                    async move { s.lock().unwrap().arm_started > n }
                })
                .await;
            }
            (Victim::Response, true) => {
                // the response is back, but the connection stays lost (it did not ask to re-arm)
                tokio::time::sleep(Duration::from_millis(500)).await;
                let listed = connections(&client).await;
                assert_eq!(listed[0].state, Connection::STATE_TARGET_LOST, "{listed:?}");
            }
            _ => {}
        }
        println!("  checked {:?} after SIGCONT", t_cont.elapsed());
    }

    // survivors: alive, no panic, no error line; the deliberative program leaves and takes its connection
    let dead = |p: Victim| p == victim && fault == Fault::Kill;
    for (who, p) in [
        (Victim::Event, &mut e),
        (Victim::Response, &mut r),
        (Victim::Manager, &mut m),
        (Victim::Deliberative, &mut d),
    ] {
        if dead(who) {
            continue;
        }
        p.query("malformed").await; // answers: alive
        let bad: Vec<String> = p
            .stderr()
            .into_iter()
            .filter(|l| l.contains("panicked") || l.contains("ERROR"))
            .collect();
        assert!(bad.is_empty(), "{who:?}: {bad:#?}");
    }
    let mut d_left = false;
    // the manager must be there to answer, and the program alive to leave
    let manager_there = !(dead(Victim::Manager) || victim == Victim::Manager && fault.loses());
    if manager_there && !dead(Victim::Deliberative) {
        d.send("quit").await;
        d_left = true;
        eventually_async(BOUND, "no connection outlives its owner", || {
            let c = &client;
            async move { connections(c).await.is_empty() }
        })
        .await;
    }
    // the invariants
    tokio::time::sleep(Duration::from_millis(400)).await; // the flow has stopped: a run in progress ends
    {
        let s = seen.lock().unwrap();
        // exactly one: it fired before the fault (above), and nothing after it may deliver again
        assert_eq!(
            s.q_started.len(),
            1,
            "a once delivered {} signals",
            s.q_started.len()
        );
        if let Some(&emitted) = s.q_started.first() {
            assert!(
                emitted >= before_ns,
                "the once delivered a signal emitted {} ms before it was armed",
                (before_ns - emitted) / 1_000_000
            );
        }
        let owed = u64::from(victim == Victim::Response);
        assert!(
            s.arm_exited + owed >= s.arm_started,
            "started {} exited {}: a live response owes no exited",
            s.arm_started,
            s.arm_exited
        );
        println!(
            "  arm started {} exited {}, q started {}",
            s.arm_started,
            s.arm_exited,
            s.q_started.len()
        );
    }
    recorder.abort();

    for (who, mut p) in [
        (Victim::Event, e),
        (Victim::Response, r),
        (Victim::Manager, m),
        (Victim::Deliberative, d),
    ] {
        if !dead(who) {
            if !(who == Victim::Deliberative && d_left) {
                p.send("quit").await;
            }
            p.wait().await; // leaves the graph cleanly
        }
    }
    // let the leases of killed peers run out before the next round reuses the names
    tokio::time::sleep(if fault == Fault::Kill {
        radar_ros::settings::DEFAULT_LEASE
    } else {
        Duration::from_millis(300)
    })
    .await;
}

/// A process stopped longer than the lease (a hang, a debugger, SIGSTOP) is declared lost by its peers, and
/// declares them lost when it continues; when they hear each other again, their endpoints are matched again
/// (RustDDS patch 13: they were kept aside and never matched again, so a publisher that hung for 5 s was
/// never heard from again). Domain 59.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_process_stopped_longer_than_the_lease_is_matched_again_when_it_continues() {
    let observer = radar(59);
    let mut e = HostPeer::start_logging(PEER, 59, LOG).await;
    e.run("publisher /p/triggered").await;
    let s = observer
        .signal_subscription::<Empty>("/p/triggered")
        .unwrap();
    s.wait_for_publishers(1).timeout(DISCOVERY).await.unwrap();
    e.signal("STOP");
    let t0 = Instant::now();
    eventually_async(BOUND, "the stopped publisher is lost", || {
        let n = s.publishers();
        async move { n == 0 }
    })
    .await;
    println!("stopped publisher lost after {:?}", t0.elapsed());
    tokio::time::sleep(Duration::from_secs(5).saturating_sub(t0.elapsed())).await;
    e.signal("CONT");
    let back = eventually_async(BOUND, "the publisher is matched again", || {
        let n = s.publishers();
        async move { n == 1 }
    })
    .await;
    println!("matched again {back:?} after SIGCONT");
    assert!(back < Duration::from_secs(5), "{back:?}");
    // and it delivers
    e.run("emit /p/triggered").await;
    s.recv().timeout(DISCOVERY).await.unwrap();
    let bad: Vec<String> = e
        .stderr()
        .into_iter()
        .filter(|l| l.contains("ERROR") || l.contains("panicked"))
        .collect();
    assert!(bad.is_empty(), "{bad:#?}");
    e.send("quit").await;
    e.wait().await;
}
