//! A signal a component of this process emits to a connection of this process goes by the in-process tap
//! alone: the transport sends the connection's reader none of it (RustDDS patch 62), where it used to send
//! each one to its own participant, parse it, cache it and wake the reader's task, which dropped it. Whichever
//! is made first, the statement's reader or the event's writer. Its own binary: the transport's probe
//! (`RUSTDDS_PROBE_TOPIC`), read once per process, is set before any participant is made.

use std::{
    sync::{atomic::Ordering, Arc},
    time::Duration,
};

use radar_ros::{msg::Empty, Event, Signal, SlotError};
use radar_test_util::{counter, eventually, radar};
use tokio::sync::{mpsc, Mutex};

const T: Duration = Duration::from_secs(10);
/// The probed topic's suffix (the probe stamps every sample of a DDS topic whose name ends with it).
const PROBED: &str = "/tapped_e/triggered";

/// Triggers once per message on its channel.
struct Fed(Arc<Mutex<mpsc::UnboundedReceiver<()>>>);
impl Event for Fed {
    type Payload = Empty;
    async fn check(&mut self) -> Result<Empty, SlotError> {
        match self.0.lock().await.recv().await {
            Some(()) => Ok(Empty::default()),
            None => std::future::pending().await,
        }
    }
}

/// The probe's stamps of `stage` so far (all of them are of the probed topic).
fn stamped(
    stamps: &[ros2_client::dds::rustdds::probe::Stamp],
    stage: ros2_client::dds::rustdds::probe::Stage,
) -> usize {
    stamps.iter().filter(|s| s.stage == stage).count()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_signal_to_a_connection_of_this_process_goes_by_the_tap_alone() {
    // before any participant, so that the probe is on for this process
    std::env::set_var("RUSTDDS_PROBE_TOPIC", PROBED);
    let r = radar(121);
    let (resp, runs) = counter(&r, "tapped_r");
    let (tx, rx) = mpsc::unbounded_channel();
    let rx = Arc::new(Mutex::new(rx));
    let mut stamps = Vec::new();
    for round in 0..2 {
        let signal = Signal::new(PROBED, "std_msgs/msg/Empty");
        // round 0: the event first, then the statement; round 1: the statement arms before the event is made
        let (ev, c) = if round == 0 {
            let ev = r.spawn_event("tapped_e", Fed(rx.clone())).unwrap();
            (ev, r.whenever(signal).start(&resp).await.unwrap())
        } else {
            let arming = r.whenever(signal).start(&resp);
            let spawning = async {
                tokio::time::sleep(Duration::from_millis(50)).await;
                r.spawn_event("tapped_e", Fed(rx.clone())).unwrap()
            };
            let (c, ev) = tokio::join!(arming, spawning);
            (ev, c.unwrap())
        };
        for i in 0..30 {
            let before = runs.load(Ordering::SeqCst);
            tx.send(()).unwrap();
            eventually(T, &format!("round {round}: run {i}"), || {
                runs.load(Ordering::SeqCst) == before + 1
            })
            .await;
        }
        drop(c);
        drop(ev);
        // what the event loop may still do with the last samples (it does nothing with them)
        tokio::time::sleep(Duration::from_millis(200)).await;
        stamps.extend(ros2_client::dds::rustdds::probe::drain());
        let written = stamped(&stamps, ros2_client::dds::rustdds::probe::Stage::Write);
        assert!(
            written >= 30 * (round + 1),
            "round {round}: the probe saw {written} writes of the trigger (is it on?)"
        );
        let parsed = stamped(&stamps, ros2_client::dds::rustdds::probe::Stage::Parsed);
        let sent = stamped(&stamps, ros2_client::dds::rustdds::probe::Stage::SocketSent);
        assert_eq!(
            (sent, parsed),
            (0, 0),
            "round {round}: triggers sent to a socket and parsed by a reader of this process"
        );
    }
}
