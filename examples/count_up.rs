//! The paper's Listing 1, in one process:
//!
//! ```text
//! response CountUp:            event StartEvent:      event EndEvent:
//!   i = 0                        sleep (2 s)            sleep (4 s)
//!   while i < 10:                trigger                trigger
//!     sleep(0.5 s); i += 1
//!   interrupt                  def main:
//!   on exit: restart             once start_event start countUp until end_event
//! ```
//!
//! Every component is a real ROS 2 node on one DDS participant; signals travel over DDS topics
//! (`/start_event/triggered`, `/count_up/start`, ...). Until the connection manager exists, the `once ... until`
//! statement is wired here by hand with two small relays (see `once_start_until`): the `once` relay forwards the
//! first `triggered` of `start_event` to `count_up/start` and then unsubscribes (so `start_event` deactivates);
//! the `until` relay forwards `end_event` to `count_up/interrupt` only while a run that the statement started is
//! in progress (from its `started` to its `exited`). The restart asked for by CountUp's exit slot is CountUp's
//! own doing, not the statement's, so it is outside that window: after the interrupt at 4 s, CountUp restarts
//! and counts to 10 undisturbed.
//!
//! Run: `cargo run --example count_up` (`-- --duration 12` to change how long it runs; Ctrl-C stops it).

use std::{
    sync::{
        atomic::{AtomicBool, Ordering},
        Arc,
    },
    time::Duration,
};

use radar_ros::{msg::Empty, Event, ExitAction, ExitReason, Radar, Response, SlotError};
use radar_ros_examples::{init_logs, Timeline};

/// Lines 1-8: count to 10 at 0.5 s; interrupt does nothing; on exit, restart.
struct CountUp {
    tl: Timeline,
}

impl Response for CountUp {
    type Start = Empty;
    type Output = Empty;

    async fn start(&mut self, _: Empty) -> Result<Empty, SlotError> {
        let mut i = 0;
        while i < 10 {
            tokio::time::sleep(Duration::from_millis(500)).await;
            i += 1;
            self.tl.mark(&format!("count_up counts {i}"), None);
        }
        Ok(Empty::default())
    }

    async fn interrupt(&mut self) {}

    async fn exit(&mut self, why: ExitReason) -> ExitAction {
        self.tl
            .mark(&format!("count_up exit slot ({})", why.describe()), None);
        ExitAction::Restart
    }
}

/// Lines 10-12 and 14-16: sleep, then trigger.
struct SleepThenTrigger(Duration);

impl Event for SleepThenTrigger {
    type Payload = Empty;
    async fn check(&mut self) -> Result<Empty, SlotError> {
        tokio::time::sleep(self.0).await;
        Ok(Empty::default())
    }
}

/// `once start_event start count_up until end_event`, by hand (see the module docs).
async fn once_start_until(radar: Radar, tl: Timeline) -> radar_ros::Result<()> {
    let t = Duration::from_secs(5);
    let started = radar.signal_subscription::<Empty>("/count_up/started")?;
    let exited = radar.signal_subscription::<Empty>("/count_up/exited")?;
    let start = radar.signal_publisher::<Empty>("/count_up/start")?;
    let interrupt = radar.signal_publisher::<Empty>("/count_up/interrupt")?;
    let until = radar.signal_subscription::<Empty>("/end_event/triggered")?;
    let once = radar.signal_subscription::<Empty>("/start_event/triggered")?;
    for w in [&start, &interrupt] {
        w.wait_for_subscribers(1, t).await?;
    }
    for r in [&started, &exited, &until, &once] {
        r.wait_for_publishers(1, t).await?;
    }
    // the statement has returned: both events are active from here
    let in_window = Arc::new(AtomicBool::new(false));
    let window = in_window.clone();
    let until_relay = async move {
        loop {
            until.recv().await?;
            tl.mark("end_event triggered", None);
            if window.load(Ordering::SeqCst) {
                interrupt.publish(Empty::default())?;
            }
        }
        #[allow(unreachable_code)]
        Ok::<(), radar_ros::Error>(())
    };
    let once_relay = async {
        once.recv().await?;
        tl.mark("start_event triggered", Some(2.0));
        drop(once); // once: the connection goes away, and start_event deactivates
        start.publish(Empty::default())?;
        started.recv().await?;
        in_window.store(true, Ordering::SeqCst);
        exited.recv().await?;
        in_window.store(false, Ordering::SeqCst);
        std::future::pending::<radar_ros::Result<()>>().await
    };
    tokio::try_join!(until_relay, once_relay).map(|_| ())
}

