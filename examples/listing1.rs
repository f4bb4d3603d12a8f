//! The components and the statement of the paper's Listing 1, shared by the `count_up` example (all in one
//! process) and `count_up_nodes` (one process per component).

use std::{
    sync::{
        atomic::{AtomicBool, Ordering},
        Arc,
    },
    time::Duration,
};

use radar_ros::{
    msg::Empty, Event, EventHandle, ExitAction, ExitReason, Radar, Response, SignalPublisher,
    SignalSubscription, SlotError,
};

use crate::Timeline;

/// Lines 1-8: count to 10 at 0.5 s; the interrupt slot does nothing; on exit, restart.
pub struct CountUp {
    /// Where counts are printed.
    pub tl: Timeline,
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

/// Lines 10-12 (`StartEvent`, 2 s) and 14-16 (`EndEvent`, 4 s): sleep, then trigger.
pub struct SleepThenTrigger(pub Duration);

impl Event for SleepThenTrigger {
    type Payload = Empty;
    async fn check(&mut self) -> Result<Empty, SlotError> {
        tokio::time::sleep(self.0).await;
        Ok(Empty::default())
    }
}

/// Line 22, `once start_event start count_up until end_event`, wired by hand until the connection manager
/// exists: the `once` relay forwards the first `start_event/triggered` to `count_up/start` and then
/// unsubscribes (so `start_event` deactivates); the `until` relay forwards `end_event/triggered` to
/// `count_up/interrupt` only while a run that this statement started is in progress (its `started` to its
/// `exited`). A restart asked for by CountUp's own exit slot is outside that window.
pub struct OnceStartUntil {
    started: SignalSubscription<Empty>,
    exited: SignalSubscription<Empty>,
    start: SignalPublisher<Empty>,
    interrupt: SignalPublisher<Empty>,
    until: SignalSubscription<Empty>,
    once: SignalSubscription<Empty>,
}

impl OnceStartUntil {
    /// Makes the relays and waits until every one is matched with its component (discovery), up to `timeout`.
    pub async fn arm(radar: &Radar, timeout: Duration) -> radar_ros::Result<OnceStartUntil> {
        let s = OnceStartUntil {
            started: radar.signal_subscription("/count_up/started")?,
            exited: radar.signal_subscription("/count_up/exited")?,
            start: radar.signal_publisher("/count_up/start")?,
            interrupt: radar.signal_publisher("/count_up/interrupt")?,
            until: radar.signal_subscription("/end_event/triggered")?,
            once: radar.signal_subscription("/start_event/triggered")?,
        };
        for w in [&s.start, &s.interrupt] {
            w.wait_for_subscribers(1, timeout).await?;
        }
        for r in [&s.started, &s.exited, &s.until, &s.once] {
            r.wait_for_publishers(1, timeout).await?;
        }
        Ok(s)
    }

    /// Runs the statement's relays until an error.
    pub async fn run(self, tl: Timeline) -> radar_ros::Result<()> {
        let OnceStartUntil {
            started,
            exited,
            start,
            interrupt,
            until,
            once,
        } = self;
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
        let once_relay = async move {
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
}

/// Prints every activation change of an event hosted in this process.
pub async fn watch_event(tl: Timeline, event: EventHandle) {
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

/// Prints every signal of `count_up`, wherever it runs. Returns once subscribed (matching takes place in the
/// background); the returned future prints until an error.
pub fn watch_count_up(
    radar: &Radar,
    tl: Timeline,
) -> radar_ros::Result<impl std::future::Future<Output = radar_ros::Result<()>>> {
    let started = radar.signal_subscription::<Empty>("/count_up/started")?;
    let interrupted = radar.signal_subscription::<Empty>("/count_up/interrupted")?;
    let exited = radar.signal_subscription::<Empty>("/count_up/exited")?;
    Ok(async move {
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
    })
}
