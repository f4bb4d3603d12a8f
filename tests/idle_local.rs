//! A program whose statements connect its own components costs nothing on the network while nothing happens.
//! Its connections' readers are matched with its events' writers, which feed them through the in-process tap
//! and send them nothing over DDS (RustDDS patch 62); such a reader used to ask its writer for a HEARTBEAT
//! every second for as long as both lived (one datagram per connection per second, and the event loop's
//! wake-ups: 1.4-1.7% of a core for 2,000 connections settled), a writer that never answers. RustDDS patch 68.
//!
//! Counted on the UDP datagrams the test's network namespace sent (`/proc/self/net/snmp`): its own binary, one
//! test, so nothing else of the suite sends then (cargo runs test binaries one at a time). Domain 230.
//! Measured here: 60 datagrams in the 3 s window with the patch, 360 without it.

use std::{
    sync::{atomic::Ordering, Arc},
    time::Duration,
};

use radar_ros::{msg::Empty, Event, SlotError};
use radar_test_util::{counter, datagrams_sent, eventually, radar};
use tokio::sync::{mpsc, Mutex};

/// Connections of the program to its own components.
const CONNECTIONS: usize = 100;
/// How long the idle program is watched.
const WINDOW: Duration = Duration::from_secs(3);

/// An event that triggers once per message on its channel; without one, its condition never holds (it checks
/// while something listens, and never triggers).
struct Gate(Option<Arc<Mutex<mpsc::UnboundedReceiver<()>>>>);
impl Event for Gate {
    type Payload = Empty;
    async fn check(&mut self) -> Result<Empty, SlotError> {
        match &self.0 {
            Some(rx) => match rx.lock().await.recv().await {
                Some(()) => Ok(Empty::default()),
                None => std::future::pending().await,
            },
            None => std::future::pending().await,
        }
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn connections_to_components_of_this_process_send_nothing_while_idle() {
    let r = radar(230);
    let n = CONNECTIONS / 2;
    // event 0 can be made to trigger, once the idle program has been watched
    let (tx, rx) = mpsc::unbounded_channel();
    let mut rx = Some(Arc::new(Mutex::new(rx)));
    let events: Vec<_> = (0..n)
        .map(|i| {
            r.spawn_event(&format!("idle/ev_{i}"), Gate(rx.take()))
                .unwrap()
        })
        .collect();
    let (responses, runs): (Vec<_>, Vec<_>) = (0..n)
        .map(|i| counter(&r, &format!("idle/resp_{i}")))
        .unzip();
    // event i starts responses i and i + 1: every component in a statement, every event listened to
    let mut guards = Vec::new();
    for j in 0..CONNECTIONS {
        let (e, s) = (j % n, (j % n + j / n) % n);
        guards.push(
            r.whenever(events[e].triggered())
                .start(&responses[s])
                .await
                .unwrap(),
        );
    }
    assert!(
        events.iter().all(|e| e.state().active),
        "every event checks while its statements listen"
    );
    // what the new matches set going (first heartbeats, discovery's announcements of the new endpoints) is over
    // long before this (the scale benchmark settles 15 s for 2,000 components; 100 settle in well under one)
    tokio::time::sleep(Duration::from_secs(4)).await;
    let before = datagrams_sent();
    tokio::time::sleep(WINDOW).await;
    let sent = datagrams_sent() - before;
    eprintln!("idle_local: {sent} UDP datagrams in {WINDOW:?}");
    // what a settled program sends by itself (its participant's announcements every 0.6 s, the periodic
    // traffic of its discovery and state writers): about 60 in this window here. A datagram per connection
    // per second would be 300 more.
    assert!(
        sent < 150,
        "{sent} UDP datagrams in {WINDOW:?} from an idle program of {CONNECTIONS} connections to its own \
         components (each connection's reader asking its writer for a HEARTBEAT every second?)"
    );
    // and the connections still deliver: event 0 starts responses 0 and 1 (its two statements), no other
    tx.send(()).unwrap();
    eventually(
        Duration::from_secs(10),
        "responses 0 and 1 started by event 0",
        || runs[0].load(Ordering::SeqCst) == 1 && runs[1].load(Ordering::SeqCst) == 1,
    )
    .await;
    tokio::time::sleep(Duration::from_millis(200)).await;
    let started: Vec<u64> = runs.iter().map(|c| c.load(Ordering::SeqCst)).collect();
    assert_eq!(
        started.iter().sum::<u64>(),
        2,
        "runs per response: {started:?}"
    );
    drop(guards);
}