/// Prints every activation change of an event.
async fn watch_event(tl: Timeline, event: radar_ros::EventHandle) {
    let mut state = event.watch_state();
    let mut last = None;
    loop {
        let st = state.borrow_and_update().clone();
        if last != Some(st.active) {
            last = Some(st.active);
            let word = if st.active {
                "active (checking)"
            } else {
                "inactive"
            };
            tl.mark(&format!("{} {word}", st.name.trim_start_matches('/')), None);
        }
        if state.changed().await.is_err() {
            return;
        }
    }
}

/// Prints every signal of count_up.
async fn watch_count_up(radar: Radar, tl: Timeline) -> radar_ros::Result<()> {
    let started = radar.signal_subscription::<Empty>("/count_up/started")?;
    let interrupted = radar.signal_subscription::<Empty>("/count_up/interrupted")?;
    let exited = radar.signal_subscription::<Empty>("/count_up/exited")?;
    let mut n_started = 0;
    loop {
        tokio::select! {
            r = started.recv() => {
                r?;
                n_started += 1;
                let listing = match n_started { 1 => Some(2.0), 2 => Some(4.0), 3 => Some(9.0), _ => None };
                tl.mark("count_up started", listing);
            }
            r = interrupted.recv() => { r?; tl.mark("count_up interrupted", Some(4.0)); }
            r = exited.recv() => { r?; tl.mark("count_up exited", None); }
        }
    }
}

#[tokio::main]
async fn main() {
    init_logs();
    let duration = std::env::args()
        .skip_while(|a| a != "--duration")
        .nth(1)
        .map(|s| s.parse::<f64>().expect("--duration SECONDS"))
        .unwrap_or(12.0);
    if let Err(e) = run(duration).await {
        eprintln!("count_up: {e}");
        std::process::exit(1);
    }
}

async fn run(duration: f64) -> radar_ros::Result<()> {
    let radar = Radar::new()?;
    println!(
        "Listing 1 (count_up) on ROS 2 domain {}; every component is a node on one DDS participant",
        radar.domain_id()
    );
    // main begins: the listing's times count from here
    let tl = Timeline::start();
    let count_up = radar.spawn_response("count_up", CountUp { tl })?;
    let radar_w = radar.clone();
    let start_event = radar.spawn_event("start_event", SleepThenTrigger(Duration::from_secs(2)))?;
    let end_event = radar.spawn_event("end_event", SleepThenTrigger(Duration::from_secs(4)))?;
    let watchers = [
        tokio::spawn(watch_event(tl, start_event)),
        tokio::spawn(watch_event(tl, end_event)),
        tokio::spawn(async move {
            if let Err(e) = watch_count_up(radar_w, tl).await {
                eprintln!("watcher: {e}");
            }
        }),
    ];
    tl.mark("once start_event start count_up until end_event", Some(0.0));
    let statement = tokio::spawn(once_start_until(radar.clone(), tl));
    tokio::select! {
        r = statement => r.expect("statement task")?,
        _ = tokio::time::sleep(Duration::from_secs_f64(duration)) => {}
        _ = tokio::signal::ctrl_c() => {}
    }
    for w in watchers {
        w.abort();
    }
    tl.mark(
        "done: shutting down (count_up's exit slot runs once more)",
        None,
    );
    count_up.shutdown().await;
    Ok(())
}
